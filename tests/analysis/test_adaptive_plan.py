import numpy as np
import pytest

from app.analysis.adaptive_plan import (
    AdaptivePlan,
    _votes_to_reach,
    compare_designs,
    simulate_design,
)


def test_votes_to_reach_interpolates_between_checkpoints():
    curve = np.array([0.2, 0.5, 0.8, 0.9])
    assert _votes_to_reach(curve, 0.65, 8, higher=True) == pytest.approx(8 * 2.5)
    assert _votes_to_reach(curve, 0.95, 8, higher=True) is None
    assert _votes_to_reach(np.array([3.0, 2.0, 1.0]), 1.5, 4, higher=False) == pytest.approx(10)


@pytest.mark.parametrize("design", ["full", "adaptive"])
def test_simulated_scales_converge_to_the_truth(design):
    plan = AdaptivePlan(conditions=8, participants=4)
    rng = np.random.default_rng(3)
    curves = np.mean([simulate_design(plan, design, rng) for _ in range(4)], axis=0)
    assert curves.shape == (4 * 7, 3)
    tau, rho, width = curves.T
    assert tau[-1] > 0.8 and rho[-1] > 0.9
    assert tau[-1] > tau[0] and width[-1] < 0.6 * width[0]


def test_the_adaptive_design_reaches_the_full_designs_ranking_sooner():
    result = compare_designs(AdaptivePlan(conditions=8, participants=3, simulations=30), passes=2)
    for metric in ("kendall", "spearman"):
        row = result["reached"][metric]
        assert row["adaptive"] is not None and row["adaptive"] < row["full"]
