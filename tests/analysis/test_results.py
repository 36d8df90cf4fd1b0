import json
from itertools import permutations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from app.analysis import analyze, read_votes
from app.errors import InputError

COLS = ["participant", "clip", "left", "right", "choice"]


def _frame(rows):
    return pd.DataFrame(rows, columns=COLS)


def test_layout_is_the_issues(tmp_path):
    rows = [
        (f"p{k}", clip, a, b, "left")
        for k in range(3)
        for clip in ("s2", "s7")
        for a, b in permutations("ABC", 2)
    ]
    r = analyze(_frame(rows), bootstrap=20)
    assert {"clips", "pooled", "participants", "conditions", "input", "options"} <= set(r)
    assert set(r["clips"]) == {"s2", "s7"}
    for section in [*r["clips"].values(), r["pooled"]]:
        assert set(section["ballots"]) == {"A", "B", "C"}
        assert {"left", "right", "undecided"} <= set(section["confusion"])
        for row in section["paired_t"]:
            assert {
                "a",
                "b",
                "mean",
                "sd",
                "sem",
                "ci_low",
                "ci_high",
                "t",
                "df",
                "p",
                "p_holm",
            } <= set(row)
        assert {"u", "chi2", "df", "p", "judges", "undecided"} <= set(section["agreement"])
        for row in section["sign_tests"]:
            assert {"a", "b", "wins", "losses", "undecided", "p"} <= set(row)
        for row in section["scale"]:
            assert set(row) == {"condition", "score", "ci_low", "ci_high"}
    assert "consistence" in r["participants"]["p0"]
    json.dumps(r, allow_nan=False)


def test_always_left_study_by_hand():
    # 4 participants pick the left panel every time: no condition is preferred
    rows = [(f"p{k}", "c", a, b, "left") for k in range(4) for a, b in permutations("AB", 2)]
    r = analyze(_frame(rows), bootstrap=50)["pooled"]
    assert r["ballots"] == {"A": 4, "B": 4} and r["undecided"] == 0
    assert r["confusion"]["left"] == [[0, 4], [4, 0]]
    assert r["sign_tests"][0]["wins"] == 4 and r["sign_tests"][0]["p"] == 1.0
    assert r["agreement"]["u"] == pytest.approx(2 * 2 * 6 / 28 - 1)  # 4-4 split of m = 8
    assert r["scale"][0]["score"] == pytest.approx(0.0, abs=1e-12)


def test_unanimous_ranking_by_hand():
    # 6 participants, both side orders, always A > B > C; plus same-condition pairs
    rows = []
    for k in range(6):
        for a, b in permutations("ABC", 2):
            rows.append((f"p{k}", "c", a, b, "left" if a < b else "right"))
        rows += [(f"p{k}", "c", x, x, "undecided" if x == "C" else "left") for x in "ABC"]
    res = analyze(_frame(rows), bootstrap=100)
    r = res["pooled"]
    assert r["ballots"] == {"A": 6 * 4 + 6, "B": 6 * 2 + 6, "C": 0}
    assert r["undecided"] == 6 and r["same_condition_votes"] == 18
    assert r["agreement"]["u"] == pytest.approx(1.0)
    assert r["agreement"]["judges"] == 12
    ab = r["sign_tests"][0]
    assert (ab["a"], ab["b"], ab["wins"], ab["losses"]) == ("A", "B", 12, 0)
    assert ab["p"] == pytest.approx(2 * 0.5**12)
    t_ab = r["paired_t"][0]
    assert t_ab["mean"] == 2 and t_ab["sd"] == 0 and t_ab["t"] is None  # SPSS: not computed
    scores = [s["score"] for s in r["scale"]]
    assert scores[0] > scores[1] > scores[2]
    for p in res["participants"].values():
        assert p["consistence"]["zeta"] == 1 and p["consistence"]["d"] == 0


def test_sign_test_vector_through_the_votes():
    rows = (
        [("p1", "c", "A", "B", "left")] * 7
        + [("p1", "c", "B", "A", "right")] * 7
        + [("p1", "c", "B", "A", "left")] * 4
        + [("p1", "c", "A", "B", "undecided")] * 2
    )
    rows = [(f"p{k}", *row[1:]) for k, row in enumerate(rows)]
    s = analyze(_frame(rows), bootstrap=0)["pooled"]["sign_tests"][0]
    assert (s["wins"], s["losses"], s["undecided"]) == (14, 4, 2)
    assert s["p"] == pytest.approx(0.030884, abs=1e-6)
    assert s["p_split"] == pytest.approx(0.041389, abs=1e-6)
    assert s["p_undecided_as_losses"] == pytest.approx(0.115318, abs=1e-6)


