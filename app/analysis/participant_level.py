"""Participant-level inference: one observation per participant and pair, not per presentation.

The pooled tests (sign tests, Kendall & Babington Smith's u) count every presentation as an
independent judge. A participant who sees a pair in both side orders, on several clips or
repeatedly contributes several correlated judgements, so pooled counts overstate the evidence.
Here each participant is one unit of observation for each unordered pair (a, b):

    d_p = (wins_a - wins_b) / n_p        n_p = all of p's votes on the pair, undecided included

and the conditions are compared by a Wilcoxon signed-rank test of the d_p across participants
(Wilcoxon 1945, :mod:`app.analysis.signed_rank`: the p of ``scipy.stats.wilcoxon`` with
zero_method "wilcox", participants with d_p = 0 dropped, two-sided). Effect size: the
matched-pairs rank-biserial correlation (Kerby 2014, "The simple difference formula")

    r = (T+ - T-) / (T+ + T-)      T+ / T- = sums of the ranks of |d_p| over positive / negative d_p

in [-1, 1] (1: every participant with a net preference prefers a). Its confidence interval is
the percentile bootstrap over participants. Holm (1979) adjusts over the pairs of one clip.

Kendall & Babington Smith's u and the sign tests are also recomputed with one judgement per
participant and pair: the majority of that participant's votes on the pair, a tie (equal wins,
or only undecided votes) counting 1/2 to each side.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import sparse, stats

from app.analysis.agreement import coefficient_of_agreement
from app.analysis.counts import undecided_pairs, wins, with_votes
from app.analysis.json_values import json_number as _num
from app.analysis.scaling import DENSE_FROM, bootstrap_columns, canonical_participant_order
from app.analysis.section_resamples import SectionResamples, pair_groups
from app.analysis.signed_rank import signed_rank_test
from app.analysis.signtest import sign_test_p
from app.analysis.ttest import holm

ONE_PER_PARTICIPANT_RULE = (
    "one judgement per participant and pair: the majority of that "
    "participant's votes on the pair, a tie counting 1/2 to each side"
)


def pair_counts(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per participant and unordered pair (a < b in condition order): wins of a, of b, undecided.

    ``t`` is (P, n, n, 3): votes with the row condition left, the column condition right and
    answer left / right / undecided. Returns three (P, C(n, 2)) arrays, pairs in
    ``np.triu_indices(n, 1)`` order; same-condition votes are not part of any pair.
    """
    n = t.shape[-2]
    i, j = np.triu_indices(n, 1)
    won, und = wins(t), undecided_pairs(t)
    return won[:, i, j], won[:, j, i], und[:, i, j]


def net_preference(t: np.ndarray) -> np.ndarray:
    """(P, C(n, 2)) d_p = (wins_a - wins_b) / n_p; NaN where p never judged the pair."""
    wa, wb, und = pair_counts(t)
    total = wa + wb + und
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (wa - wb) / np.where(total > 0, total, 1), np.nan)


def rank_biserial(d: ArrayLike) -> float | None:
    """Matched-pairs rank-biserial correlation of differences ``d`` (zeros dropped).

    >>> rank_biserial([0.5, 1.0, -0.25, 0.0])  # ranks 2, 3 positive, 1 negative: (5 - 1) / 6
    0.6666666666666666
    """
    x = np.asarray(d, dtype=float)
    x = x[~np.isnan(x) & (x != 0)]
    if x.size == 0:
        return None
    ranks = stats.rankdata(np.abs(x))
    plus = float(ranks[x > 0].sum())
    total = float(ranks.sum())
    return (2.0 * plus - total) / total


