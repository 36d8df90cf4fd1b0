"""From a votes table to every statistic of a paired-comparison study, per clip and pooled:
:func:`analyze` (also importable as ``app.analysis.analyze``).

The layout: ``{"clips": {CLIP: SECTION}, "pooled": SECTION,
"participants": {ID: {...}}}`` plus ``"conditions"``, ``"input"`` (source, votes, skipped bad
rows) and ``"options"`` (how undecided votes were treated, bootstrap settings). A SECTION holds
ballots, undecided, confusion, scores, paired_t, agreement, sign_tests and scale; see
docs/reference/analysis.md for every field. The result is plain JSON (NaN written as null).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from app.analysis.agreement import coefficient_of_agreement
from app.analysis.answer_details import reason_summary, strength_summary
from app.analysis.appropriateness import appropriateness, without_appropriateness
from app.analysis.btd import btd_summary
from app.analysis.consistence import consistence_p, consistence_row, consistence_table
from app.analysis.counts import (
    UNDECIDED_TREATMENTS,
    VoteCounts,
    ballots,
    count_votes,
    undecided_pairs,
    wins,
)
from app.analysis.json_values import json_number as _num
from app.analysis.mixed_btd import mixed_btd_summary
from app.analysis.participant_level import one_judgement_per_participant, participant_level_tests
from app.analysis.quality import (
    QUALITY_FIELDS,
    excluded_participants,
    parse_rules,
    participant_quality,
)
from app.analysis.scaling import JOD_SIGMA, bootstrap_scale, connected
from app.analysis.signtest import sign_test_p
from app.analysis.ttest import holm, paired_t_many
from app.analysis.votes import ANALYSED_KINDS, VotesTable, read_votes
from app.errors import InputError


def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.triu_indices(n, 1)


def _section(
    t: np.ndarray,
    names: Sequence[str],
    *,
    undecided: str,
    bootstrap: int,
    seed: int,
    confidence: float,
    anchor: int | None,
) -> dict[str, Any]:
    """Statistics of one clip (or the pool): ``t`` is (P, n, n, 3) for that clip."""
    seen = t.sum(axis=(1, 2, 3)) > 0
    t = t[seen]
    total = t.sum(axis=0)
    n = len(names)
    won = wins(t)
    und = undecided_pairs(t)
    judged = wins(t, undecided).astype(float)
    off = ~np.eye(n, dtype=bool)
    i, j = _pairs(n)

    # Per-participant scores: their ballots per condition (NaN where never shown).
    shown = (t.sum(axis=(2, 3)) + t.sum(axis=(1, 3))) > 0
    scores = np.where(shown, judged.sum(axis=-1), np.nan)
    tt = paired_t_many(scores[:, i], scores[:, j], confidence=confidence)
    p_holm = holm(tt["p"])
    paired = [
        {
            "a": names[a],
            "b": names[b],
            **{k: _num(tt[k][q]) for k in ("mean", "sd", "sem", "ci_low", "ci_high", "t", "p")},
            "n": int(tt["n"][q]),
            "df": None if np.isnan(tt["df"][q]) else int(tt["df"][q]),
            "p_holm": _num(p_holm[q]),
        }
        for q, (a, b) in enumerate(zip(i, j, strict=True))
    ]

    pooled_judged = np.where(off, judged.sum(axis=0), 0.0)
    raw_agree = coefficient_of_agreement(pooled_judged).as_dict()
    agree: dict[str, Any] = {k: _num(v) for k, v in raw_agree.items()}
    agree["undecided"] = undecided
    agree["undecided_votes"] = int(total[..., 2][off].sum())

    w_all, u_all = won.sum(axis=0), und.sum(axis=0)
    signs = []
    for a, b in zip(i, j, strict=True):
        win, loss, tie = int(w_all[a, b]), int(w_all[b, a]), int(u_all[a, b])
        if win + loss + tie == 0:
            continue
        signs.append(
            {
                "a": names[a],
                "b": names[b],
                "wins": win,
                "losses": loss,
                "undecided": tie,
                "p": _num(sign_test_p(win, loss, tie)),
                "p_split": _num(sign_test_p(win, loss, tie, undecided_rule="split")),
                "p_undecided_as_losses": _num(sign_test_p(win, loss, tie, undecided_rule="loss")),
            }
        )
    holm_signs = holm([s["p"] for s in signs]) if signs else np.zeros(0)
    for s, ph in zip(signs, holm_signs, strict=True):
        s["p_holm"] = _num(ph)

    scale_rows, note = _scale(
        np.where(off, judged, 0.0),
        names,
        bootstrap=bootstrap,
        seed=seed,
        confidence=confidence,
        anchor=anchor,
    )
    ballot_counts = ballots(total)
    return {
        "votes": int(total.sum()),
        "participants": int(seen.sum()),
        "ballots": {c: int(v) for c, v in zip(names, ballot_counts, strict=True)},
        "undecided": int(total[..., 2].sum()),
        "same_condition_votes": int(np.trace(total.sum(axis=-1))),
        "confusion": {
            "conditions": list(names),
            "left": total[..., 0].tolist(),
            "right": total[..., 1].tolist(),
            "undecided": total[..., 2].tolist(),
        },
        "scores": {
            c: {
                "mean": _num(np.nanmean(scores[:, q])) if shown[:, q].any() else None,
                "sd": _num(np.nanstd(scores[:, q], ddof=1)) if shown[:, q].sum() > 1 else None,
            }
            for q, c in enumerate(names)
        },
        "paired_t": paired,
        "agreement": agree,
        "sign_tests": signs,
        "scale": scale_rows,
        "scale_note": note,
        "participant_level": participant_level_tests(
            t, names, bootstrap=bootstrap, seed=seed, confidence=confidence
        ),
        "one_per_participant": one_judgement_per_participant(t, names),
        "btd": btd_summary(t, names, bootstrap=bootstrap, seed=seed, confidence=confidence),
    }


def _scale(
    per_participant: np.ndarray,
    names: Sequence[str],
    *,
    bootstrap: int,
    seed: int,
    confidence: float,
    anchor: int | None,
) -> tuple[list[dict[str, Any]], str | None]:
    """Case V rows for the conditions that were compared; others (and a split graph) get None."""
    pooled = per_participant.sum(axis=0)
    active = np.flatnonzero((pooled + pooled.T).sum(axis=1) > 0)
    empty = [{"condition": c, "score": None, "ci_low": None, "ci_high": None} for c in names]
    if active.size < 2:
        return empty, "fewer than two conditions have decided comparisons"
    sub = per_participant[:, active][:, :, active]
    if not connected(sub.sum(axis=0)):
        return empty, "the compared pairs do not link all conditions; no common scale"
    sub_anchor = None
    if anchor is not None:
        if anchor not in active:
            return empty, f"anchor {names[anchor]!r} was never compared"
        sub_anchor = int(np.flatnonzero(active == anchor)[0])
    scale, low, high = bootstrap_scale(
        sub, replicates=bootstrap, seed=seed, confidence=confidence, anchor=sub_anchor
    )
    for q, c in enumerate(active.tolist()):
        empty[c] = {
            "condition": names[c],
            "score": _num(scale[q]),
            "ci_low": _num(low[q]),
            "ci_high": _num(high[q]),
        }
    missing = [names[c] for c in range(len(names)) if c not in set(active.tolist())]
    return empty, (f"never compared: {', '.join(missing)}" if missing else None)


def _participants(counts: VoteCounts) -> dict[str, Any]:
    """Each participant's votes, scores per condition (pooled) and coefficient of consistence."""
    t = counts.tensor.sum(axis=1)  # (P, n, n, 3) pooled over clips
    won = wins(t)
    beats = won > np.swapaxes(won, -1, -2)
    table = consistence_table(beats)
    scores = won.sum(axis=-1).tolist()
    votes = t.sum(axis=(1, 2, 3)).tolist()
    undecided = t[..., 2].sum(axis=(1, 2)).tolist()
    clips = (counts.tensor.sum(axis=(2, 3, 4)) > 0).sum(axis=1).tolist()
    out: dict[str, Any] = {}
    for q, pid in enumerate(counts.participants):
        out[pid] = {
            "votes": votes[q],
            "undecided": undecided[q],
            "clips": clips[q],
            "ballots": dict(zip(counts.conditions, scores[q], strict=True)),
            "consistence": consistence_row(table, q),
        }
    return out


