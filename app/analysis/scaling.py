"""Thurstone Case V scale with bootstrap confidence intervals over participants.

Case V (Thurstone 1927; Mosteller 1951) models each judgement of i against j as comparing two
normal variables of equal variance: P(i preferred to j) = Phi((s_i - s_j) / sigma'). From the
observed proportion P_ij = c_ij / (c_ij + c_ji) each judged pair gives a difference
d_ij = sigma * Phi^-1(P_ij); the scale solves the weighted least-squares problem

    minimise  sum over judged pairs of n_ij (s_i - s_j - d_ij)^2,   n_ij = c_ij + c_ji

(for a complete, balanced design this is Mosteller's row-mean solution; for a chain of pairs it
reproduces every d_ij exactly). Units are JOD (just objectionable differences) with
sigma = 1 / Phi^-1(0.75) = 1.4826, so that a difference of 1 means 75 % preference.
Unanimous pairs (P = 0 or 1) are clipped to 1/(2 n_ij) and 1 - 1/(2 n_ij). The scale is fixed
by a mean of 0, or by a chosen anchor condition at 0. Confidence intervals are percentile
intervals of the scale recomputed on participants resampled with replacement (seeded).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike
from scipy import sparse, stats
from scipy.sparse.csgraph import connected_components

JOD_SIGMA = float(1.0 / stats.norm.ppf(0.75))  # 1.482602: 1 JOD = 75 % preference


def _differences(c: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Weights n_ij and differences d_ij = sigma Phi^-1(P_ij) (rows i, columns j), batched."""
    n = c + np.swapaxes(c, -1, -2)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = np.where(n > 0, c / np.where(n > 0, n, 1.0), 0.5)
        eps = np.where(n > 0, 0.5 / np.where(n > 0, n, 1.0), 0.0)
    p = np.clip(p, eps, 1.0 - eps)
    return n, sigma * stats.norm.ppf(p)


def connected(counts: ArrayLike) -> bool:
    """Whether the judged pairs link every condition (the scale is defined only then)."""
    c = np.asarray(counts, dtype=float)
    off = c + c.T
    np.fill_diagonal(off, 0.0)
    k, _ = connected_components(sparse.csr_matrix(off > 0), directed=False)
    return bool(k == 1)


def thurstone_case_v(
    counts: ArrayLike, *, anchor: int | None = None, sigma: float = JOD_SIGMA
) -> np.ndarray:
    """Case V scale values; ``counts[..., i, j]`` = judgements of i over j (batched allowed).

    Returns NaN where the comparison graph is not connected.

    >>> bool(np.allclose(thurstone_case_v([[0, 25, 0], [75, 0, 25], [0, 75, 0]]), [-1, 0, 1]))
    True
    >>> thurstone_case_v([[0, 25, 0], [75, 0, 25], [0, 75, 0]], anchor=0).round(6).tolist()
    [0.0, 1.0, 2.0]
    """
    c = np.asarray(counts, dtype=float).copy()
    k = c.shape[-1]
    idx = np.arange(k)
    c[..., idx, idx] = 0.0
    w, d = _differences(c, sigma)
    w[..., idx, idx] = 0.0
    # Normal equations L s = b: L the weighted graph Laplacian, b_i = sum_j n_ij d_ij.
    lap = -w
    lap[..., idx, idx] = w.sum(axis=-1)
    b = (w * d).sum(axis=-1)
    # Adding the all-ones matrix / k fixes the mean at 0 without changing a connected solution.
    system = lap + 1.0 / k
    cond = np.linalg.cond(system)
    good = np.isfinite(cond) & (cond < 1e12)
    safe = np.where(good[..., None, None], system, np.eye(k))
    s = np.linalg.solve(safe, b[..., None])[..., 0]
    s = np.where(good[..., None], s, np.nan)
    if anchor is not None:
        s = s - s[..., anchor : anchor + 1]
    return s


