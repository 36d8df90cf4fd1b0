"""The published board: every system's standing from the pooled votes, as ``leaderboard.json``.

:func:`standings` fits the scores (:mod:`app.leaderboard.scores`) to the votes of every
published round and adds, per system, its rank band, votes, participants, the preliminary
flag, coherence and the robustness check: the same votes under the Bradley-Terry-Davidson
model with crossed participant and segment random effects (:mod:`app.analysis.mixed_btd`),
on the same Elo scale, and Kendall's tau between the two orders. :func:`board_document`
assembles the file the page and any other site read (its fields: ``docs/guide/leaderboard.md``,
"leaderboard.json").

Systems are named in the votes by their *code* (``sys01``, ``ground_truth``): a round's study
package names no system that is still anonymous; the document maps codes to public names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from app.analysis.json_values import json_number
from app.analysis.mixed_btd import mixed_btd_summary
from app.leaderboard.scores import (
    ELO_ORIGIN,
    ELO_PER_LOG_WORTH,
    fit_coherence,
    fit_scale,
    kendall_tau,
    preliminary_reason,
    rank_bands,
    votes_and_people,
)
from app.leaderboard.season import PublishRules
from app.leaderboard.votes import coherence_counts, naturalness_counts

BOARD_FORMAT = "facepair-leaderboard/1"


@dataclass(frozen=True)
class SystemEntry:
    """What the board says of a system besides its scores (filled in by the web layer)."""

    code: str
    name: str
    anchor: bool
    team: str = ""
    paper: str = ""
    training_data: str = ""
    anonymous_until: str | None = None
    rounds: tuple[int, ...] = ()
    renders: tuple[Mapping[str, str], ...] = ()
    objective: Mapping[str, Any] = field(default_factory=dict)


def _round(value: float, digits: int = 1) -> float | None:
    number = json_number(value)
    return None if number is None else round(float(number), digits)


def standings(
    frame: pd.DataFrame,
    codes: Sequence[str],
    fixed_anchors: Sequence[str],
    rules: PublishRules,
    *,
    seed: int,
    segments: Sequence[str],
    drifted_rounds: Sequence[int] = (),
) -> dict[str, Any]:
    """Every score of the pooled votes ``frame`` (:func:`app.leaderboard.votes.pooled_frame`).

    Returns ``{"systems": {code: {...}}, "scale": {...}, "robustness": {...}}``; a system is
    preliminary with fewer than ``rules.min_votes`` votes or when every round it was in is
    one of ``drifted_rounds``.
    """
    counts, people = naturalness_counts(frame, codes)
    scale = fit_scale(
        counts,
        codes,
        fixed_anchors,
        bootstrap=rules.bootstrap,
        seed=seed,
        confidence=rules.confidence,
    )
    hits, _ = coherence_counts(frame, codes)
    coherence = fit_coherence(
        hits, codes, bootstrap=rules.bootstrap, seed=seed, confidence=rules.confidence
    )
    bands = rank_bands(codes, scale.score, scale.low, scale.high)
    tally = votes_and_people(counts, codes)
    flagged = set(drifted_rounds)
    systems: dict[str, Any] = {}
    for k, code in enumerate(codes):
        rounds = sorted(set(frame.loc[_involves(frame, code), "round"].astype(int).tolist()))
        drift_only = rounds if rounds and set(rounds) <= flagged else []
        votes, participants = tally[code]
        reason = preliminary_reason(votes, rules.min_votes, drift_only)
        systems[code] = {
            "score": _round(scale.score[k]),
            "ci_low": _round(scale.low[k]),
            "ci_high": _round(scale.high[k]),
            "rank_band": bands[code],
            "votes": votes,
            "participants": participants,
            "preliminary": reason is not None,
            "preliminary_reason": reason,
            # measured only in drifted rounds: the next round takes it as an anchor
            "remeasure": bool(drift_only),
            "rounds": rounds,
            "coherence": {
                "score": _round(coherence.share[k]),
                "ci_low": _round(coherence.low[k]),
                "ci_high": _round(coherence.high[k]),
                "votes": int(coherence.decided[k]),
            },
        }
    return {
        "systems": systems,
        "scale": {
            "gamma": json_number(scale.gamma),
            "nu": json_number(scale.nu),
            "replicates": scale.replicates,
            "participants": len(people),
            "note": scale.note,
        },
        "robustness": _mixed(frame, codes, fixed_anchors, segments, systems, rules.confidence),
    }


def _involves(frame: pd.DataFrame, code: str) -> pd.Series:
    return (frame["left"] == code) | (frame["right"] == code)


def _mixed(
    frame: pd.DataFrame,
    codes: Sequence[str],
    anchors: Sequence[str],
    segments: Sequence[str],
    main: Mapping[str, Any],
    confidence: float,
) -> dict[str, Any]:
    """The mixed model's scores on the board's scale and their agreement with the main fit."""
    tensor, _ = naturalness_counts(frame, codes, clips=segments)
    summary = mixed_btd_summary(tensor, list(codes), confidence=confidence)
    theta = summary["scores"]
    anchored = [theta[a] for a in anchors if theta.get(a) is not None]
    if len(anchored) != len([a for a in anchors if a in codes]) or not anchored:
        note = summary["note"] or "an anchor has no score"
        return {"model": summary["model"], "systems": {}, "kendall_tau": None, "note": note}
    origin = float(np.mean(anchored))

    def elo(value: float | None) -> float | None:
        return None if value is None else _round(ELO_ORIGIN + ELO_PER_LOG_WORTH * (value - origin))

    systems = {
        c: {
            "score": elo(theta[c]),
            "ci_low": elo(summary["ci"][c][0]),
            "ci_high": elo(summary["ci"][c][1]),
        }
        for c in codes
    }
    tau = kendall_tau({c: main[c]["score"] for c in codes}, {c: systems[c]["score"] for c in codes})
    return {
        "model": summary["model"],
        "sd_participant": summary["sd_participant"],
        "sd_segment": summary["sd_clip"],
        "systems": systems,
        "kendall_tau": None if tau is None else round(tau, 3),
        "note": summary["note"],
    }


def board_document(
    *,
    season: Mapping[str, Any],
    entries: Sequence[SystemEntry],
    fitted: Mapping[str, Any],
    rounds: Sequence[Mapping[str, Any]],
    rules: PublishRules,
    published_at: str,
    links: Mapping[str, str],
) -> dict[str, Any]:
    """``leaderboard.json``: the season, the scale's definition, one entry per system (in band
    order, then by score), the rounds with their drift checks, the robustness check and links.

    ``links`` holds ``votes`` (the pooled votes CSV) and ``reproduce`` (the command that
    refits the model from it).
    """
    systems = fitted["systems"]
    rows = []
    for entry in entries:
        standing = systems.get(entry.code)
        if standing is None:
            continue
        rows.append(
            {
                "name": entry.name,
                "code": entry.code,
                **{k: standing[k] for k in ("score", "ci_low", "ci_high", "rank_band")},
                **{k: standing[k] for k in ("votes", "participants", "preliminary")},
                "preliminary_reason": standing["preliminary_reason"],
                "remeasure": standing["remeasure"],
                "anchor": entry.anchor,
                "coherence": standing["coherence"],
                "objective": dict(entry.objective),
                "team": entry.team,
                "paper": entry.paper,
                "training_data": entry.training_data,
                "anonymous_until": entry.anonymous_until,
                "rounds": standing["rounds"],
                "renders": [dict(r) for r in entry.renders],
            }
        )
    rows.sort(
        key=lambda r: (
            r["rank_band"] is None,
            r["rank_band"] or 0,
            -(r["score"] if r["score"] is not None else -np.inf),
            r["name"],
        )
    )
    robust = fitted["robustness"]
    names = {e.code: e.name for e in entries}
    return {
        "format": BOARD_FORMAT,
        "season": dict(season),
        "published_at": published_at,
        "scale": {
            "naturalness": (
                "Bradley-Terry-Davidson model with ties and a side effect, maximum likelihood on "
                "the naturalness votes of every round pooled; Elo points, the mean of the fixed "
                "anchors at 1000, 400 points per factor 10 in worth"
            ),
            "interval": (
                f"{rules.confidence:.0%} percentile bootstrap over participants "
                f"({rules.bootstrap} resamples)"
            ),
            "coherence": (
                "percent of decided mismatched-speech votes for the face moving with the speech "
                "heard (50 = chance), same bootstrap"
            ),
            "rank_band": (
                "systems in score order; each joins the current band while its interval "
                "overlaps the band leader's, else it opens the next band"
            ),
            "preliminary": (
                f"fewer than {rules.min_votes} votes, or measured only in drifted rounds"
            ),
            **fitted["scale"],
        },
        "systems": rows,
        "rounds": [dict(r) for r in rounds],
        "robustness": {
            **{k: v for k, v in robust.items() if k != "systems"},
            # in the standings' order, so the two fits read side by side
            "systems": [
                {"name": names[row["code"]], "code": row["code"], **robust["systems"][row["code"]]}
                for row in rows
                if row["code"] in robust.get("systems", {})
            ],
        },
        "links": dict(links),
    }
