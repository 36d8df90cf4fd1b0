"""Participant quality: side bias, undecided rate, agreement with the consensus, catch trials,
response time and a likelihood outlier score; exclusion rules applied before every statistic.

Per participant, over all their votes:

- ``side_left``: share of "left" among their decided votes; ``side_p``: exact two-sided
  binomial test of left against right (a participant who always picks one side has p -> 0).
- ``undecided``: share of undecided votes.
- ``tau``: Kendall's tau-b (Kendall 1945, ties corrected) between the participant's wins per
  condition (decided votes on pairs of different conditions) and the consensus ranking, the
  pooled Bradley-Terry-Davidson scores of all participants (or, where the model has no finite
  maximum, the pooled wins).
- ``catch``: share of identical-clip pairs (the same condition on both sides) answered
  "undecided", the answer ``app.trials.catch`` expects of an identical catch trial; null
  for a participant who saw none.
- ``median_ms``: median response time (``response_ms``), null when the column is empty.
- ``outlier``: pwcmp's outlier distance (Perez-Ortiz & Mantiuk 2017, sec. 9): with L_p the
  participant's log-likelihood under the model fitted to everyone else, Q1 and IQR the first
  quartile and inter-quartile range of all L_p, (Q1 - L_p) / IQR where L_p < Q1, else 0.

Exclusion rules read ``FIELD OP NUMBER`` joined by commas, e.g. ``catch<1.0,side_p<0.001``; a
participant matching any rule is excluded; a null value matches no rule.
"""

from __future__ import annotations

import operator
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from app.analysis.btd import fit_btd, leave_one_out_loglik
from app.analysis.counts import VoteCounts, wins
from app.analysis.signtest import sign_test_p
from app.errors import InputError

QUALITY_FIELDS: dict[str, str] = {
    "side_left": "share of left among decided votes",
    "side_p": "binomial p of left against right",
    "undecided": "share of undecided votes",
    "tau": "Kendall tau-b with the consensus ranking",
    "catch": "share of identical pairs answered undecided",
    "median_ms": "median response time (ms)",
    "same_left": "share of left among decided identical-pair votes (side bias on pairs "
    "without a difference)",
    "unfinished": "share of votes whose clip did not play to its end (media log)",
    "stall_ms": "total milliseconds the clips stalled (media log)",
    "focus_lost": "times the window lost focus during trials (media log)",
    "outlier": "pwcmp outlier distance (IQRs below the first quartile of log-likelihood)",
}
_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
_RULE = re.compile(
    r"^\s*([a-z_]+)\s*(<=|>=|<|>)\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?)\s*$", re.IGNORECASE
)


@dataclass(frozen=True)
class ExclusionRule:
    """Exclude a participant whose ``field`` compares to ``value`` by ``op``."""

    field: str
    op: str
    value: float

    def __str__(self) -> str:
        return f"{self.field}{self.op}{self.value:g}"

    def matches(self, quality: dict[str, Any]) -> bool:
        v = quality.get(self.field)
        return v is not None and bool(_OPS[self.op](v, self.value))


def parse_rules(text: str | Sequence[str] | None) -> list[ExclusionRule]:
    """Rules from ``"catch<1.0,side_p<0.001"`` (or a list of such parts); a bad part raises.

    >>> [str(r) for r in parse_rules("catch<1.0, side_p<0.001")]
    ['catch<1', 'side_p<0.001']
    """
    if text is None:
        return []
    parts = text.split(",") if isinstance(text, str) else list(text)
    rules = []
    for part in parts:
        if not part.strip():
            continue
        m = _RULE.match(part)
        if m is None:
            raise InputError(
                f"cannot read rule {part.strip()!r}: expected FIELD OP NUMBER such as catch<1.0",
                field="exclude",
            )
        name = m.group(1).lower()
        if name not in QUALITY_FIELDS:
            raise InputError(
                f"unknown field {name!r} in rule {part.strip()!r} (expected one "
                f"of {', '.join(QUALITY_FIELDS)})",
                field="exclude",
            )
        rules.append(ExclusionRule(name, m.group(2), float(m.group(3))))
    return rules