def bootstrap_rank_biserial(d: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """r of every resample at once; ``weights[b, p]`` = times participant p is drawn in b
    (or, to share one copy between calls, its transpose as float32: ``columns[p, b]``, see
    :func:`resample_columns`).

    A participant drawn w times adds w tied values, so the mid-rank of a group of equal |d| is
    (weight of all smaller values) + (weight of the group + 1) / 2: the ranks follow from
    cumulative weights over the sorted distinct |d|, without sorting each resample.
    Participants with NaN or zero d carry no rank (zero_method "wilcox").
    """
    columns = weights if weights.dtype == np.float32 else resample_columns(weights)
    replicates = columns.shape[1]
    rows, cols, g = pair_groups(d)
    if g == 0:
        return np.full(replicates, np.nan)
    member = sparse.csr_matrix(
        (np.ones(rows.size, np.float32), (rows, cols)), shape=(2 * g, columns.shape[0])
    )
    # (replicates, 2g), whole counts, exact in float32 in any order of addition; dense
    # where the indicator is (a few distinct |d| with most participants in one)
    dense = member.nnz >= DENSE_FROM * member.shape[0] * member.shape[1]
    sums = ((member.toarray() if dense else member) @ columns).T.astype(np.float64)
    return rank_biserial_of_groups(sums[:, :g], sums[:, g:])


def rank_biserial_of_groups(in_group: np.ndarray, positive_w: np.ndarray) -> np.ndarray:
    """r of each resample from its weight in each group of equal ``|d|`` (ascending) and in
    that group's positive part, both (replicates, g): the mid-rank of a group is the weight
    of the groups before it plus (its weight + 1) / 2 (:func:`bootstrap_rank_biserial`)."""
    before = np.cumsum(in_group, axis=1) - in_group
    mid = before + (in_group + 1.0) / 2.0
    plus = (mid * positive_w).sum(axis=1)
    size = in_group.sum(axis=1)
    total = size * (size + 1.0) / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(size > 0, (2.0 * plus - total) / np.where(size > 0, total, 1.0), np.nan)


def resample_columns(weights: np.ndarray) -> np.ndarray:
    """The resamples' weights by participant, ``(n_part, replicates)`` float32 (exact: whole
    counts below 2**24), contiguous for the sparse products above."""
    return np.ascontiguousarray(np.asarray(weights).T, dtype=np.float32)


def _percentile_ci(values: np.ndarray, confidence: float) -> list[float | None]:
    ok = values[~np.isnan(values)]
    if ok.size < max(10, values.size // 2):
        return [None, None]
    tail = (1.0 - confidence) / 2.0 * 100.0
    low, high = np.percentile(ok, [tail, 100.0 - tail])
    return [_num(low), _num(high)]


def participant_level_tests(
    t: np.ndarray,
    names: Sequence[str],
    *,
    bootstrap: int = 1000,
    seed: int = 0,
    confidence: float = 0.95,
    resamples: SectionResamples | None = None,
) -> list[dict[str, Any]]:
    """Wilcoxon signed-rank test of d_p per pair, rank-biserial r with bootstrap CI, Holm.

    ``t`` is (P, n, n, 3) for one clip (or pooled over clips). Participants are put in an order
    given by their data before resampling, so relabelling them changes nothing. ``resamples``:
    the section's resampled sums (:func:`app.analysis.section_resamples.resample_section`) of
    ``t``'s participants with votes, already in that order; without them each pair is
    resampled here. Returns one dict per pair that at least one participant judged: a, b,
    n_participants, median_d, W, p, p_holm, effect, effect_ci.
    """
    t = with_votes(t)
    if t.shape[0] > 1 and resamples is None:
        t = t[canonical_participant_order(t)]
    d = net_preference(t) if resamples is None else resamples.d
    i, j = np.triu_indices(len(names), 1)
    resampled = bootstrap > 0 and t.shape[0] > 1 and resamples is None
    # one copy of the resamples' weights for every pair (and every section)
    columns = bootstrap_columns(t.shape[0], bootstrap, seed) if resampled else None
    rows = []
    for q, (a, b) in enumerate(zip(i, j, strict=True)):
        col = d[:, q]
        judged = col[~np.isnan(col)]
        if judged.size == 0:
            continue
        row: dict[str, Any] = {
            "a": names[int(a)],
            "b": names[int(b)],
            "n_participants": int(judged.size),
            "median_d": _num(np.median(judged)),
            "W": None,
            "p": None,
        }
        if np.any(judged != 0):
            w, p = signed_rank_test(judged[None, :])
            row["W"], row["p"] = _num(w[0]), _num(p[0])
        row["effect"] = rank_biserial(judged)
        row["effect_ci"] = [None, None]
        if resamples is not None:
            r_boot = rank_biserial_of_groups(*resamples.groups[q])
            row["effect_ci"] = _percentile_ci(r_boot, confidence)
        elif columns is not None:
            row["effect_ci"] = _percentile_ci(bootstrap_rank_biserial(col, columns), confidence)
        rows.append(row)
    adjusted = holm([np.nan if r["p"] is None else r["p"] for r in rows])
    for r, ph in zip(rows, adjusted, strict=True):
        r["p_holm"] = _num(ph)
    return rows


def one_judgement_per_participant(t: np.ndarray, names: Sequence[str]) -> dict[str, Any]:
    """u and sign tests with each participant's majority on a pair as their one judgement.

    ``t`` is (P, n, n, 3). The preference matrix a[i, j] counts participants whose votes favour
    i over j, plus 1/2 for each participant tied on the pair; sign tests count the participants
    for a, for b and tied (p: ties excluded; p_split: ties half to each side).
    """
    n = len(names)
    wa, wb, und = pair_counts(t)
    judged = (wa + wb + und) > 0
    for_a, for_b = (wa > wb) & judged, (wb > wa) & judged
    tied = judged & (wa == wb)
    i, j = np.triu_indices(n, 1)
    a = np.zeros((n, n))
    a[i, j] = for_a.sum(axis=0) + 0.5 * tied.sum(axis=0)
    a[j, i] = for_b.sum(axis=0) + 0.5 * tied.sum(axis=0)
    agree: dict[str, Any] = {
        k: (v if isinstance(v, int) or v is None else _num(v))
        for k, v in coefficient_of_agreement(a).as_dict().items()
    }
    signs = []
    for q, (x, y) in enumerate(zip(i, j, strict=True)):
        win, loss, tie = int(for_a[:, q].sum()), int(for_b[:, q].sum()), int(tied[:, q].sum())
        if win + loss + tie == 0:
            continue
        signs.append(
            {
                "a": names[int(x)],
                "b": names[int(y)],
                "participants_for_a": win,
                "participants_for_b": loss,
                "participants_tied": tie,
                "p": _num(sign_test_p(win, loss, tie)),
                "p_split": _num(sign_test_p(win, loss, tie, undecided_rule="split")),
            }
        )
    for s, ph in zip(signs, holm([s["p"] for s in signs]) if signs else [], strict=True):
        s["p_holm"] = _num(ph)
    return {"rule": ONE_PER_PARTICIPANT_RULE, "agreement": agree, "sign_tests": signs}