def _consistence_summary(participants: dict[str, Any], n: int) -> dict[str, Any]:
    z = np.array([p["consistence"]["zeta"] for p in participants.values()], dtype=float)
    p = np.array(
        [
            np.nan if p["consistence"]["p"] is None else p["consistence"]["p"]
            for p in participants.values()
        ]
    )
    smallest = consistence_p(np.zeros(1), n)[0][0] if n >= 3 else np.nan
    return {
        "participants": len(z),
        "conditions": n,
        "min_p": _num(smallest),
        "tested": int((~np.isnan(p)).sum()),
        "significant_05": int((p < 0.05).sum()),
        "median_zeta": _num(np.nanmedian(z)) if (~np.isnan(z)).any() else None,
        "mean_zeta": _num(np.nanmean(z)) if (~np.isnan(z)).any() else None,
    }


def _analysed_rows(table: VotesTable) -> tuple[VotesTable, int, dict[str, str]]:
    """The votes the statistics use: catch trials (``kind``) and participants the export marks
    ``excluded`` are left out. Returns the table, the number of catch votes and, per participant
    left out, the reason (the first one their rows give)."""
    frame = table.frame
    if "kind" not in frame or "excluded" not in frame:  # built by hand, not read
        return table, 0, {}
    catch = ~frame["kind"].isin(ANALYSED_KINDS).to_numpy()
    excluded = (frame["excluded"] != "").to_numpy()
    left_out = (
        frame.loc[excluded]
        .drop_duplicates("participant")
        .set_index("participant")["excluded"]
        .to_dict()
    )
    keep = ~catch & ~excluded
    if keep.all():
        return table, 0, {}
    kept = VotesTable(
        frame[keep].reset_index(drop=True), table.skipped, table.problems, table.source
    )
    return kept, int((catch & ~excluded).sum()), {str(k): str(v) for k, v in left_out.items()}


