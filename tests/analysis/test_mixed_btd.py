import warnings

import numpy as np
import pytest

from app.analysis.btd import fit_btd
from app.analysis.mixed_btd import fit_mixed_btd, mixed_btd_summary
from app.analysis.mixed_coverage import Truth, coverage, fixed_wald, simulate_counts


def _study(truth, participants, clips, seed):
    return simulate_counts(truth, participants, clips, np.random.default_rng(seed))


def test_a_large_study_recovers_its_effects():
    truth = Truth(theta=(-0.6, -0.1, 0.2, 0.5), gamma=1.3, nu=0.4, sd_participant=0.5, sd_clip=0.3)
    fit = fit_mixed_btd(_study(truth, 300, 12, 7))
    assert fit.converged
    np.testing.assert_allclose(fit.theta, np.array(truth.theta) - 0.0, atol=0.12)
    assert abs(fit.sd_participant - 0.5) < 0.08 and abs(fit.sd_clip - 0.3) < 0.12
    assert abs(fit.gamma - 1.3) < 0.08 and abs(fit.nu - 0.4) < 0.05
    assert np.all(fit.se > 0) and np.all(fit.se < 0.15)


def test_without_random_variation_it_is_the_fixed_model():
    truth = Truth(sd_participant=0.0, sd_clip=0.0)
    t = _study(truth, 60, 4, 2)
    fit = fit_mixed_btd(t)
    fixed = fit_btd(t.sum(axis=(0, 1)))
    assert fit.converged and fit.sd_participant < 0.1 and fit.sd_clip < 0.1
    np.testing.assert_allclose(fit.theta, fixed.theta, atol=0.03)
    assert abs(fit.gamma - fixed.gamma) < 0.02 and abs(fit.nu - fixed.nu) < 0.02


#: Twelve votes (participant, clip, left, right, outcome 0 left / 1 right / 2 undecided) on
#: which Schall's update for the clip variance crawls: its REML estimate is 0, reached only
#: after the update has shrunk by about 1e-5 per step for a hundred steps near sd 0.11.
CRAWL = [
    (0, 0, 0, 0, 0), (0, 0, 1, 0, 0), (0, 1, 0, 1, 0), (0, 1, 0, 3, 1), (0, 1, 2, 3, 0),
    (1, 1, 3, 0, 1), (2, 0, 1, 2, 0), (2, 0, 1, 3, 0), (2, 1, 0, 1, 0), (3, 0, 2, 0, 0),
    (4, 0, 0, 3, 2), (4, 1, 1, 3, 0),
]  # fmt: skip


def _tensor(votes, participants=5, clips=2, conditions=4):
    t = np.zeros((participants, clips, conditions, conditions, 3))
    for vote in votes:
        t[vote] += 1
    return t


def test_a_crawling_variance_is_followed_to_its_estimate():
    t = _tensor(CRAWL)
    tight = fit_mixed_btd(t, tol=1e-11, max_updates=6000)
    assert tight.converged and tight.sd_clip == 0.0
    # A stop on the step size alone reported sd 0.111 here.
    fit = fit_mixed_btd(t)
    assert fit.converged and fit.sd_clip == 0.0
    assert fit.sd_participant == pytest.approx(tight.sd_participant, rel=1e-5)
    np.testing.assert_allclose(fit.theta, tight.theta, atol=1e-5)


#: Twelve votes whose likelihood is nearly flat in the clip SD: the iteration stopped at sd
#: 0.16730 for one order of the participants and 0.16735 for another.
FLAT_IN_CLIP = [
    (0, 0, 0, 0, 0), (0, 0, 1, 0, 0), (0, 1, 0, 1, 0), (0, 1, 0, 3, 1), (0, 1, 2, 3, 0),
    (1, 1, 3, 0, 1), (2, 0, 1, 2, 0), (2, 1, 0, 1, 0), (2, 1, 1, 3, 0), (3, 0, 2, 0, 0),
    (4, 0, 0, 3, 2), (4, 1, 1, 3, 0),
]  # fmt: skip


@pytest.mark.parametrize("votes", [CRAWL, FLAT_IN_CLIP], ids=["crawl", "flat"])
def test_the_order_of_the_participants_changes_nothing(votes):
    t = _tensor(votes)
    first = fit_mixed_btd(t)
    for order in ([0, 2, 1, 3, 4], [4, 3, 2, 1, 0], [1, 0, 4, 2, 3]):
        other = fit_mixed_btd(t[order])
        assert other.converged and other.sd_clip == first.sd_clip
        assert other.sd_participant == first.sd_participant
        np.testing.assert_array_equal(other.theta, first.theta)
        np.testing.assert_array_equal(other.se, first.se)