@pytest.mark.parametrize(
    ("name", "u", "chi2", "df"),
    [
        ("kendall1940-boys.txt", 0.186569, 412.4321, 90.7479),
        ("kendall1940-girls.txt", 0.082182, 180.2949, 62.3819),
    ],
)
def test_agreement_vectors_through_the_votes(analysis_data, matrix_votes, name, u, chi2, df):
    a = np.loadtxt(analysis_data / name).astype(int)
    r = analyze(matrix_votes(a), bootstrap=0)
    ag = r["pooled"]["agreement"]
    assert ag["u"] == pytest.approx(u, abs=5e-7)
    assert ag["chi2"] == pytest.approx(chi2, abs=6e-4)
    assert ag["df"] == pytest.approx(df, abs=6e-5)
    assert ag["undecided"] == "exclude"


def test_thurstone_example_through_the_votes(matrix_votes):
    votes = matrix_votes([[0, 25, 0], [75, 0, 25], [0, 75, 0]], names=["X", "Y", "Z"])
    r = analyze(votes, bootstrap=0)
    assert [s["score"] for s in r["pooled"]["scale"]] == pytest.approx([-1, 0, 1], abs=1e-9)
    anchored = analyze(votes, bootstrap=0, anchor="X")
    assert [s["score"] for s in anchored["pooled"]["scale"]] == pytest.approx([0, 1, 2])


def test_undecided_split_is_stated_and_used():
    rows = [
        ("p1", "c", "A", "B", "left"),
        ("p2", "c", "A", "B", "undecided"),
        ("p3", "c", "B", "A", "right"),
        ("p4", "c", "A", "B", "undecided"),
    ]
    ex = analyze(_frame(rows), bootstrap=0)
    sp = analyze(_frame(rows), undecided="split", bootstrap=0)
    assert ex["options"]["undecided"] == "exclude" and sp["options"]["undecided"] == "split"
    assert sp["pooled"]["agreement"]["undecided"] == "split"
    assert ex["pooled"]["agreement"]["judges"] is None or ex["pooled"]["agreement"]["u"] is None
    assert sp["pooled"]["agreement"]["judges"] == 4  # 3 + 1 judgements on (A, B)
    assert sp["pooled"]["scores"]["A"]["mean"] == pytest.approx((1 + 0.5 + 1 + 0.5) / 4)
    with pytest.raises(InputError, match="undecided"):
        analyze(_frame(rows), undecided="drop")


def test_skipped_rows_reported(tmp_path):
    path = tmp_path / "v.csv"
    path.write_text("participant,clip,left,right,choice\np,c,A,B,left\np,c,A,B,nope\n")
    r = analyze(read_votes(path, skip_bad_rows=True), bootstrap=0)
    assert r["input"]["skipped_rows"] == 1 and "nope" in r["input"]["problems"][0]
    with pytest.raises(InputError, match=":3: choice"):
        analyze(path)


def test_explicit_conditions_keep_unseen_ones():
    rows = [("p1", "c", "A", "B", "left"), ("p2", "c", "B", "A", "left")] * 3
    r = analyze(_frame(rows), conditions=["B", "A", "C"], bootstrap=10)
    assert r["conditions"] == ["B", "A", "C"]
    assert r["pooled"]["ballots"]["C"] == 0
    scale = {s["condition"]: s["score"] for s in r["pooled"]["scale"]}
    assert scale["C"] is None and scale["A"] is not None
    assert "never compared: C" in r["pooled"]["scale_note"]


def test_no_votes_is_an_input_error():
    with pytest.raises(InputError, match="no valid votes"):
        analyze(_frame([]))


# ---- properties -----------------------------------------------------------------------------

votes_strategy = st.lists(
    st.tuples(
        st.sampled_from(["ann", "bob", "cy", "dee", "eve"]),
        st.sampled_from(["s2", "s7"]),
        st.sampled_from("ABCD"),
        st.sampled_from("ABCD"),
        st.sampled_from(["left", "right", "undecided"]),
    ),
    min_size=1,
    max_size=60,
)
slow = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SWAP = {"left": "right", "right": "left", "undecided": "undecided"}


def _run(rows, **kw):
    return analyze(_frame(rows), conditions=list("ABCD"), bootstrap=30, **kw)


#: One participant, one clip, a condition never judged: a flat mixed-model likelihood (a
#: singular curvature, an unbounded interval, a negative variance by rounding).
FLAT = [
    [
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "C", "left"),
        ("ann", "s2", "A", "C", "left"),
        ("ann", "s2", "A", "C", "right"),
        ("ann", "s2", "A", "D", "undecided"),
    ],
    [
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "C", "left"),
        ("ann", "s2", "A", "C", "right"),
        ("ann", "s2", "C", "B", "undecided"),
    ],
    [
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "A", "left"),
        ("ann", "s2", "A", "C", "left"),
        ("ann", "s2", "A", "C", "right"),
        ("ann", "s2", "A", "D", "undecided"),
    ],
]


@slow
@given(votes_strategy)
@example(FLAT[0])
@example(FLAT[1])
@example(FLAT[2])
def test_ballots_plus_undecided_is_votes(rows):
    r = _run(rows)
    for section in [*r["clips"].values(), r["pooled"]]:
        assert sum(section["ballots"].values()) + section["undecided"] == section["votes"]
    assert r["pooled"]["votes"] == len(rows)


