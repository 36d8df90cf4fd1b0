from hypothesis import given
from hypothesis import strategies as st

from app.stimuli.progress import progress_steps


@given(st.integers(min_value=0, max_value=50))
def test_each_step_reports_one_more_of_the_total(total):
    seen = []
    step = progress_steps(lambda done, n: seen.append((done, n)), total)
    for _ in range(total):
        step()
    assert seen == [(k, total) for k in range(1, total + 1)]


def test_steps_without_a_progress_callback_report_nothing():
    step = progress_steps(None, 3)
    step()
    step()


def test_two_jobs_count_apart():
    a, b = [], []
    step_a = progress_steps(lambda done, _: a.append(done), 2)
    step_b = progress_steps(lambda done, _: b.append(done), 2)
    step_a()
    step_b()
    step_a()
    assert a == [1, 2] and b == [1]
