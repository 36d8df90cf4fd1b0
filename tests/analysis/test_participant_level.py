import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import stats

from app.analysis import analyze, read_votes
from app.analysis.counts import count_votes
from app.analysis.participant_level import (
    bootstrap_rank_biserial,
    net_preference,
    one_judgement_per_participant,
    participant_level_tests,
    rank_biserial,
)
from app.analysis.ttest import holm

COLS = ["participant", "clip", "left", "right", "choice"]


def _tensor(rows, conditions=None):
    counts = count_votes(read_votes(pd.DataFrame(rows, columns=COLS)), conditions)
    return counts, counts.tensor.sum(axis=1)


def _d_by_hand(rows, a, b):
    """d_p computed from the rows directly (no count tensor)."""
    out = {}
    for pid, _clip, left, right, choice in rows:
        if {left, right} != {a, b} or left == right:
            continue
        wa, wb, n = out.get(pid, (0, 0, 0))
        picked = left if choice == "left" else right if choice == "right" else None
        out[pid] = (wa + (picked == a), wb + (picked == b), n + 1)
    return {p: (wa - wb) / n for p, (wa, wb, n) in out.items()}


def _random_rows(rng, participants=9, conditions="ABC", repeats=2):
    rows = []
    for k in range(participants):
        bias = rng.normal(0, 1)
        for _ in range(repeats):
            for a in conditions:
                for b in conditions:
                    if a == b:
                        continue
                    z = bias * (conditions.index(b) - conditions.index(a)) + rng.normal()
                    choice = "undecided" if abs(z) < 0.4 else ("left" if z > 0 else "right")
                    rows.append((f"p{k}", "c", a, b, choice))
    return rows


def test_net_preference_by_hand():
    rows = [
        ("p1", "c", "A", "B", "left"),
        ("p1", "c", "B", "A", "left"),
        ("p1", "c", "A", "B", "undecided"),
        ("p1", "c", "A", "B", "left"),
        ("p2", "c", "B", "A", "right"),
        ("p2", "c", "A", "A", "left"),
    ]
    counts, t = _tensor(rows)
    d = net_preference(t)
    # p1: A wins 2, B wins 1, 1 undecided -> (2 - 1) / 4; p2: one vote for A
    assert d[:, 0].tolist() == [0.25, 1.0]
    assert d[:, 0].tolist() == [_d_by_hand(rows, "A", "B")[p] for p in counts.participants]


def test_wilcoxon_matches_scipy_on_hand_computed_differences():
    rng = np.random.default_rng(3)
    rows = _random_rows(rng, participants=15)
    _, t = _tensor(rows)
    res = participant_level_tests(t, ["A", "B", "C"], bootstrap=0)
    assert [(r["a"], r["b"]) for r in res] == [("A", "B"), ("A", "C"), ("B", "C")]
    ps = []
    for r in res:
        d = np.array(list(_d_by_hand(rows, r["a"], r["b"]).values()))
        expected = stats.wilcoxon(d, zero_method="wilcox", alternative="two-sided")
        assert r["W"] == pytest.approx(expected.statistic)
        assert r["p"] == pytest.approx(expected.pvalue)
        assert r["n_participants"] == 15 and r["median_d"] == pytest.approx(np.median(d))
        ps.append(expected.pvalue)
    assert [r["p_holm"] for r in res] == pytest.approx(holm(ps).tolist())


def test_rank_biserial_against_the_signed_rank_statistic():
    # no ties: T+ + T- = n(n+1)/2 and scipy's two-sided W = min(T+, T-)
    d = np.array([0.9, -0.2, 0.5, 0.7, -0.4, 0.3, 1.0, 0.1])
    n = d.size
    w = stats.wilcoxon(d).statistic
    r = rank_biserial(d)
    assert abs(r) == pytest.approx(1 - 4 * w / (n * (n + 1)))
    plus = sum(k + 1 for k, v in enumerate(sorted(np.abs(d))) if v in d[d > 0])
    assert r == pytest.approx(4 * plus / (n * (n + 1)) - 1)
    assert rank_biserial([0.0, np.nan]) is None
    assert rank_biserial([0.5, 0.5, 0.0]) == 1.0


@given(
    st.lists(st.sampled_from([-1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0]), min_size=1, max_size=12),
    st.integers(0, 2**31),
)
@settings(max_examples=60, deadline=None)
def test_bootstrap_effect_equals_explicit_resamples(d, seed):
    d = np.array(d)
    rng = np.random.default_rng(seed)
    weights = rng.multinomial(d.size, np.full(d.size, 1 / d.size), size=8)
    fast = bootstrap_rank_biserial(d, weights)
    for b in range(8):
        explicit = rank_biserial(np.repeat(d, weights[b]))
        if explicit is None:
            assert np.isnan(fast[b])
        else:
            assert fast[b] == pytest.approx(explicit)