@slow
@given(votes_strategy, st.sampled_from(["exclude", "split"]))
def test_swapping_sides_changes_nothing_that_matters(rows, undecided):
    swapped = [(p, c, right, left, SWAP[ch]) for p, c, left, right, ch in rows]
    # the mixed model is not compared (it has a side term of its own), so it is not fitted
    a = _run(rows, undecided=undecided, mixed_model=False)
    b = _run(swapped, undecided=undecided, mixed_model=False)
    for sa, sb in [
        *zip(a["clips"].values(), b["clips"].values(), strict=True),
        (a["pooled"], b["pooled"]),
    ]:
        assert sa["ballots"] == sb["ballots"] and sa["undecided"] == sb["undecided"]
        assert _same(sa["agreement"], sb["agreement"])
        assert _same(sa["scale"], sb["scale"])
        assert _same(sa["sign_tests"], sb["sign_tests"])
        assert np.array(sa["confusion"]["left"]).T.tolist() == sb["confusion"]["right"]


# Relabelled, these votes took 203 and 224 variance updates to the same mixed fit, before
# the fit put the participants in an order of their counts.
SLOW_TO_CONVERGE = [
    ("ann", "s2", "B", "A", "right"),
    ("ann", "s2", "D", "D", "left"),
    ("bob", "s7", "C", "A", "right"),
    ("ann", "s2", "B", "B", "left"),
    ("bob", "s2", "B", "C", "right"),
    ("ann", "s7", "C", "D", "right"),
    ("cy", "s7", "B", "D", "right"),
    ("ann", "s2", "D", "D", "left"),
    ("dee", "s7", "C", "A", "right"),
    ("ann", "s7", "C", "D", "right"),
    ("ann", "s2", "D", "D", "left"),
    ("ann", "s2", "B", "D", "left"),
    ("cy", "s2", "D", "B", "undecided"),
    ("ann", "s2", "D", "D", "left"),
    ("ann", "s2", "A", "A", "left"),
    ("eve", "s2", "B", "C", "right"),
    ("bob", "s7", "C", "A", "left"),
]


@slow
@given(votes_strategy, st.permutations(["ann", "bob", "cy", "dee", "eve"]))
@example(SLOW_TO_CONVERGE, ["ann", "bob", "cy", "eve", "dee"])
def test_relabelling_participants_changes_nothing(rows, order):
    rename = dict(zip(["ann", "bob", "cy", "dee", "eve"], [f"x{o}" for o in order], strict=True))
    relabelled = [(rename[p], *rest) for p, *rest in rows]
    a, b = _run(rows), _run(relabelled)
    # The mixed model is fitted iteratively, with the participants in an order of their
    # counts: the same iterations, whatever the names.
    assert a["pooled"]["mixed_btd"].get("iterations") == b["pooled"]["mixed_btd"].get("iterations")
    assert _same(a["pooled"], b["pooled"]) and _same(a["clips"], b["clips"])
    assert _same({rename[k]: v for k, v in a["participants"].items()}, b["participants"])


def _same(x, y, rel=1e-9, abs=1e-12):
    """Equal up to floating-point summation order (or ``rel``/``abs``)."""
    if isinstance(x, dict):
        return (
            isinstance(y, dict)
            and x.keys() == y.keys()
            and all(_same(x[k], y[k], rel, abs) for k in x)
        )
    if isinstance(x, list):
        return (
            isinstance(y, list)
            and len(x) == len(y)
            and all(_same(p, q, rel, abs) for p, q in zip(x, y, strict=True))
        )
    if isinstance(x, float) and isinstance(y, float):
        return x == pytest.approx(y, rel=rel, abs=abs)
    return x == y


@pytest.mark.parametrize("cpus", [2, 8])
def test_the_mixed_model_beside_the_sections_or_after_them_gives_the_same_numbers(
    monkeypatch, cpus
):
    import app.analysis.results as results

    rng = np.random.default_rng(3)
    rows = [
        (f"p{p}", f"s{k}", a, b, rng.choice(["left", "right", "undecided"]))
        for p in range(12)
        for k in range(3)
        for a, b in permutations("ABC", 2)
    ]
    frame = pd.DataFrame(rows, columns=["participant", "clip", "left", "right", "choice"])
    monkeypatch.setattr(results.os, "sched_getaffinity", lambda pid: set(range(cpus)))
    assert results.side_by_side() == (cpus > results.SIDE_BY_SIDE_ABOVE)
    steps = []
    got = analyze(frame, bootstrap=50, progress=lambda done, total: steps.append((done, total)))
    monkeypatch.setattr(results.os, "sched_getaffinity", lambda pid: set(range(10 - cpus)))
    other = analyze(frame, bootstrap=50)
    assert json.dumps(got, sort_keys=True) == json.dumps(other, sort_keys=True)
    assert got["pooled"]["mixed_btd"]["sd_participant"] is not None
    assert steps[-1][0] == steps[-1][1] and all(a <= b for a, b in steps)