def test_one_clip_has_no_clip_effect():
    fit = fit_mixed_btd(_study(Truth(), 40, 1, 4))
    assert fit.converged and np.isnan(fit.sd_clip) and fit.note == "one clip: no clip effect"


def test_a_condition_that_wins_everything_is_not_fitted():
    t = np.zeros((3, 2, 2, 2, 3))
    t[:, :, 0, 1, 0] = 2  # condition 0 on the left always chosen
    t[:, :, 1, 0, 1] = 2  # and on the right
    out = mixed_btd_summary(t, ["a", "b"])
    assert out["scores"] == {"a": None, "b": None} and "no finite" in out["note"]


def test_summary_reports_intervals_around_the_scores():
    out = mixed_btd_summary(_study(Truth(), 30, 6, 5), ["a", "b", "c", "d"])
    for c in "abcd":
        low, high = out["ci"][c]
        assert low < out["scores"][c] < high
        assert out["jod_ci"][c][0] == pytest.approx(low / np.log(3))
    assert out["gamma_ci"][0] < out["gamma"] < out["gamma_ci"][1]
    assert out["participants"] == 30 and out["clips"] == 6


def test_a_few_simulated_studies_land_near_the_truth():
    """A small version of the coverage study of docs/analysis.md (python -m
    app.analysis.mixed_coverage --studies 200): estimates near the truth, intervals that
    mostly hold it."""
    result = coverage(studies=6, participants=30, clips=8, seed=11)
    assert result["failed"] == 0
    np.testing.assert_allclose(result["mean_estimate"], result["truth"], atol=0.12)
    assert result["coverage_theta"] >= 0.75
    assert abs(result["mean_sd"][0] - 0.5) < 0.15


@pytest.mark.slow
def test_the_analysis_reports_it_beside_the_fixed_model(tmp_path):
    from app.analysis import analyze
    from app.analysis.report.blocks import Table
    from app.analysis.report.document import build_document
    from app.analysis.simulate import simulate_votes

    votes = simulate_votes({"a": -0.5, "b": 0.0, "c": 0.6}, participants=12, seed=3)
    r = analyze(votes, bootstrap=0)
    m = r["pooled"]["mixed_btd"]
    assert r["options"]["mixed_model"] and m["participants"] == 12 and m["clips"] == 2
    assert m["scores"]["a"] < m["scores"]["b"] < m["scores"]["c"]
    assert m["sd_participant"] is not None and m["estimator"].startswith("penalised")
    tables = [b for b in build_document(r) if isinstance(b, Table)]
    mixed = next(t for t in tables if t.caption.startswith("Table 9b"))
    assert [row[0] for row in mixed.rows] == ["a", "b", "c"]
    assert analyze(votes, bootstrap=0, mixed_model=False)["pooled"]["mixed_btd"] is None


def test_the_comparator_is_the_fixed_models_maximum_likelihood():
    t = _study(Truth(), 20, 3, 8)
    est, se, ok = fixed_wald(t)
    fixed = fit_btd(t.sum(axis=(0, 1)))
    assert ok
    np.testing.assert_allclose(est[:4], fixed.theta, atol=1e-5)
    np.testing.assert_allclose(np.exp(est[4:]), [fixed.gamma, fixed.nu], rtol=1e-5)
    assert np.all(se > 0)


def test_with_large_random_effects_only_the_mixed_intervals_hold_the_truth():
    result = coverage(
        Truth(sd_participant=1.0, sd_clip=0.6), studies=8, participants=30, clips=8, seed=2
    )
    assert result["coverage_theta"] >= 0.8
    assert result["fixed_coverage_theta"] < 0.6
    assert len(result["coverage_se"]) == len(result["parameters"])


def test_degenerate_votes_end_as_not_converged_without_warnings():
    # a single vote, or every vote for the left panel: the effects run off towards infinity
    # while the fit looks for a maximum; it must say so, not overflow or warn on the way
    one = np.zeros((2, 2, 3, 3, 3))
    one[0, 0, 1, 0, 1] = 1
    left = np.zeros((3, 2, 3, 3, 3))
    left[:, :, 0, 1, 0] = 4
    left[:, :, 1, 2, 0] = 3
    for t in (one, left):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            fit = fit_mixed_btd(t)
        assert not fit.converged and fit.note
