import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis.ratings import mixed_mos
from app.errors import InputError

MU = {"a": 2.0, "b": 3.0, "c": 3.0, "d": 4.0}


def _ratings(seed, participants=16, clips=4, sd_p=0.5, sd_k=0.3, noise=0.6):
    rng = np.random.default_rng(seed)
    u, v = rng.normal(0, sd_p, participants), rng.normal(0, sd_k, clips)
    rows = [
        (f"p{p}", f"s{k}", c, m + u[p] + v[k] + rng.normal(0, noise))
        for p in range(participants)
        for k in range(clips)
        for c, m in MU.items()
    ]
    return pd.DataFrame(rows, columns=["participant", "clip", "condition", "rating"])


def test_known_means_and_differences_are_recovered():
    covered, found, null_rejected = 0, 0, 0
    runs = 12
    for seed in range(runs):
        out = mixed_mos(_ratings(seed))
        assert out["converged"] and out["n"] == 16 * 4 * 4
        # the condition means' differences are estimated within participants and clips
        pairs = {(r["a"], r["b"]): r for r in out["contrasts"]}
        low, high = pairs[("a", "d")]["ci"]
        covered += low <= -2.0 <= high
        found += pairs[("a", "b")]["p_holm"] < 0.05
        null_rejected += pairs[("b", "c")]["p_holm"] < 0.05
        assert out["raw_mos"]["a"] == pytest.approx(
            out["mos"]["a"], abs=1e-9
        )  # balanced: the GLS mean is the plain mean
    assert covered >= 10 and found == runs and null_rejected <= 2


def test_its_variance_components_are_statsmodels_crossed_recipe():
    import statsmodels.formula.api as smf

    data = _ratings(5)
    out = mixed_mos(data)
    data["one"] = 1
    ref = smf.mixedlm(
        "rating ~ 0 + C(condition)",
        data,
        groups="one",
        vc_formula={"participant": "0 + C(participant)", "clip": "0 + C(clip)"},
    ).fit(reml=True)
    assert out["sd_participant"] == pytest.approx(np.sqrt(ref.vcomp[1]), rel=1e-3)
    assert out["sd_clip"] == pytest.approx(np.sqrt(ref.vcomp[0]), rel=1e-3)
    assert out["mos"]["d"] == pytest.approx(ref.fe_params.iloc[3], rel=1e-6)


def test_bad_tables_are_one_line():
    with pytest.raises(InputError, match="missing columns: clip"):
        mixed_mos(pd.DataFrame({"participant": [1], "condition": ["a"], "rating": [3.0]}))
    with pytest.raises(InputError, match="no ratings"):
        mixed_mos(_ratings(0), conditions=["zz"])


@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 3), st.integers(0, 2), st.sampled_from("abc"), st.floats(0, 100)),
        min_size=1,
        max_size=40,
    )
)
def test_any_table_of_ratings_gives_an_answer(rows):
    data = pd.DataFrame(rows, columns=["participant", "clip", "condition", "rating"])
    out = mixed_mos(data)
    assert set(out["mos"]) == set(data["condition"])