def test_effect_interval_and_relabelling():
    rng = np.random.default_rng(5)
    rows = _random_rows(rng, participants=12)
    _, t = _tensor(rows)
    res = participant_level_tests(t, ["A", "B", "C"], bootstrap=300, seed=1)
    for r in res:
        lo, hi = r["effect_ci"]
        assert -1 <= lo <= hi <= 1
    renamed = [(f"x{11 - int(p[1:])}", *rest) for p, *rest in rows]
    _, t2 = _tensor(renamed)
    assert participant_level_tests(t2, ["A", "B", "C"], bootstrap=300, seed=1) == res


def test_one_judgement_per_participant_by_hand():
    # p1 and p2 prefer A (3 of 4 and 2 of 2), p3 is tied on A-B (1-1), p4 only undecided
    rows = (
        [("p1", "c", "A", "B", "left")] * 3
        + [("p1", "c", "B", "A", "left")]
        + [("p2", "c", "B", "A", "right")] * 2
        + [("p3", "c", "A", "B", "left"), ("p3", "c", "A", "B", "right")]
        + [("p4", "c", "A", "B", "undecided")]
    )
    _, t = _tensor(rows)
    r = one_judgement_per_participant(t, ["A", "B"])
    s = r["sign_tests"][0]
    assert (s["participants_for_a"], s["participants_for_b"], s["participants_tied"]) == (2, 0, 2)
    assert s["p"] == pytest.approx(0.5)  # 2 of 2 under Bin(2, 1/2), two-sided
    # a = [[0, 3], [1, 0]] (2 + 2 halves, 0 + 2 halves): m = 4, Sigma = C(3,2) + C(1,2) = 3
    assert r["agreement"]["sigma"] == pytest.approx(3.0)
    assert r["agreement"]["u"] == pytest.approx(2 * 3 / 6 - 1)
    assert r["agreement"]["judges"] == 4


def test_pooled_counts_overstate_the_evidence():
    # 6 participants each see A|B and B|A five times and always pick A: pooled m = 60
    rows = [
        (f"p{k}", "c", a, b, "left" if a == "A" else "right")
        for k in range(6)
        for _ in range(5)
        for a, b in (("A", "B"), ("B", "A"))
    ] + [(f"p{k}", "c", a, b, "left") for k in range(6) for a, b in (("A", "C"), ("C", "A"))]
    r = analyze(pd.DataFrame(rows, columns=COLS), bootstrap=0)["pooled"]
    pooled = next(s for s in r["sign_tests"] if (s["a"], s["b"]) == ("A", "B"))
    per = next(s for s in r["one_per_participant"]["sign_tests"] if s["b"] == "B")
    wil = next(s for s in r["participant_level"] if s["b"] == "B")
    assert pooled["wins"] == 60 and per["participants_for_a"] == 6
    assert per["p"] == pytest.approx(2 * 0.5**6) and pooled["p"] < per["p"]
    assert wil["n_participants"] == 6 and wil["effect"] == 1.0
    assert wil["p"] == pytest.approx(stats.wilcoxon(np.ones(6)).pvalue)


def test_sections_carry_the_new_statistics():
    r = analyze("app/data/examples/votes.csv", bootstrap=50)
    for section in [*r["clips"].values(), r["pooled"]]:
        assert len(section["participant_level"]) == 6
        for row in section["participant_level"]:
            assert set(row) == {
                "a",
                "b",
                "n_participants",
                "median_d",
                "W",
                "p",
                "p_holm",
                "effect",
                "effect_ci",
            }
        assert section["one_per_participant"]["agreement"]["judges"] == 14
    json.dumps(r, allow_nan=False)


@given(
    st.lists(
        st.tuples(
            st.sampled_from(["p1", "p2", "p3"]),
            st.sampled_from(["s", "t"]),
            st.sampled_from("ABC"),
            st.sampled_from("ABC"),
            st.sampled_from(["left", "right", "undecided"]),
        ),
        min_size=1,
        max_size=30,
    )
)
@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_any_votes_give_bounded_participant_statistics(rows):
    r = analyze(pd.DataFrame(rows, columns=COLS), bootstrap=20)
    json.dumps(r, allow_nan=False)
    for section in [*r["clips"].values(), r["pooled"]]:
        for row in section["participant_level"]:
            assert row["effect"] is None or -1 <= row["effect"] <= 1
            assert row["p"] is None or 0 <= row["p"] <= 1
            assert -1 <= row["median_d"] <= 1