#: Progress steps the mixed model is given (its variance updates, usually 20-40).
MIXED_STEPS = 40


def analyze(
    votes: VotesTable | pd.DataFrame | str | Path,
    *,
    conditions: Sequence[str] | None = None,
    undecided: str = "exclude",
    skip_bad_rows: bool = False,
    bootstrap: int = 1000,
    seed: int = 0,
    confidence: float = 0.95,
    anchor: str | None = None,
    exclude: str | Sequence[str] | None = None,
    mixed_model: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Every statistic for a votes table (or a votes CSV path / frame).

    ``undecided`` is "exclude" (default: undecided votes count in ballots' undecided column
    only) or "split" (half a judgement to each side in scores, u and the scale; sign tests
    always report both). ``bootstrap`` replicates with ``seed`` give the intervals of the
    scale, the model and the effect sizes; ``anchor`` fixes that condition at 0 on the Case V
    scale instead of the mean. ``exclude`` holds participant-quality rules such as
    ``"catch<1.0,side_p<0.001"`` (:mod:`app.analysis.quality`); participants matching one are
    left out of every statistic and listed under ``quality.excluded``. ``mixed_model`` adds
    the Bradley-Terry-Davidson model with participant and clip random effects to the pooled
    section (:mod:`app.analysis.mixed_btd`; its cost grows with the cells of participant x
    clip x pair that hold votes). ``progress(done, total)`` is called as the sections and the
    mixed model's variance updates are done.

    The statistics run with one BLAS thread: their matrix products are small, and a BLAS
    pool spinning for the second core on a host with other work made the mixed model seven
    times slower (38 s against 5.6 s for 600,000 votes).
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return _analyze(
            votes,
            conditions=conditions,
            undecided=undecided,
            skip_bad_rows=skip_bad_rows,
            bootstrap=bootstrap,
            seed=seed,
            confidence=confidence,
            anchor=anchor,
            exclude=exclude,
            mixed_model=mixed_model,
            progress=progress,
        )


def _analyze(
    votes: VotesTable | pd.DataFrame | str | Path,
    *,
    conditions: Sequence[str] | None,
    undecided: str,
    skip_bad_rows: bool,
    bootstrap: int,
    seed: int,
    confidence: float,
    anchor: str | None,
    exclude: str | Sequence[str] | None,
    mixed_model: bool,
    progress: Callable[[int, int], None] | None,
) -> dict[str, Any]:
    if undecided not in UNDECIDED_TREATMENTS:
        raise InputError(
            f"must be one of {', '.join(UNDECIDED_TREATMENTS)}, got {undecided!r}",
            field="undecided",
        )
    if not 0.0 < confidence < 1.0:
        raise InputError(f"must lie between 0 and 1, got {confidence}", field="confidence")
    table = (
        votes
        if isinstance(votes, VotesTable)
        else read_votes(votes, skip_bad_rows=skip_bad_rows, conditions=conditions)
    )
    table, catch_votes, left_out = _analysed_rows(table)
    if len(table) == 0:
        raise InputError("no valid votes to analyse", path=table.source)
    rules = parse_rules(exclude)
    # Appropriateness pairs (the same condition with its own and another clip's motion)
    # have their own test; the pair statistics see the comparisons of conditions only.
    appropriate = appropriateness(table.frame)
    table = without_appropriateness(table)
    if len(table) == 0:
        raise InputError("no valid votes to analyse", path=table.source)
    counts = count_votes(table, conditions)
    names = counts.conditions
    quality = participant_quality(counts, table.frame)
    excluded = excluded_participants(quality, rules)
    if excluded:
        kept = ~table.frame["participant"].isin(list(excluded))
        if not kept.any():
            raise InputError(
                f"the rules {', '.join(map(str, rules))} exclude every participant", field="exclude"
            )
        table = VotesTable(
            table.frame[kept].reset_index(drop=True), table.skipped, table.problems, table.source
        )
        counts = count_votes(table, names)
    anchor_idx = None
    if anchor is not None:
        if anchor not in names:
            raise InputError(f"unknown condition {anchor!r}", field="anchor")
        anchor_idx = names.index(anchor)
    kw: dict[str, Any] = {
        "undecided": undecided,
        "bootstrap": bootstrap,
        "seed": seed,
        "confidence": confidence,
        "anchor": anchor_idx,
    }
    # the sections count one each; the mixed model its variance updates (a few dozen)
    sections = len(counts.clips) + 1
    total = sections + (MIXED_STEPS if mixed_model else 0)
    report = progress or (lambda done, of: None)
    lock = threading.Lock()
    done = {"sections": 0, "updates": 0}

    def advance(key: str, value: int | None = None) -> None:
        with lock:
            done[key] = done[key] + 1 if value is None else min(value, MIXED_STEPS - 1)
            report(done["sections"] + done["updates"], total)

    # The mixed model runs beside the sections, on the other core: numpy gives up the GIL in
    # its array loops, and the two read the counts only, so the numbers are those of one
    # after the other
    with ThreadPoolExecutor(max_workers=1) as pool:
        mixed = (
            pool.submit(
                mixed_btd_summary,
                counts.tensor,
                names,
                confidence=confidence,
                progress=lambda updates, cap: advance("updates", updates),
            )
            if mixed_model
            else None
        )
        clips = {}
        for k, clip in enumerate(counts.clips):
            clips[clip] = _section(counts.tensor[:, k], names, **kw)
            advance("sections")
        pooled = _section(counts.tensor.sum(axis=1), names, **kw)
        advance("sections")
        participants = _participants(counts)
        pooled["consistence"] = _consistence_summary(participants, len(names))
        pooled["mixed_btd"] = mixed.result() if mixed is not None else None
    report(total, total)
    return {
        "conditions": list(names),
        "input": {
            "source": table.source,
            "votes": len(table),
            "skipped_rows": table.skipped,
            "problems": list(table.problems),
            "participants": len(counts.participants),
            "clips": list(counts.clips),
            "excluded_participants": len(excluded),
            "catch_votes": catch_votes,
            "left_out": left_out,
        },
        "options": {
            "undecided": undecided,
            "bootstrap": bootstrap,
            "seed": seed,
            "confidence": confidence,
            "anchor": anchor,
            "scale": "Thurstone Case V, least squares, JOD units",
            "jod_sigma": JOD_SIGMA,
            "exclude": [str(r) for r in rules],
            "mixed_model": mixed_model,
        },
        "clips": clips,
        "pooled": pooled,
        "participants": participants,
        "quality": {
            "rules": [str(r) for r in rules],
            "excluded": excluded,
            "fields": dict(QUALITY_FIELDS),
            "participants": quality,
        },
        "appropriateness": appropriate,
        "strengths": strength_summary(table.frame, names),
        "reasons": reason_summary(table.frame, names),
    }
