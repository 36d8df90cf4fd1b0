"""The statistics of one clip's votes, or of every clip's pooled: a SECTION of
:func:`app.analysis.results.analyze`'s result.

A SECTION holds the votes and participants counted, ballots, undecided votes, the confusion
matrix, per-participant scores, paired t-tests, the coefficient of agreement, sign tests, the
Thurstone Case V scale, the participant-level tests and the fixed Bradley-Terry-Davidson model;
docs/reference/analysis.md gives every field. Numbers are written through
:func:`app.analysis.json_values.json_number` (NaN as null).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from app.analysis.agreement import coefficient_of_agreement
from app.analysis.btd import btd_summary
from app.analysis.counts import ballots, undecided_pairs, wins
from app.analysis.json_values import json_number as _num
from app.analysis.participant_level import (
    net_preference,
    one_judgement_per_participant,
    participant_level_tests,
)
from app.analysis.scaling import bootstrap_scale, connected
from app.analysis.section_resamples import resample_section, section_order
from app.analysis.signtest import sign_test_p
from app.analysis.ttest import holm, paired_t_many


def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.triu_indices(n, 1)


def clip_statistics(
    t: np.ndarray,
    names: Sequence[str],
    *,
    undecided: str,
    bootstrap: int,
    seed: int,
    confidence: float,
    anchor: int | None,
) -> dict[str, Any]:
    """Statistics of one clip (or the pool): ``t`` is (P, n, n, 3) for that clip.

    ``undecided`` is how undecided votes count in scores, agreement and scale ("exclude" or
    "split"); ``bootstrap`` replicates with ``seed`` give the intervals at ``confidence``;
    ``anchor`` is the index of the condition fixed at 0 on the scale (None: the mean).
    """
    seen = t.sum(axis=(1, 2, 3)) > 0
    t = t if seen.all() else t[seen]
    # every resampled statistic from one product, in one order of the participants
    ordered, resamples = t, None
    if bootstrap > 0 and t.shape[0] > 1:
        ordered = t[section_order(t)]
        resamples = resample_section(ordered, net_preference(ordered), bootstrap, seed)
    total = t.sum(axis=0)
    n = len(names)
    won = wins(t)
    und = undecided_pairs(t)
    judged = wins(t, undecided).astype(float)
    off = ~np.eye(n, dtype=bool)

    # Per-participant scores: their ballots per condition (NaN where never shown).
    shown = (t.sum(axis=(2, 3)) + t.sum(axis=(1, 3))) > 0
    scores = np.where(shown, judged.sum(axis=-1), np.nan)
    paired = _paired_t(scores, names, confidence)
    agree = _agreement(judged, total, off, undecided)
    signs = _sign_tests(won, und, names)
    scale_rows, note = _scale(
        np.where(off, judged, 0.0),
        names,
        bootstrap=bootstrap,
        seed=seed,
        confidence=confidence,
        anchor=anchor,
        resampled=None if resamples is None else resamples.judgements(undecided),
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
            ordered,
            names,
            bootstrap=bootstrap,
            seed=seed,
            confidence=confidence,
            resamples=resamples,
        ),
        "one_per_participant": one_judgement_per_participant(t, names),
        "btd": btd_summary(
            ordered,
            names,
            bootstrap=bootstrap,
            seed=seed,
            confidence=confidence,
            resampled=None if resamples is None else resamples.counts,
        ),
    }


def _paired_t(scores: np.ndarray, names: Sequence[str], confidence: float) -> list[dict[str, Any]]:
    """Paired t-tests of the per-participant ``scores`` (P, n) on every pair of conditions,
    with Holm's adjustment over the pairs."""
    i, j = _pairs(len(names))
    tt = paired_t_many(scores[:, i], scores[:, j], confidence=confidence)
    p_holm = holm(tt["p"])
    return [
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


def _agreement(
    judged: np.ndarray, total: np.ndarray, off: np.ndarray, undecided: str
) -> dict[str, Any]:
    """The coefficient of agreement of the judgements pooled over participants (same-condition
    pairs, ``off`` the diagonal, left out), with the undecided rule and votes."""
    pooled_judged = np.where(off, judged.sum(axis=0), 0.0)
    raw_agree = coefficient_of_agreement(pooled_judged).as_dict()
    agree: dict[str, Any] = {k: _num(v) for k, v in raw_agree.items()}
    agree["undecided"] = undecided
    agree["undecided_votes"] = int(total[..., 2][off].sum())
    return agree


def _sign_tests(won: np.ndarray, und: np.ndarray, names: Sequence[str]) -> list[dict[str, Any]]:
    """Exact sign tests of every pair with votes (undecided votes excluded, split, or counted
    as losses), Holm-adjusted over those pairs."""
    w_all, u_all = won.sum(axis=0), und.sum(axis=0)
    signs = []
    for a, b in zip(*_pairs(len(names)), strict=True):
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
    return signs


def _scale(
    per_participant: np.ndarray,
    names: Sequence[str],
    *,
    bootstrap: int,
    seed: int,
    confidence: float,
    anchor: int | None,
    resampled: np.ndarray | None,
) -> tuple[list[dict[str, Any]], str | None]:
    """Case V rows for the conditions that were compared; others (and a split graph) get None.
    ``resampled``: each resample's judgements (replicates, n, n), or None to resample here."""
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
        sub,
        replicates=bootstrap,
        seed=seed,
        confidence=confidence,
        anchor=sub_anchor,
        resampled=None if resampled is None else resampled[:, active][:, :, active],
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
