"""The bootstrap of one section (a clip, or every clip pooled), every resampled sum at once.

Each statistic of a section with a bootstrap interval is a function of sums over the
participants of one resample: the Case V scale of the resampled judgements, the
Bradley-Terry-Davidson refit of the resampled vote counts (:mod:`app.analysis.btd`) and the
rank-biserial correlation of the participants' net preferences
(:mod:`app.analysis.participant_level`, from the resampled weight of each group of equal
``|d|``). A resample is a weight per participant (:func:`app.analysis.scaling.bootstrap_weights`),
so all of those sums are one product of the weights with the section's data side by side:
the weights are read once per section instead of once per statistic and pair, and every
statistic of the section sees the same resampled participants.

The participants are put in one order given by their votes (:func:`section_order`), so
relabelling them changes nothing, and neither does showing every pair the other way round:
the order is by what each participant judged, sides aside, first. The judgements the scale
uses are a linear function of the counts (:func:`app.analysis.counts.wins`), so their
resampled sums come from the counts' own, exactly: the sums are whole numbers or halves,
exact in float32 below 2**23 in any order of addition
(:func:`app.analysis.scaling.resampled_sums`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.analysis.counts import undecided_pairs, wins
from app.analysis.scaling import canonical_participant_order, resampled_sums


@dataclass(frozen=True)
class SectionResamples:
    """The resampled sums of a section: ``counts`` (replicates, n, n, 3), the vote counts of
    each resample, and per unordered pair (``np.triu_indices(n, 1)`` order) the resampled
    weights of each group of equal ``|d|`` and of its positive part (:func:`pair_groups`),
    with ``d`` (P, C(n, 2)) the participants' net preferences they were made from."""

    counts: np.ndarray
    groups: tuple[tuple[np.ndarray, np.ndarray], ...]
    d: np.ndarray

    def judgements(self, undecided: str) -> np.ndarray:
        """(replicates, n, n): each resample's judgements of i over j, the diagonal 0."""
        judged = np.asarray(wins(self.counts, undecided), dtype=float)
        n = judged.shape[-1]
        judged[:, np.arange(n), np.arange(n)] = 0.0
        return judged


def pair_groups(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The indicator of a pair's net preferences ``d`` (P,) by group of equal ``|d|``:
    (rows, participants) of its non-zero entries, rows 0..g-1 the groups and g..2g-1 their
    positive members, and g. Participants with NaN or zero ``d`` are in no group (zero_method
    "wilcox")."""
    keep = np.flatnonzero(~np.isnan(d) & (d != 0))
    x = d[keep]
    distinct, group = np.unique(np.abs(x), return_inverse=True)
    g = distinct.size
    positive = x > 0
    rows = np.concatenate([group, g + group[positive]])
    return rows, np.concatenate([keep, keep[positive]]), g


def resample_section(t: np.ndarray, d: np.ndarray, replicates: int, seed: int) -> SectionResamples:
    """Every resampled sum of a section in one product (see the module's docstring).

    ``t`` (P, n, n, 3) holds the section's participants with votes, already in the order of
    :func:`section_order`, and ``d`` (P, C(n, 2)) their net preferences
    (:func:`app.analysis.participant_level.net_preference`)."""
    p, n = t.shape[0], t.shape[-2]
    width = n * n * 3
    spans, columns = [], [t.reshape(p, width)]
    start = width
    for q in range(d.shape[1]):
        rows, who, g = pair_groups(d[:, q])
        member = np.zeros((p, 2 * g), dtype=t.dtype)
        member[who, rows] = 1
        columns.append(member)
        spans.append((start, g))
        start += 2 * g
    sums = resampled_sums(np.hstack(columns), replicates, seed)
    counts = sums[:, :width].reshape(replicates, n, n, 3)
    groups = tuple((sums[:, s : s + g], sums[:, s + g : s + 2 * g]) for s, g in spans)
    return SectionResamples(counts, groups, d)


def section_order(t: np.ndarray) -> np.ndarray:
    """The order of a section's participants ``t`` (P, n, n, 3) that its resamples use:
    :func:`app.analysis.scaling.canonical_participant_order` of their judgements of i over j
    and undecided votes per pair, whichever side each condition was on, then of their votes
    as shown.

    Participants alike in the first two share their judgements and net preferences, so
    which of them takes which place changes none of the sums the Case V scale and the
    rank-biserial correlation are made from: those intervals stay the same when every pair
    is shown the other way round.
    """
    p, n = t.shape[0], t.shape[-2]
    upper = np.triu_indices(n, 1)
    key = np.concatenate(
        [
            wins(t).reshape(p, -1),
            undecided_pairs(t)[:, upper[0], upper[1]],
            t.reshape(p, -1),
        ],
        axis=1,
    )
    return canonical_participant_order(key)
