"""The leaderboard's scores (``app.leaderboard.scores``, ``votes``, ``drift``, ``board``): the
pooled fit recovers the preferences the votes were drawn from, rank bands follow their rule,
and the drift check tells a stable scale from a shifted one."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.leaderboard.board import board_document, standings
from app.leaderboard.drift import drift_check
from app.leaderboard.scores import (
    fit_coherence,
    fit_scale,
    kendall_tau,
    preliminary_reason,
    rank_bands,
    to_elo,
)
from app.leaderboard.season import PublishRules
from app.leaderboard.simulate import Preferences, answer_mismatch, answer_pair
from app.leaderboard.votes import coherence_counts, naturalness_counts, pooled_frame

TRUTH = {"gt": 1.4, "good": 0.7, "mid": 0.0, "weak": -0.8, "none": -1.5}
COHERENCE = {"gt": 0.85, "good": 0.75, "mid": 0.6, "weak": 0.5, "none": 0.5}


def simulated_votes(
    truth: dict[str, float],
    *,
    participants: int,
    rounds: dict[int, list[str]],
    seed: int,
    shift: dict[int, dict[str, float]] | None = None,
    per_pair: int = 2,
) -> pd.DataFrame:
    """Export-shaped votes of simulated participants: in each round every pair of its systems,
    ``per_pair`` times per participant and side order, plus one mismatched-speech pair per
    system; ``shift`` moves strengths in a round (a drifted crowd)."""
    rng = np.random.default_rng(seed)
    rows = []
    for number, systems in rounds.items():
        moved = {k: v + (shift or {}).get(number, {}).get(k, 0.0) for k, v in truth.items()}
        prefs = Preferences(moved, COHERENCE)
        for person in range(participants):
            own = prefs.for_participant(rng)
            for a_pos, a in enumerate(systems):
                for b in systems[a_pos + 1 :]:
                    for left, right in [(a, b), (b, a)] * per_pair:
                        choice, _ = answer_pair(own, left, right, rng)
                        rows.append((number, f"p{person}", "s1", left, right, choice, "trial", ""))
            for system in systems:
                side = "left" if rng.random() < 0.5 else "right"
                choice, _ = answer_mismatch(own, system, side, rng)
                rows.append((number, f"p{person}", "s1", system, system, choice, "mismatch", side))
    columns = ["round", "participant", "clip", "left", "right", "choice", "kind", "mismatched"]
    frame = pd.DataFrame(rows, columns=columns)
    frame["excluded"] = ""
    return pooled_frame(frame)


def test_pooled_fit_recovers_the_simulated_order() -> None:
    codes = list(TRUTH)
    frame = simulated_votes(TRUTH, participants=30, rounds={1: codes}, seed=3)
    counts, people = naturalness_counts(frame, codes)
    fit = fit_scale(counts, codes, ["gt", "none"], bootstrap=200, seed=1, confidence=0.95)
    assert len(people) == 30
    assert [codes[k] for k in np.argsort(-fit.score)] == codes
    # the scale: anchors' mean at 1000, Elo points proportional to the true log worths
    assert np.mean(fit.score[[0, 4]]) == pytest.approx(1000.0)
    slope = np.polyfit(list(TRUTH.values()), fit.score, 1)[0]
    assert slope == pytest.approx(400 / np.log(10), rel=0.25)
    assert np.all(fit.low <= fit.score) and np.all(fit.score <= fit.high)
    assert fit.replicates >= 100
    hits, _ = coherence_counts(frame, codes)
    coherence = fit_coherence(hits, codes, bootstrap=200, seed=1, confidence=0.95)
    assert coherence.share[0] > coherence.share[-1]
    assert np.all(coherence.decided > 0)


def test_a_newcomer_in_a_second_round_is_placed_by_the_anchors_alone() -> None:
    """Round 2 compares a newcomer with the anchors only; the pooled fit still places it."""
    truth = {**TRUTH, "new": 0.3}
    rounds = {1: list(TRUTH), 2: ["gt", "good", "none", "new"]}
    frame = simulated_votes(truth, participants=30, rounds=rounds, seed=5)
    codes = list(truth)
    fit = fit_scale(
        naturalness_counts(frame, codes)[0],
        codes,
        ["gt", "none"],
        bootstrap=0,
        seed=0,
        confidence=0.95,
    )
    order = [codes[k] for k in np.argsort(-fit.score)]
    assert order.index("new") < order.index("weak")
    assert order.index("good") < order.index("new")
    assert kendall_tau(dict(zip(codes, fit.score, strict=True)), truth) >= 0.8


def test_a_system_that_won_everything_has_no_finite_score() -> None:
    counts = np.zeros((3, 2, 2, 3))
    counts[:, 0, 1, 0] = 5  # a always preferred
    fit = fit_scale(counts, ["a", "b"], ["b"], bootstrap=20, seed=0, confidence=0.95)
    assert np.all(np.isnan(fit.score)) and fit.note


def test_anchors_never_compared_say_so() -> None:
    counts = np.zeros((2, 3, 3, 3))
    counts[:, 0, 1] = [3, 2, 1]
    fit = fit_scale(counts, ["a", "b", "c"], ["c"], bootstrap=0, seed=0, confidence=0.95)
    assert fit.note == "anchors never compared: c"


def test_to_elo_is_a_shift_and_scale() -> None:
    theta = np.array([0.2, -0.4, 1.0])
    elo = to_elo(theta, [0, 1])
    assert elo[0] - elo[1] == pytest.approx(0.6 * 400 / np.log(10))
    assert (elo[0] + elo[1]) / 2 == pytest.approx(1000.0)


intervals = st.lists(
    st.tuples(
        st.floats(-500, 500, allow_nan=False),
        st.floats(0, 200, allow_nan=False),
        st.floats(0, 200, allow_nan=False),
    ),
    min_size=1,
    max_size=12,
)


@given(intervals)
@settings(max_examples=200, deadline=None)
def test_rank_bands_follow_their_rule(rows) -> None:
    names = [f"s{k:02d}" for k in range(len(rows))]
    score = [s for s, _, _ in rows]
    low = [s - d for s, d, _ in rows]
    high = [s + u for s, _, u in rows]
    bands = rank_bands(names, score, low, high)
    order = sorted(range(len(rows)), key=lambda k: (-score[k], names[k]))
    seen = [bands[names[k]] for k in order]
    assert seen[0] == 1
    assert all(b - a in (0, 1) for a, b in zip(seen, seen[1:], strict=False))
    leader = order[0]
    for k in order[1:]:
        if bands[names[k]] == bands[names[leader]]:
            assert high[k] >= low[leader]  # shares the band: overlaps its leader
        else:
            assert high[k] < low[leader]
            leader = k


def test_rank_bands_skip_systems_without_a_score() -> None:
    bands = rank_bands(["a", "b"], [np.nan, 10.0], [np.nan, 5.0], [np.nan, 15.0])
    assert bands == {"a": None, "b": 1}


def test_preliminary_reasons() -> None:
    assert preliminary_reason(300, 300, []) is None
    assert preliminary_reason(20, 300, []) == "20 votes, fewer than 300"
    assert "round 2" in (preliminary_reason(400, 300, [2]) or "")


def test_drift_check_flags_a_shifted_crowd_and_passes_a_stable_one() -> None:
    systems = list(TRUTH)
    links = [("gt", "good"), ("good", "none")]
    rounds = {1: systems, 2: systems}
    stable = simulated_votes(TRUTH, participants=25, rounds=rounds, seed=11)
    moved = simulated_votes(
        TRUTH, participants=25, rounds=rounds, seed=11, shift={2: {"gt": -1.5, "none": 1.5}}
    )
    kwargs = {"bootstrap": 200, "seed": 0, "alpha": 0.05}
    calm = drift_check(stable, systems, links, 2, **kwargs)
    drifted = drift_check(moved, systems, links, 2, **kwargs)
    assert calm["checked"] and not calm["drifted"]
    assert drifted["checked"] and drifted["drifted"]
    assert drifted["links"][0]["difference"] < 0
    first = drift_check(stable, systems, links, 1, **kwargs)
    assert not first["checked"] and first["note"] == "no earlier round to compare with"


def test_board_document_has_the_published_fields() -> None:
    from app.leaderboard.board import SystemEntry

    codes = list(TRUTH)
    frame = simulated_votes(TRUTH, participants=20, rounds={1: codes}, seed=2)
    rules = PublishRules(min_votes=150, bootstrap=100)
    fitted = standings(frame, codes, ["gt", "none"], rules, seed=0, segments=["s1"])
    entries = [SystemEntry(code=c, name=c.title(), anchor=c in ("gt", "none")) for c in codes]
    doc = board_document(
        season={"name": "t"},
        entries=entries,
        fitted=fitted,
        rounds=[],
        rules=rules,
        published_at="2026-01-01T00:00:00Z",
        links={"votes": "votes.csv"},
    )
    rows = doc["systems"]
    assert [r["code"] for r in rows] == codes  # band order, then score
    for row in rows:
        for key in ("name", "score", "ci_low", "ci_high", "rank_band", "votes", "participants"):
            assert row[key] is not None, key
        assert row["preliminary"] == (row["votes"] < 150)
        assert row["anchor"] == (row["code"] in ("gt", "none"))
        assert row["coherence"]["score"] is not None
    assert doc["robustness"]["kendall_tau"] is not None
    assert doc["robustness"]["kendall_tau"] >= 0.6
