import numpy as np
import pytest

from app.analysis.btd import JOD_PER_LOG_WORTH, fit_btd
from app.analysis.plan import StudyPlan, plan_from_pilot, plan_study, simulate_counts
from app.errors import InputError


def test_simulated_votes_follow_the_model():
    plan = StudyPlan(("a", "b", "c"), (0.0, 0.5, 1.0), gamma=1.5, nu=0.6)
    counts = simulate_counts(plan, 40, 200, np.random.default_rng(1))
    assert counts.shape == (200, 40, 3, 3, 3)
    assert (counts.sum(axis=(2, 3, 4)) == 6).all()  # one pass through the 6 ordered pairs
    pooled = counts.sum(axis=(0, 1))
    pi = np.exp(np.array(plan.jod) / JOD_PER_LOG_WORTH)
    for i, j in [(0, 1), (2, 0)]:
        w = np.array([1.5 * pi[i], pi[j], 0.6 * np.sqrt(pi[i] * pi[j])])
        assert pooled[i, j] / pooled[i, j].sum() == pytest.approx(w / w.sum(), abs=0.02)
    fit = fit_btd(pooled)
    assert fit.gamma == pytest.approx(1.5, rel=0.05) and fit.nu == pytest.approx(0.6, rel=0.05)


def test_unordered_design_balances_sides():
    plan = StudyPlan(("a", "b"), (0.0, 0.0), design="unordered", votes=3)
    counts = simulate_counts(plan, 50, 100, np.random.default_rng(2)).sum(axis=(0, 1, 4))
    assert counts.sum() == 15000
    assert counts[0, 1] / counts.sum() == pytest.approx(0.5, abs=0.03)


def test_power_is_alpha_without_effect_and_grows_with_participants():
    null = plan_study(StudyPlan(("a", "b"), (0.0, 0.0), votes=4), [30], simulations=1000)
    for test in ("wilcoxon", "sign_per_participant"):
        assert null["levels"][0]["power"][test]["a vs b"] <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / 1000)
    r = plan_study(StudyPlan(("a", "b", "c"), (0.0, 0.3, 0.6)), [10, 30, 60], simulations=400)
    power = [lv["power"]["wilcoxon"]["a vs c"] for lv in r["levels"]]
    widths = [lv["ci_width_jod"]["a"] for lv in r["levels"]]
    assert power[0] < power[1] < power[2]
    assert widths[0] > widths[1] > widths[2]
    # the interval width shrinks like 1 / sqrt(participants)
    assert widths[1] / widths[2] == pytest.approx(np.sqrt(2), rel=0.15)


def test_pilot_plan_uses_the_fitted_model():
    c = np.zeros((2, 2, 3))
    c[0, 1], c[1, 0] = [8, 1, 2], [2, 4, 2]
    plan = plan_from_pilot(c, ["a", "b"])
    half = np.log(2) * JOD_PER_LOG_WORTH
    assert plan.jod == pytest.approx((half, -half))
    assert plan.gamma == pytest.approx(2.0) and plan.nu == pytest.approx(1.0)
    c[1, 0] = [0, 0, 0]
    c[0, 1] = [5, 0, 0]
    with pytest.raises(InputError, match="no model to plan from"):
        plan_from_pilot(c, ["a", "b"])


@pytest.mark.parametrize(
    "plan, message",
    [
        (StudyPlan(("a",), (0.0,)), "at least two"),
        (StudyPlan(("a", "b"), (0.0, 1.0), votes=1), "do not reach every pair"),
        (StudyPlan(("a", "b"), (0.0, 1.0), nu=-1), "nu"),
        (StudyPlan(("a", "b"), (0.0, 1.0), design="other"), "expected one of"),
    ],
)
def test_bad_plans_are_refused(plan, message):
    with pytest.raises(InputError, match=message):
        plan_study(plan, [10], simulations=10)
