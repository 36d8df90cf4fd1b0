import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis.objective import (
    flatten_measures,
    measures_from_summaries,
    objective_to_perceptual,
    report_scores,
)


def _synthetic(seed, clips=6, conditions=5, slope=0.5, noise=0.2):
    """Scores = clip shift + slope * z(predictive) + noise; 'unrelated' is independent."""
    rng = np.random.default_rng(seed)
    measures, scores, raw = {}, {}, []
    for k in range(clips):
        for c in range(conditions):
            x = rng.normal(3.0, 2.0)
            raw.append(x)
            measures[(f"s{k}", f"c{c}")] = {"predictive": x, "unrelated": rng.normal()}
    z = (np.array(raw) - np.mean(raw)) / np.std(raw)
    for q, key in enumerate(measures):
        scores[key] = 2.0 * int(key[0][1:]) + slope * z[q] + rng.normal(0, noise)
    return measures, scores


def test_a_known_relation_is_recovered_with_its_uncertainty():
    hits = {"predictive": 0, "unrelated": 0}
    for seed in range(40):
        out = objective_to_perceptual(*_synthetic(seed))
        rows = {r["measure"]: r for r in out["measures"]}
        assert out["measures"][0]["measure"] == "predictive"
        assert rows["predictive"]["p_holm"] < 0.001
        for name, truth in (("predictive", 0.5), ("unrelated", 0.0)):
            low, high = rows[name]["ci"]
            hits[name] += low <= truth <= high
    # 95 % intervals: about 38 of 40 hold the truth
    assert hits["predictive"] >= 34 and hits["unrelated"] >= 34


def test_it_is_ordinary_least_squares_with_clip_intercepts():
    import statsmodels.api as sm

    measures, scores = _synthetic(3, noise=0.4)
    out = objective_to_perceptual(measures, scores)
    row = next(r for r in out["measures"] if r["measure"] == "unrelated")
    keys = list(measures)
    x = np.array([measures[k]["unrelated"] for k in keys])
    z = (x - x.mean()) / x.std()
    clips = sorted({k for k, _ in keys})
    dummies = np.array([[k == c for c in clips] for k, _ in keys], dtype=float)
    fit = sm.OLS(np.array([scores[k] for k in keys]), np.column_stack([z, dummies])).fit()
    assert row["slope"] == pytest.approx(fit.params[0])
    assert row["se"] == pytest.approx(fit.bse[0])
    assert row["p"] == pytest.approx(fit.pvalues[0])
    assert row["ci"] == pytest.approx(list(fit.conf_int()[0]))


def test_constant_and_scarce_measures_are_skipped():
    measures = {("s", c): {"flat": 1.0, "x": float(i)} for i, c in enumerate("abcd")}
    measures[("s", "a")]["only_here"] = 2.0
    scores = {("s", c): float(i) for i, c in enumerate("abcd")}
    scores[("s", "d")] = 0.0
    out = objective_to_perceptual(measures, scores)
    assert [r["measure"] for r in out["measures"]] == ["x"]
    assert set(out["skipped"]) == {"flat", "only_here"}


def test_summaries_and_report_scores_are_read():
    summary = {
        "conditions": {
            "none": {"measures": {"head": {"speed_mean_deg_s": 0.0}, "cc": [0.1]}},
            "gt": {"measures": {"head": {"speed_mean_deg_s": 9.0}, "cc": [0.4]}},
        }
    }
    cells = measures_from_summaries({"s1": summary})
    assert cells[("s1", "gt")] == {"head.speed_mean_deg_s": 9.0, "cc.0": 0.4}
    results = {"clips": {"s1": {"btd": {"jod": {"none": -0.5, "gt": None}}}}}
    assert report_scores(results) == {("s1", "none"): -0.5, ("s1", "gt"): None}


json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=3),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3)
    ),
    max_leaves=12,
)


@settings(max_examples=80, deadline=None)
@given(
    st.dictionaries(st.text(max_size=4), json_values, max_size=4),
    st.lists(st.floats(-5, 5), min_size=6, max_size=6),
)
def test_any_summary_json_gives_finite_rows_or_skips(raw, values):
    flat = flatten_measures(raw)
    assert all(np.isfinite(v) for v in flat.values())
    measures = {("s", str(i)): {k: v * (i + 1) for k, v in flat.items()} for i in range(6)}
    scores = {("s", str(i)): values[i] for i in range(6)}
    out = objective_to_perceptual(measures, scores)
    assert len(out["measures"]) + len(out["skipped"]) == len(flat)


def test_field_metrics_are_each_mesh_conditions_mean_over_its_clips():
    from app.analysis.objective import field_metrics

    measures = {
        ("s1", "ff"): {"mesh.lve_mm": 2.0, "mesh.fdd_mm": 0.5, "head.speed": 9.0},
        ("s2", "ff"): {"mesh.lve_mm": 4.0, "mesh.fdd_mm": -0.5},
        ("s1", "built_in"): {"head.speed": 3.0},
    }
    out = field_metrics(measures)
    assert out == {"ff": {"clips": 2, "lve_mm": 3.0, "fdd_mm": 0.0}}
