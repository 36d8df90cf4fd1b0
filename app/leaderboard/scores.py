"""Scores: naturalness on an Elo scale, coherence as a share, rank bands and the preliminary flag.

**Naturalness** is the Bradley-Terry-Davidson model with ties and a side effect
(:func:`app.analysis.btd.fit_btd`; Davidson 1970, Davidson & Beaver 1977) fitted by maximum
likelihood to the naturalness votes of *every* round pooled: a clear and a slight preference
are both a preference, "cannot decide" is a tie with its own parameter nu (no hand-set weights
such as 4/2/1). Scores are log worths theta moved to an Elo scale,

    score_i = 1000 + (400 / ln 10) (theta_i - mean_a theta_a),

the mean over the season's fixed anchors (in every round, so the zero point never moves when a
system joins): 200 points is a preference of 76 % between decided votes (10^(200/400) = 3.16).
The 95 % interval is the percentile bootstrap over participants: participants (of all rounds)
resampled with replacement, every replicate refitted (:func:`app.analysis.btd.fit_btd_many`),
the same transform applied. ``facepair analyze`` on the published ``votes.csv`` fits the same
model (its ``pooled.btd``, centred on the mean of all systems: the scores differ by a constant).

**Coherence** is GENEA's mismatching score: of the decided mismatched-speech votes on a
system, the share for the face that moves with the speech heard (50 % is chance), with a
percentile bootstrap interval over the same participants' resamples.

**Rank bands** (:func:`rank_bands`): no bare ranks. Systems in order of score; the first opens
band 1 and leads it; each next system joins the current band while its interval overlaps the
leader's (its upper bound is at least the leader's lower bound), else it opens the next band
and leads it. A system without an interval cannot be told apart and joins the current band.

**Preliminary**: fewer naturalness votes than the season's ``[publish] min_votes`` (default
300, the TTS arena's rule), or measured only in a round whose anchors drifted
(:mod:`app.leaderboard.drift`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from app.analysis.btd import fit_btd, fit_btd_many
from app.analysis.scaling import canonical_participant_order, resampled_sums

ELO_ORIGIN = 1000.0
ELO_PER_LOG_WORTH = float(400.0 / np.log(10.0))


@dataclass(frozen=True)
class ScaleFit:
    """Scores on the Elo scale with their interval (NaN where a system has none), the model's
    side factor and tie parameter, and why there are no scores when the fit failed."""

    systems: tuple[str, ...]
    score: np.ndarray
    low: np.ndarray
    high: np.ndarray
    gamma: float
    nu: float
    replicates: int
    note: str | None = None


def to_elo(theta: np.ndarray, anchor_index: Sequence[int]) -> np.ndarray:
    """Log worths (last axis: systems) on the Elo scale, the anchors' mean at 1000.

    >>> to_elo(np.array([0.0, np.log(10.0)]), [0]).round(3).tolist()
    [1000.0, 1400.0]
    """
    theta = np.asarray(theta, dtype=float)
    origin = theta[..., list(anchor_index)].mean(axis=-1, keepdims=True)
    return ELO_ORIGIN + ELO_PER_LOG_WORTH * (theta - origin)


def _active(counts: np.ndarray) -> np.ndarray:
    """Systems with any vote against another."""
    pooled = counts.sum(axis=0)
    n = pooled.shape[0]
    off = np.where(~np.eye(n, dtype=bool), pooled.sum(axis=-1), 0.0)
    return np.flatnonzero((off + off.T).sum(axis=1) > 0)


def fit_scale(
    counts: np.ndarray,
    systems: Sequence[str],
    anchors: Sequence[str],
    *,
    bootstrap: int,
    seed: int,
    confidence: float,
) -> ScaleFit:
    """The naturalness scale of ``counts`` (P, n, n, 3): scores relative to ``anchors``.

    Systems never compared get NaN; so does everything when the anchors were not compared or
    the model has no finite maximum (a system won or lost every comparison), with the note.
    """
    names = tuple(systems)
    n = len(names)
    nan = np.full(n, np.nan)
    counts = np.asarray(counts, dtype=float)
    active = _active(counts)
    anchor_index = [k for k, s in enumerate(names) if s in set(anchors)]
    missing = [names[k] for k in anchor_index if k not in set(active.tolist())]
    if active.size < 2 or missing or not anchor_index:
        why = f"anchors never compared: {', '.join(missing)}" if missing else "too few votes"
        return ScaleFit(names, nan, nan.copy(), nan.copy(), np.nan, np.nan, 0, why)
    sub = counts[:, active][:, :, active]
    fit = fit_btd(sub.sum(axis=0))
    if not fit.converged:
        return ScaleFit(names, nan, nan.copy(), nan.copy(), np.nan, np.nan, 0, fit.note)
    local = [int(np.flatnonzero(active == k)[0]) for k in anchor_index]
    score = nan.copy()
    score[active] = to_elo(fit.theta, local)
    low, high = nan.copy(), nan.copy()
    used = 0
    people = sub[sub.sum(axis=(1, 2, 3)) > 0]
    if bootstrap > 0 and people.shape[0] > 1:
        people = people[canonical_participant_order(people)]
        p, m = people.shape[0], active.size
        boot = resampled_sums(people.reshape(p, -1), bootstrap, seed).reshape(-1, m, m, 3)
        beta, ok = fit_btd_many(boot)
        used = int(ok.sum())
        if used >= max(10, bootstrap // 2):
            values = to_elo(beta[ok][:, :m], local)
            tail = (1.0 - confidence) / 2.0 * 100.0
            lo, hi = np.percentile(values, [tail, 100.0 - tail], axis=0)
            low[active], high[active] = lo, hi
    return ScaleFit(names, score, low, high, float(fit.gamma), float(fit.nu), used, fit.note)


@dataclass(frozen=True)
class CoherenceFit:
    """Per system: the share (percent) of decided mismatched-speech votes for the matched face,
    its interval, and the decided votes behind it."""

    systems: tuple[str, ...]
    share: np.ndarray
    low: np.ndarray
    high: np.ndarray
    decided: np.ndarray


def fit_coherence(
    counts: np.ndarray, systems: Sequence[str], *, bootstrap: int, seed: int, confidence: float
) -> CoherenceFit:
    """Coherence of ``counts`` (P, n, 2: hits, decided votes per participant and system).

    >>> c = np.zeros((2, 1, 2)); c[0, 0] = [3, 4]; c[1, 0] = [1, 2]
    >>> fit_coherence(c, ["a"], bootstrap=0, seed=0, confidence=0.95).share.tolist()
    [66.66666666666667]
    """
    counts = np.asarray(counts, dtype=float)
    n = len(systems)
    total = counts.sum(axis=0) if counts.size else np.zeros((n, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(total[:, 1] > 0, 100.0 * total[:, 0] / total[:, 1], np.nan)
    low, high = np.full(n, np.nan), np.full(n, np.nan)
    p = counts.shape[0]
    if bootstrap > 0 and p > 1:
        ordered = counts[canonical_participant_order(counts)]
        boot = resampled_sums(ordered.reshape(p, -1), bootstrap, seed).reshape(-1, n, 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            values = 100.0 * boot[..., 0] / boot[..., 1]
        tail = (1.0 - confidence) / 2.0 * 100.0
        for k in range(n):
            column = values[:, k][np.isfinite(values[:, k])]
            if column.size >= max(10, bootstrap // 2):
                low[k], high[k] = np.percentile(column, [tail, 100.0 - tail])
    return CoherenceFit(tuple(systems), share, low, high, total[:, 1])


def rank_bands(
    names: Sequence[str],
    score: Sequence[float] | np.ndarray,
    low: Sequence[float] | np.ndarray,
    high: Sequence[float] | np.ndarray,
) -> dict[str, int | None]:
    """The rank band of each system (1 = the top band; None without a score).

    Systems are taken in order of score (ties: by name). The first opens band 1 and leads it.
    Each next system joins the current band while its interval overlaps the leader's, i.e.
    its upper bound is at least the leader's lower bound (it lies at or below the leader, so
    that is the whole overlap condition); otherwise it opens the next band and leads it. A
    missing bound counts as unbounded (it overlaps everything).

    >>> rank_bands(["a", "b", "c", "d"], [90, 80, 60, 55], [85, 70, 50, 52], [95, 88, 69, 58])
    {'a': 1, 'b': 1, 'c': 2, 'd': 2}
    """
    band: dict[str, int | None] = {n: None for n in names}
    rows = [
        (float(s), str(n), float(lo), float(hi))
        for n, s, lo, hi in zip(names, score, low, high, strict=True)
        if s is not None and np.isfinite(s)
    ]
    rows.sort(key=lambda r: (-r[0], r[1]))
    current, leader_low = 0, np.inf
    for _score, name, lo, hi in rows:
        top = hi if np.isfinite(hi) else np.inf
        if current == 0 or top < leader_low:
            current += 1
            leader_low = lo if np.isfinite(lo) else -np.inf
        band[name] = current
    return band


def votes_and_people(counts: np.ndarray, systems: Sequence[str]) -> dict[str, tuple[int, int]]:
    """Per system: naturalness votes on pairs it was in, and the participants who gave them."""
    counts = np.asarray(counts, dtype=float)
    on = counts.sum(axis=-1)  # (P, n, n)
    per = on.sum(axis=2) + on.sum(axis=1)  # (P, n): votes with the system on either side
    return {s: (int(per[:, k].sum()), int((per[:, k] > 0).sum())) for k, s in enumerate(systems)}


def preliminary_reason(votes: int, min_votes: int, drift_rounds: Sequence[int]) -> str | None:
    """Why a system's score is preliminary, or None.

    >>> preliminary_reason(120, 300, []), preliminary_reason(500, 300, [2])
    ('120 votes, fewer than 300', 'measured only in round 2, whose anchors drifted')
    """
    if votes < min_votes:
        return f"{votes} votes, fewer than {min_votes}"
    if drift_rounds:
        rounds = ", ".join(str(r) for r in drift_rounds)
        plural = "s" if len(drift_rounds) > 1 else ""
        return f"measured only in round{plural} {rounds}, whose anchors drifted"
    return None


def kendall_tau(a: Mapping[str, float | None], b: Mapping[str, float | None]) -> float | None:
    """Kendall's tau-b between two scorings on the systems both score."""
    from scipy.stats import kendalltau

    both = [k for k in a if a.get(k) is not None and b.get(k) is not None]
    if len(both) < 3:
        return None
    tau = kendalltau([a[k] for k in both], [b[k] for k in both]).statistic
    return float(tau) if np.isfinite(tau) else None