def tau_b(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Kendall's tau-b between each row of ``x`` (J, n) and ``y`` (n,); NaN where undefined."""
    i, j = np.triu_indices(x.shape[-1], 1)
    sx, sy = np.sign(x[:, i] - x[:, j]), np.sign(y[i] - y[j])
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = (sx * sy).sum(axis=1) / np.sqrt((sx != 0).sum(axis=1) * float((sy != 0).sum()))
    return np.where(np.isfinite(tau), tau, np.nan)


def _outlier_distance(loglik: np.ndarray) -> np.ndarray:
    ok = ~np.isnan(loglik)
    out = np.full(loglik.shape, np.nan)
    if ok.sum() < 4:
        return out
    q1, q3 = np.percentile(loglik[ok], [25, 75])
    iqr = q3 - q1
    if iqr <= 0:
        return np.where(ok, 0.0, np.nan)
    return np.where(ok, np.maximum(q1 - loglik, 0.0) / iqr, np.nan)


def participant_quality(counts: VoteCounts, frame: pd.DataFrame) -> dict[str, dict[str, Any]]:
    """Every participant's quality measures (see the module docstring) as JSON-ready dicts."""
    t = counts.tensor.sum(axis=1).astype(float)  # (P, n, n, 3) over clips
    n = t.shape[-2]
    diag = np.arange(n)
    left, right, und = (t[..., q].sum(axis=(1, 2)) for q in range(3))
    decided = left + right
    same = t[:, diag, diag, :]
    same_votes = same.sum(axis=(1, 2))
    off = ~np.eye(n, dtype=bool)
    won = np.where(off, wins(t), 0.0).sum(axis=-1)
    fit = fit_btd(t.sum(axis=0))
    consensus = fit.theta if fit.converged else won.sum(axis=0)
    tau = tau_b(won, consensus)
    outlier = _outlier_distance(leave_one_out_loglik(t))
    times = pd.to_numeric(frame["response_ms"], errors="coerce").astype(float)
    people = list(counts.participants)
    median_ms = _aligned(times.groupby(frame["participant"]).median(), people)
    side_p = sign_test_p(left, right)
    media = {k: _aligned(v, people) for k, v in _media_measures(frame).items()}
    with np.errstate(invalid="ignore", divide="ignore"):
        same_decided = same[:, :, :2].sum(axis=(1, 2))
        columns = {
            "votes": (left + right + und).astype(np.int64).tolist(),
            "side_left": _nullable(np.where(decided > 0, left / decided, np.nan)),
            "side_p": _nullable(np.where(decided > 0, side_p, np.nan)),
            "undecided": _nullable(und / (decided + und)),
            "tau": _nullable(tau),
            "catch": _nullable(
                np.where(same_votes > 0, same[:, :, 2].sum(axis=1) / same_votes, np.nan)
            ),
            "catch_trials": same_votes.astype(np.int64).tolist(),
            "median_ms": _nullable(median_ms),
            "outlier": _nullable(outlier),
            "same_left": _nullable(
                np.where(same_decided > 0, same[:, :, 0].sum(axis=1) / same_decided, np.nan)
            ),
            **{name: _nullable(values) for name, values in media.items()},
        }
    names = list(columns)
    return {
        pid: dict(zip(names, row, strict=True))
        for pid, row in zip(people, zip(*columns.values(), strict=True), strict=True)
    }


def _nullable(values: np.ndarray) -> list[float | None]:
    """Floats as JSON holds them: NaN and infinities as None."""
    v = np.asarray(values, dtype=float)
    return [x if ok else None for x, ok in zip(v.tolist(), np.isfinite(v).tolist(), strict=True)]


def _aligned(per_participant: pd.Series, people: list[str]) -> np.ndarray:
    """A per-participant series as an array in ``people``'s order (NaN for the missing)."""
    values = pd.Series(
        per_participant.to_numpy(dtype=float), index=per_participant.index.astype(str)
    )
    return values.reindex(people).to_numpy(dtype=float)


def _media_measures(frame: pd.DataFrame) -> dict[str, pd.Series]:
    """Per participant, from the media log columns (NaN where a file has none)."""
    by = frame["participant"]

    def given(name: str) -> pd.Series | None:
        """The column as floats, or None where no row has a value (nothing to group)."""
        if name not in frame or frame[name].isna().all():
            return None
        return pd.to_numeric(frame[name], errors="coerce").astype(float)

    ended = given("played_to_end")
    out = {"unfinished": (1 - ended).groupby(by).mean() if ended is not None else pd.Series()}
    for name in ("stall_ms", "focus_lost"):
        values = given(name)
        out[name] = values.groupby(by).sum(min_count=1) if values is not None else pd.Series()
    return {k: v.astype(float) for k, v in out.items()}


def excluded_participants(
    quality: dict[str, dict[str, Any]], rules: Sequence[ExclusionRule]
) -> dict[str, list[str]]:
    """Participant -> the rules they match (only those matching at least one)."""
    out = {}
    for pid, q in quality.items():
        hits = [f"{r} ({r.field} = {q[r.field]:.4g})" for r in rules if r.matches(q)]
        if hits:
            out[pid] = hits
    return out
