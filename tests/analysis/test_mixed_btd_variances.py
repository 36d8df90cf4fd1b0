import numpy as np
import pytest

from app.analysis.mixed_btd import _fixed_start, fit_mixed_btd, mixed_btd_summary
from app.analysis.mixed_btd_model import MixedBTDModel
from app.analysis.mixed_btd_variances import (
    CRAWL_VARIANCE,
    START_VARIANCES,
    _beyond_bound,
    moment_variances,
)
from app.analysis.mixed_coverage import Truth, simulate_counts


def _separated(votes):
    """Two participants always choose a, two always b, ``votes`` times on each side order."""
    t = np.zeros((4, 1, 2, 2, 3))
    t[:2, 0, 0, 1, 0] = t[:2, 0, 1, 0, 1] = votes
    t[2:, 0, 0, 1, 1] = t[2:, 0, 1, 0, 0] = votes
    return t


def test_a_variance_beyond_the_bound_ends_the_fit_at_once():
    """With 20 votes a side order, each participant's choice is certain: the participant SD's
    update from the bound still points beyond it (its estimate, with the bound raised, is
    5.2), so the fit says so after a few updates instead of circling the bound for 200
    cycles."""
    fit = fit_mixed_btd(_separated(20))
    assert not fit.converged
    assert fit.note == (
        "the fit did not converge (the participant SD grows beyond the fit's bound of 4.5 "
        "log-worth units)"
    )
    assert 0 < fit.iterations < 20


def test_a_large_variance_within_the_bound_is_still_estimated():
    """With 5 votes the penalised fit has a finite participant SD (3.85), below the bound."""
    fit = fit_mixed_btd(_separated(5))
    assert fit.converged and 3.5 < fit.sd_participant < 4.2
    assert fit.theta == pytest.approx([0.0, 0.0], abs=1e-9)


@pytest.mark.parametrize("seed", [22, 24])
def test_small_variances_settle_in_a_few_dozen_updates(seed):
    """Both SDs just above the 0.02 taken as 0: with one SQUAREM step length for the two
    variances, the jitter of the settled one held back the one crawling up from the cut-off,
    and these fits took 488 and 407 updates (a 60,000-vote study: 90-101 CPU seconds). With a
    step length per variance: a few dozen, and the same estimates."""
    truth = Truth(sd_participant=0.04, sd_clip=0.03)
    fit = fit_mixed_btd(simulate_counts(truth, 300, 6, np.random.default_rng(seed)))
    assert fit.converged and fit.settled and fit.iterations <= 60, fit.iterations
    assert {22: (0.0266, 0.0392), 24: (0.0386, 0.0496)}[seed] == pytest.approx(
        (fit.sd_participant, fit.sd_clip), abs=5e-4
    )


def test_the_updates_stop_at_their_cap_and_say_so():
    truth = Truth(sd_participant=0.04, sd_clip=0.03)
    t = simulate_counts(truth, 300, 6, np.random.default_rng(22))
    seen = []
    fit = fit_mixed_btd(t, max_updates=9, progress=lambda done, total: seen.append((done, total)))
    assert fit.iterations <= 9 and not fit.settled and fit.converged
    assert fit.note.startswith(f"stopped after {fit.iterations} variance updates (the cap)")
    assert np.all(np.isfinite(fit.theta)) and seen and seen[-1][1] == 9
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    summary = mixed_btd_summary(t, ["a", "b", "c", "d"][: t.shape[2]])
    assert summary["settled"] is True


def test_the_note_names_every_sd_beyond_the_bound():
    assert _beyond_bound(np.array([False, False])) is None
    assert _beyond_bound(np.array([False, True])) == (
        "the fit did not converge (the clip SD grows beyond the fit's bound of 4.5 log-worth units)"
    )
    assert _beyond_bound(np.array([True, True])) == (
        "the fit did not converge (the participant and clip SDs grow beyond the fit's bound "
        "of 4.5 log-worth units)"
    )


@pytest.mark.parametrize(("sd_participant", "sd_clip"), [(0.5, 0.3), (0.3, 0.15)])
def test_the_moment_start_lies_near_the_variances_it_estimates(sd_participant, sd_clip):
    """Moment estimates from the fixed model's terms land near the simulated variances (and
    so near the REML fit the updates reach from them)."""
    truth = Truth(sd_participant=sd_participant, sd_clip=sd_clip)
    t = simulate_counts(truth, 400, 12, np.random.default_rng(5)).astype(float)
    n = t.shape[2]
    t[:, :, np.arange(n), np.arange(n)] = 0.0
    model = MixedBTDModel(t)
    z = _fixed_start(model, t)
    start = moment_variances(model, model.terms(z, np.zeros((model.P, n))))
    fit = fit_mixed_btd(t)
    assert np.sqrt(start[0]) == pytest.approx(sd_participant, rel=0.25)
    assert np.sqrt(start[1]) == pytest.approx(sd_clip, rel=0.4)
    assert np.sqrt(start[0]) == pytest.approx(fit.sd_participant, rel=0.15)


def test_without_random_effects_the_moment_start_is_the_usual_one():
    """No participant or clip effect in the votes: the estimates fall at or below the cut-off
    and the updates start where they always did (the crawl towards 0 is probed as before)."""
    truth = Truth(sd_participant=0.0, sd_clip=0.0)
    t = simulate_counts(truth, 300, 6, np.random.default_rng(6)).astype(float)
    model = MixedBTDModel(t)
    z = _fixed_start(model, t)
    start = moment_variances(model, model.terms(z, np.zeros((model.P, model.n))))
    assert all(s in (START_VARIANCES[q], CRAWL_VARIANCE) for q, s in enumerate(start))
    fit = fit_mixed_btd(t)
    assert fit.converged and fit.sd_clip < 0.05
