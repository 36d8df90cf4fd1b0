"""From a votes table to every statistic of a paired-comparison study, per clip and pooled:
:func:`analyze` (also importable as ``app.analysis.analyze``).

The layout: ``{"clips": {CLIP: SECTION}, "pooled": SECTION,
"participants": {ID: {...}}}`` plus ``"conditions"``, ``"input"`` (source, votes, skipped bad
rows) and ``"options"`` (how undecided votes were treated, bootstrap settings). A SECTION holds
ballots, undecided, confusion, scores, paired_t, agreement, sign_tests and scale
(:func:`app.analysis.clip_statistics.clip_statistics`); see docs/reference/analysis.md for
every field. The result is plain JSON (NaN written as null).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from app.analysis.answer_details import reason_summary, strength_summary
from app.analysis.appropriateness import appropriateness, without_appropriateness
from app.analysis.clip_statistics import clip_statistics
from app.analysis.consistence import consistence_p, consistence_row, consistence_table
from app.analysis.counts import (
    UNDECIDED_TREATMENTS,
    VoteCounts,
    count_votes,
    wins,
)
from app.analysis.json_values import json_number as _num
from app.analysis.mixed_btd import mixed_btd_summary
from app.analysis.quality import (
    QUALITY_FIELDS,
    ExclusionRule,
    excluded_participants,
    parse_rules,
    participant_quality,
)
from app.analysis.scaling import JOD_SIGMA
from app.analysis.votes import ANALYSED_KINDS, VotesTable, read_votes
from app.errors import InputError


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
    """:func:`analyze` itself: the options checked, the votes the statistics use
    (:func:`_analysed_votes`), the sections and the mixed model (:func:`_sections`)."""
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
    used = _analysed_votes(table, conditions, exclude)
    table, counts, rules, excluded = used.table, used.counts, used.rules, used.excluded
    names = counts.conditions
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
    clips, pooled, participants = _sections(
        counts, kw, mixed_model=mixed_model, confidence=confidence, progress=progress
    )
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
            "catch_votes": used.catch_votes,
            "left_out": used.left_out,
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
            "participants": used.quality,
        },
        "appropriateness": used.appropriate,
        "strengths": strength_summary(table.frame, names),
        "reasons": reason_summary(table.frame, names),
    }


@dataclass(frozen=True)
class _AnalysedVotes:
    """The votes the statistics use and what was set aside on the way: catch votes and the
    participants the export left out (:func:`_analysed_rows`), the appropriateness test of the
    mismatch pairs, and the participants the quality ``rules`` exclude."""

    table: VotesTable
    counts: VoteCounts
    rules: list[ExclusionRule]
    quality: dict[str, Any]
    excluded: dict[str, list[str]]
    appropriate: dict[str, dict[str, Any]]
    catch_votes: int
    left_out: dict[str, str]


def _analysed_votes(
    table: VotesTable, conditions: Sequence[str] | None, exclude: str | Sequence[str] | None
) -> _AnalysedVotes:
    """The votes of ``table`` the pair statistics use, counted over ``conditions`` (None: the
    conditions voted on), with the participants the quality rules ``exclude`` holds left
    out."""
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
    return _AnalysedVotes(
        table, counts, rules, quality, excluded, appropriate, catch_votes, left_out
    )


#: The mixed model runs beside the sections only where the process may use more CPUs than
#: this. On a 2-CPU host the two at once took 16 % more CPU (the whole ``analyze`` of 600,000
#: votes: 5.1 against 4.3 CPU-s, each thread slower beside the other, 110 MB more memory
#: faulted in at once) for 8 % less wall time (3.8 against 4.1 s), and they left no CPU to
#: anything else on the host, such as the web workers beside a report job.
SIDE_BY_SIDE_ABOVE = 2


def side_by_side() -> bool:
    """Whether the mixed model runs beside the sections (more than
    :data:`SIDE_BY_SIDE_ABOVE` CPUs for this process)."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return cpus > SIDE_BY_SIDE_ABOVE


def _sections(
    counts: VoteCounts,
    kw: dict[str, Any],
    *,
    mixed_model: bool,
    confidence: float,
    progress: Callable[[int, int], None] | None,
) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """Each clip's section, the pooled one (with the participants' consistence and, when
    ``mixed_model``, the mixed model) and the participants, reporting to ``progress``; ``kw``
    holds the options of :func:`app.analysis.clip_statistics.clip_statistics`."""
    names = counts.conditions
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

    def sections_of_clips() -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
        clips = {}
        for k, clip in enumerate(counts.clips):
            clips[clip] = clip_statistics(counts.tensor[:, k], names, **kw)
            advance("sections")
        pooled = clip_statistics(counts.tensor.sum(axis=1), names, **kw)
        advance("sections")
        participants = _participants(counts)
        pooled["consistence"] = _consistence_summary(participants, len(names))
        return clips, pooled, participants

    def mixed() -> dict[str, Any] | None:
        if not mixed_model:
            return None
        return mixed_btd_summary(
            counts.tensor,
            names,
            confidence=confidence,
            progress=lambda updates, cap: advance("updates", updates),
        )

    # With cores to spare the mixed model runs beside the sections: numpy gives up the GIL
    # in its array loops, and the two read the counts only, so the numbers are those of one
    # after the other (:func:`side_by_side`)
    if mixed_model and side_by_side():
        with ThreadPoolExecutor(max_workers=1) as pool:
            beside = pool.submit(mixed)
            clips, pooled, participants = sections_of_clips()
            pooled["mixed_btd"] = beside.result()
    else:
        clips, pooled, participants = sections_of_clips()
        pooled["mixed_btd"] = mixed()
    report(total, total)
    return clips, pooled, participants