def canonical_participant_order(per_participant: np.ndarray) -> np.ndarray:
    """Order participants by their data, so the bootstrap does not depend on their labels.

    The order is lexicographic in each participant's values (ties keep their places). Counts
    are packed several to a 64-bit key first (the order of the keys is that of the values),
    so the sort takes a few keys instead of hundreds.

    >>> canonical_participant_order(np.array([[1, 0], [0, 2], [0, 1], [1, 0]])).tolist()
    [2, 1, 0, 3]
    """
    flat = per_participant.reshape(per_participant.shape[0], -1)
    keys = _packed_counts(flat)
    return np.lexsort((flat if keys is None else keys).T[::-1])


def _packed_counts(flat: np.ndarray) -> np.ndarray | None:
    """(rows, keys) uint64 whose lexicographic order is that of the rows of ``flat``, for
    whole non-negative values below 2**32; None for other values.

    Each row is written as one big-endian byte string of its values, all in the width the
    largest needs (a bit each for 0 and 1), and read back 8 bytes to a key: the order of
    byte strings of one length is that of their values."""
    if flat.size == 0:
        return None
    if not np.issubdtype(flat.dtype, np.integer):
        with np.errstate(invalid="ignore"):
            if not np.all(flat == np.floor(flat)):  # NaN too
                return None
    low, high = flat.min(), flat.max()
    if low < 0 or high >= 2**32:
        return None
    if high <= 1:
        text = np.packbits(flat.astype(np.uint8), axis=1)
    else:
        width = ">u1" if high < 2**8 else ">u2" if high < 2**16 else ">u4"
        text = np.ascontiguousarray(flat.astype(width)).view(np.uint8)
    rows, size = text.shape
    padded = np.zeros((rows, -(-size // 8) * 8), np.uint8)
    padded[:, :size] = text  # the same zeros end every row: the order is kept
    return padded.view(">u8").astype(np.uint64)


@functools.lru_cache(maxsize=4)
def bootstrap_weights(n_part: int, replicates: int, seed: int) -> np.ndarray:
    """(replicates, n_part) counts: how often each participant is drawn in each resample.

    A resample of participants with replacement is a weight vector, so a statistic that is a
    sum over participants is recomputed for all replicates at once as ``weights @ data``.
    The same draws serve every statistic of an analysis (the pooled votes and each clip's,
    the scale, the scores and the signed-rank effect sizes): they are drawn once, as the
    float32 rows of :func:`bootstrap_rows`, and handed out read-only.

    >>> bootstrap_weights(5, 3, seed=0).sum(axis=1).tolist()
    [5, 5, 5]
    """
    counts = bootstrap_rows(n_part, replicates, seed).astype(
        np.int32 if n_part < 2**31 else np.int64
    )
    counts.flags.writeable = False
    return counts


@functools.lru_cache(maxsize=4)
def bootstrap_rows(n_part: int, replicates: int, seed: int) -> np.ndarray:
    """The resamples' weights as drawn: (replicates, n_part) float32, read-only, the
    left-hand side of the dense products below (whole counts below 2**24 are exact in
    float32; a participant is drawn that often only among more than 16 million).

    Drawn :data:`_DRAWN_ROWS` resamples at a time (10,000 participants x 1,000 resamples take
    0.05-0.1 s): the draws of all of them at once, and an integer copy beside the float32
    one, were another 80 MB to fault in."""
    rng = np.random.default_rng(seed)
    kind = np.int32 if n_part < 2**31 else np.int64
    rows = np.empty((replicates, n_part), np.float32)
    for start in range(0, replicates, _DRAWN_ROWS):
        block = rows[start : start + _DRAWN_ROWS]
        draws = rng.integers(0, n_part, size=block.shape, dtype=kind)
        for row, drawn in zip(block, draws, strict=True):
            row[:] = np.bincount(drawn, minlength=n_part)
    rows.flags.writeable = False
    return rows


#: Resamples :func:`bootstrap_rows` draws in one call (part of what the seed gives).
_DRAWN_ROWS = 64


@functools.lru_cache(maxsize=4)
def bootstrap_columns(n_part: int, replicates: int, seed: int) -> np.ndarray:
    """The weights of :func:`bootstrap_weights` by participant, ``(n_part, replicates)``
    float32, contiguous and read-only: the right-hand side of the sparse products below."""
    columns = np.ascontiguousarray(bootstrap_rows(n_part, replicates, seed).T)
    columns.flags.writeable = False
    return columns


#: :func:`resampled_sums` multiplies densely when at least this share of the data is
#: non-zero: a dense float32 product (BLAS) does a multiply-add 8-14 times faster than the
#: sparse one, whose rows are scattered (measured at 10,000 participants x 1,000 resamples).
DENSE_FROM = 1.0 / 8.0


def resampled_sums(data: np.ndarray, replicates: int, seed: int) -> np.ndarray:
    """``bootstrap_weights(P, replicates, seed) @ data`` for ``data`` (P, F): each
    resample's sums over its participants, (replicates, F), to the same digits.

    Sums of halves (undecided votes split) and whole counts are exact in float32 below
    2**23, in any order of addition, which holds for any study whose resampled totals stay
    under 8 million votes; the product is then float32: dense (BLAS) when at least
    :data:`DENSE_FROM` of the data is non-zero, else over the non-zero counts only (a clip
    with many conditions shows each participant a few of its pairs), the sparse data times
    the columns of :func:`bootstrap_columns`. Otherwise the product is dense float64.
    """
    data = np.asarray(data)
    if not np.issubdtype(data.dtype, np.integer):
        data = np.asarray(data, dtype=np.float64)
    n_part = data.shape[0]
    # whole counts need no test; halves are whole once doubled
    exact = np.issubdtype(data.dtype, np.integer) or bool(
        np.all((halves := data * 2.0) == np.round(halves))
    )
    heaviest = _heaviest(n_part, replicates, seed)
    if not exact or np.abs(data).sum(axis=0).max(initial=0) * heaviest >= 2.0**23:
        weights = bootstrap_weights(n_part, replicates, seed)
        return np.asarray(weights @ data.astype(np.float64), np.float64)
    # columns without a count (a pair no one was shown) sum to 0: left out of the product
    used = np.flatnonzero(data.any(axis=0))
    out = np.zeros((replicates, data.shape[1]))
    if used.size < data.shape[1]:
        data = data[:, used]
    if np.count_nonzero(data) >= DENSE_FROM * data.size:
        out[:, used] = bootstrap_rows(n_part, replicates, seed) @ data.astype(np.float32)
    else:
        rows = sparse.csr_matrix(data.T.astype(np.float32))
        out[:, used] = (rows @ bootstrap_columns(n_part, replicates, seed)).T
    return out


@functools.lru_cache(maxsize=4)
def _heaviest(n_part: int, replicates: int, seed: int) -> int:
    """The most times any participant is drawn in one resample of :func:`bootstrap_weights`."""
    return int(bootstrap_rows(n_part, replicates, seed).max(initial=0))


def bootstrap_scale(
    per_participant: np.ndarray,
    *,
    replicates: int = 1000,
    seed: int = 0,
    confidence: float = 0.95,
    anchor: int | None = None,
    sigma: float = JOD_SIGMA,
    resampled: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scale and percentile CI from participants resampled with replacement.

    ``per_participant[p, i, j]``: participant p's judgements of i over j. Participants are put
    in a canonical order (by their data) before resampling, so relabelling them changes nothing;
    ``resampled`` (replicates, k, k), each resample's sums made already, replaces that.
    Returns (scale, ci_low, ci_high); CI bounds are NaN where too few replicates were defined.
    """
    data = np.asarray(per_participant, dtype=float)
    scale = thurstone_case_v(data.sum(axis=0), anchor=anchor, sigma=sigma)
    n_part, k = data.shape[0], data.shape[-1]
    if replicates <= 0 or n_part < 2 or np.isnan(scale).all():
        nan = np.full(k, np.nan)
        return scale, nan, nan
    if resampled is None:
        data = data[canonical_participant_order(data)]
        resampled = resampled_sums(data.reshape(n_part, -1), replicates, seed)
    boot = resampled.reshape(replicates, k, k)
    values = thurstone_case_v(boot, anchor=anchor, sigma=sigma)
    ok = ~np.isnan(values).any(axis=1)
    if ok.sum() < max(10, replicates // 2):
        nan = np.full(k, np.nan)
        return scale, nan, nan
    tail = (1.0 - confidence) / 2.0 * 100.0
    low, high = np.percentile(values[ok], [tail, 100.0 - tail], axis=0)
    return scale, low, high
