import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from app.analysis import analyze, read_votes
from app.analysis.btd import leave_one_out_loglik
from app.analysis.counts import count_votes
from app.analysis.quality import parse_rules, participant_quality, tau_b
from app.errors import InputError

COLS = ["participant", "clip", "left", "right", "choice"]
PAIRS = [(a, b) for a in "ABC" for b in "ABC"]


def _study(seed=0, participants=10):
    """Participants who prefer A > B > C (noisily); p0 always answers left."""
    rng = np.random.default_rng(seed)
    worth = {"A": 1.0, "B": 0.0, "C": -1.0}
    rows = []
    for k in range(participants):
        for a, b in PAIRS * 2:
            z = worth[a] - worth[b] + rng.normal(0, 0.8)
            choice = (
                "undecided"
                if a == b and k % 2
                else ("undecided" if abs(z) < 0.2 else "left" if z > 0 else "right")
            )
            rows.append((f"p{k}", "c", a, b, "left" if k == 0 else choice))
    frame = pd.DataFrame(rows, columns=COLS)
    frame["response_ms"] = 1000.0 + 10 * np.arange(len(frame))
    return frame


def test_rules_parse_and_bad_rules_name_the_option():
    rules = parse_rules("catch<1.0, side_p<=0.001,outlier>1.5")
    assert [(r.field, r.op, r.value) for r in rules] == [
        ("catch", "<", 1.0),
        ("side_p", "<=", 0.001),
        ("outlier", ">", 1.5),
    ]
    assert parse_rules(None) == [] and parse_rules(" ") == []
    for bad, words in [
        ("catch<<1", "cannot read rule"),
        ("speed<3", "unknown field 'speed'"),
        ("catch<", "cannot read rule"),
    ]:
        with pytest.raises(InputError, match=words) as info:
            parse_rules(bad)
        assert info.value.field == "exclude"


@given(st.text(max_size=30))
@settings(max_examples=200, deadline=None)
def test_any_rule_text_is_read_or_refused_in_one_line(text):
    try:
        rules = parse_rules(text)
    except InputError as exc:
        assert "\n" not in str(exc)
    else:
        assert all(r.field for r in rules)


def test_side_bias_catch_and_times():
    frame = _study()
    counts = count_votes(read_votes(frame))
    q = participant_quality(counts, frame)
    assert q["p0"]["side_left"] == 1.0 and q["p0"]["side_p"] == pytest.approx(2 * 0.5**18)
    # odd participants answer every identical pair undecided; p0 never does
    assert q["p1"]["catch"] == 1.0 and q["p1"]["catch_trials"] == 6
    assert q["p0"]["catch"] == 0.0
    assert q["p2"]["median_ms"] == pytest.approx(np.median(1000.0 + 10 * np.arange(36, 54)))
    votes = frame[frame.participant == "p3"]
    assert q["p3"]["undecided"] == pytest.approx((votes.choice == "undecided").mean())


@given(
    st.lists(st.lists(st.integers(0, 3), min_size=4, max_size=4), min_size=1, max_size=6),
    st.lists(st.integers(-2, 2), min_size=4, max_size=4),
)
@settings(max_examples=80, deadline=None)
def test_tau_b_equals_scipy(rows, consensus):
    x = np.array(rows, dtype=float)
    y = np.array(consensus, dtype=float)
    got = tau_b(x, y)
    for q, row in enumerate(x):
        if len(set(row)) < 2 or len(set(y)) < 2:
            assert np.isnan(got[q])
        else:
            assert got[q] == pytest.approx(stats.kendalltau(row, y).statistic)


def test_outlier_distance_is_pwcmps():
    frame = _study(participants=12)
    reversed_rows = frame[frame.participant == "p5"].copy()
    reversed_rows["choice"] = reversed_rows["choice"].map(
        {"left": "right", "right": "left", "undecided": "undecided"}
    )
    frame = pd.concat([frame[frame.participant != "p5"], reversed_rows], ignore_index=True)
    counts = count_votes(read_votes(frame))
    q = participant_quality(counts, frame)
    loo = leave_one_out_loglik(counts.tensor.sum(axis=1).astype(float))
    q1, q3 = np.percentile(loo, [25, 75])
    for k, pid in enumerate(counts.participants):
        assert q[pid]["outlier"] == pytest.approx(max(q1 - loo[k], 0) / (q3 - q1))
    assert max(q, key=lambda p: q[p]["outlier"]) == "p5"
    assert q["p5"]["tau"] < 0 < q["p2"]["tau"]


def test_exclusion_applies_before_every_statistic():
    frame = _study()
    r = analyze(frame, exclude="side_p<0.001", bootstrap=30)
    assert list(r["quality"]["excluded"]) == ["p0"]
    assert r["quality"]["excluded"]["p0"][0].startswith("side_p<0.001 (side_p = ")
    assert "p0" in r["quality"]["participants"] and "p0" not in r["participants"]
    without = analyze(frame[frame.participant != "p0"], bootstrap=30)
    for key in (
        "ballots",
        "agreement",
        "sign_tests",
        "scale",
        "paired_t",
        "btd",
        "participant_level",
        "one_per_participant",
    ):
        assert r["pooled"][key] == without["pooled"][key]
    assert r["input"]["excluded_participants"] == 1 and r["options"]["exclude"] == ["side_p<0.001"]
    with pytest.raises(InputError, match="exclude every participant"):
        analyze(frame, exclude="side_left>=0")
