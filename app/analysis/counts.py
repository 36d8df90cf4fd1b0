"""Vote counts: the one array every statistic is computed from.

``VoteCounts.tensor[p, k, l, r, c]`` counts participant p's votes on clip k when condition l was
on the left and r on the right, with answer c (0 left, 1 right, 2 undecided). Ballots, the
confusion matrix, preference counts, per-participant scores and every test are sums over it,
so a vote is classified in exactly one place.

Thesis sec. 5.2: every ordered pair of the 4 x 4 combinations is shown, same-condition pairs
included; a vote on a same-condition pair is a ballot for that condition (collapsed ballots)
but carries no preference between conditions, so it is left out of u, sign tests and scaling.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from app.analysis.votes import CHOICES, VotesTable
from app.errors import InputError

UNDECIDED_TREATMENTS = ("exclude", "split")


@dataclass(frozen=True)
class VoteCounts:
    """Counts of votes by participant, clip, left condition, right condition and answer."""

    participants: tuple[str, ...]
    clips: tuple[str, ...]
    conditions: tuple[str, ...]
    tensor: np.ndarray  # (P, K, n, n, 3) int64

    def wins(self, undecided: str = "exclude") -> np.ndarray:
        """(P, K, n, n): judgements of i over j, whichever side i was on (:func:`wins`)."""
        return wins(self.tensor, undecided)

    def undecided_pairs(self) -> np.ndarray:
        """(P, K, n, n) symmetric: undecided votes on the unordered pair {i, j}."""
        return undecided_pairs(self.tensor)


def wins(tensor: np.ndarray, undecided: str = "exclude") -> np.ndarray:
    """(..., n, n): judgements of condition i over j, whichever side i was on.

    ``tensor`` is (..., n, n, 3) as in :class:`VoteCounts`: a ``left`` vote with i on the left
    and a ``right`` vote with i on the right are both judgements of i over j (thesis sec. 5.2).
    With ``undecided="split"`` every undecided vote adds 1/2 to both directions. The diagonal
    holds same-condition votes (a ballot for that condition).

    >>> t = np.zeros((2, 2, 3), dtype=np.int64)
    >>> t[0, 1, 0], t[0, 1, 2] = 3, 2  # a left, b right: 3 votes for the left, 2 undecided
    >>> t[1, 0, 1] = 1  # b left, a right: 1 vote for the right
    >>> wins(t).tolist(), wins(t, "split").tolist()
    ([[0, 4], [0, 0]], [[0.0, 5.0], [1.0, 0.0]])
    """
    w = tensor[..., 0] + np.swapaxes(tensor[..., 1], -1, -2)
    if undecided == "split":
        return w + 0.5 * undecided_pairs(tensor)
    if undecided != "exclude":
        raise InputError(
            f"undecided must be one of {', '.join(UNDECIDED_TREATMENTS)}, got {undecided!r}",
            field="undecided",
        )
    return w


def with_votes(t: np.ndarray) -> np.ndarray:
    """The participants of ``t`` (P, n, n, 3) who voted at all (``t`` itself when all did:
    a large study's section is not copied for nothing)."""
    seen = t.reshape(t.shape[0], -1).sum(axis=1) > 0
    return t if seen.all() else t[seen]


def undecided_pairs(tensor: np.ndarray) -> np.ndarray:
    """(..., n, n) symmetric: undecided votes on the unordered pair {i, j}."""
    u = tensor[..., 2]
    return u + np.swapaxes(u, -1, -2)


def count_votes(votes: VotesTable, conditions: Sequence[str] | None = None) -> VoteCounts:
    """Build :class:`VoteCounts`; conditions come from ``conditions`` or, sorted, from the data.

    A vote naming a condition outside an explicit list raises :class:`InputError`.
    """
    frame = votes.frame
    people, clip_cat = _categorical(frame["participant"]), _categorical(frame["clip"])
    left_cat, right_cat = _categorical(frame["left"]), _categorical(frame["right"])
    seen = set(map(str, left_cat.categories)) | set(map(str, right_cat.categories))
    if conditions is None:
        names = tuple(sorted(seen))
    else:
        names = tuple(dict.fromkeys(str(c).strip() for c in conditions))
        if not names or any(not c for c in names):
            raise InputError("give at least one non-empty condition name", field="conditions")
        unknown = sorted(seen - set(names))
        if unknown:
            raise InputError(
                f"votes name conditions not in the list: {', '.join(unknown)}",
                path=votes.source,
                field="conditions",
            )
    n_p, n_k, n_c = len(people.categories), len(clip_cat.categories), len(names)
    # the flat index ((((p * K + k) * n + l) * n + r) * 3 + c), built in place
    flat = people.codes.astype(np.int64)
    for size, codes in (
        (n_k, clip_cat.codes),
        (n_c, left_cat.set_categories(names).codes),
        (n_c, right_cat.set_categories(names).codes),
        (3, pd.Categorical(frame["choice"], categories=CHOICES).codes),
    ):
        flat *= size
        flat += codes
    tensor = np.bincount(flat, minlength=n_p * n_k * n_c * n_c * 3).reshape(n_p, n_k, n_c, n_c, 3)
    return VoteCounts(
        tuple(map(str, people.categories)), tuple(map(str, clip_cat.categories)), names, tensor
    )


def _categorical(column: pd.Series) -> pd.Categorical:
    """A column as a categorical of the values it holds (the reader's columns already are one;
    a filtered table keeps categories no row uses any more)."""
    if not isinstance(column.dtype, pd.CategoricalDtype):
        return pd.Categorical(column)
    codes = column.cat.codes.to_numpy()
    categories = column.cat.categories
    used = np.bincount(codes[codes >= 0], minlength=len(categories)) > 0
    if used.all():
        return pd.Categorical(column)
    kept = np.where(codes >= 0, (np.cumsum(used) - 1)[codes], -1)
    return pd.Categorical.from_codes(kept, categories=categories[used])


def ballots(tensor: np.ndarray) -> np.ndarray:
    """Times each condition was chosen, whichever side (last axis: conditions).

    ``tensor`` is (..., n, n, 3); same-condition votes count for that condition.
    """
    return tensor[..., 0].sum(axis=-1) + tensor[..., 1].sum(axis=-2)
