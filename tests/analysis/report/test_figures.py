import pytest

from app.analysis import analyze
from app.analysis.report import figures
from app.analysis.simulate import simulate_votes


@pytest.fixture(scope="module")
def results():
    votes = simulate_votes({"a": 0.0, "b": 0.5, "c": 1.0}, participants=5, clips=("x", "y"))
    return analyze(votes, bootstrap=20)


def test_every_figure_draws(results):
    for fig in (
        figures.ballots_figure(results),
        figures.preference_bars_figure(results["pooled"]),
        figures.confusion_figure(results["pooled"]),
        figures.scale_figure(results),
        figures.consistence_figure(results),
    ):
        fig.canvas.draw()
        assert fig.axes


def test_preference_bars_show_fig9_counts(results):
    fig = figures.preference_bars_figure(results["pooled"])
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    tests = results["pooled"]["sign_tests"]
    assert sorted(labels) == sorted(f"{s['a']} vs {s['b']}" for s in tests)
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert any(t.startswith("p ") for t in texts)
    assert str(tests[0]["wins"]) in texts or tests[0]["wins"] == 0


def test_scale_interval_not_containing_its_estimate_is_drawn_as_given(results):
    # A percentile bootstrap interval can lie wholly on one side of the point estimate (seen with
    # a handful of votes); the figure must draw it, not fail on negative error-bar lengths.
    import copy

    skewed = copy.deepcopy(results)
    row = skewed["pooled"]["scale"][0]
    row["ci_low"], row["ci_high"] = row["score"] + 0.2, row["score"] + 0.9
    fig = figures.scale_figure(skewed)
    fig.canvas.draw()
    segments = [seg for coll in fig.axes[0].collections for seg in coll.get_segments()]
    spans = sorted(round(float(s[1][0] - s[0][0]), 6) for s in segments)
    assert 0.7 in spans


def test_count_axes_have_whole_ticks():
    import numpy as np

    few = analyze(simulate_votes({"a": 0.0, "b": 0.5}, participants=1, clips=("x",)), bootstrap=0)
    for fig in (figures.ballots_figure(few), figures.consistence_figure(few)):
        fig.canvas.draw()
        ticks = fig.axes[0].get_yticks()
        assert np.allclose(ticks, np.round(ticks)), ticks
