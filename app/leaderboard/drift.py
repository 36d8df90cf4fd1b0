"""The drift check: do the anchors keep their distances from one round to the next?

Pooling every round's votes in one Bradley-Terry fit assumes that a round's participants judge
as earlier ones did: that the scale did not drift (another crowd, another season of the year,
a changed page). The anchors are in several rounds, so the assumption can be tested. For the
newest round r and each drift link (anchors next to each other on the earlier board, the pairs
the round's plan always keeps: :mod:`app.leaderboard.pairing`):

    d_r   = theta_a - theta_b   fitted to round r's naturalness votes alone,
    d_old = theta_a - theta_b   fitted to the votes of every round before r,
    z     = (d_r - d_old) / sqrt(se_r^2 + se_old^2),

the standard errors from the participant bootstrap of each fit (the two sets of participants
are independent), two-sided normal p-values, Holm-adjusted over the links. The round *drifted*
when any adjusted p is below the season's ``[publish] drift_alpha`` (0.05).

What is done then (docs/guide/leaderboard.md, "When the anchors drift"): the round is still
published, flagged with its anchors' differences; its newcomers are marked preliminary until a
later round without drift measures them again, and the next round takes them as anchors, so
that re-measurement happens by itself; the pooled scores keep every vote.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from app.analysis.btd import fit_btd, fit_btd_many
from app.analysis.json_values import json_number
from app.analysis.scaling import canonical_participant_order, resampled_sums
from app.analysis.ttest import holm
from app.leaderboard.scores import ELO_PER_LOG_WORTH
from app.leaderboard.votes import naturalness_counts


def _differences(
    counts: np.ndarray, links: Sequence[tuple[int, int]], bootstrap: int, seed: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """Each link's difference theta_a - theta_b and its bootstrap standard error, or None when
    the fit has no finite maximum (or the linked systems have no votes)."""
    counts = counts[counts.sum(axis=(1, 2, 3)) > 0]
    pooled = counts.sum(axis=0)
    n = pooled.shape[0]
    off = np.where(~np.eye(n, dtype=bool), pooled.sum(axis=-1), 0.0)
    active = np.flatnonzero((off + off.T).sum(axis=1) > 0)
    if any(a not in active or b not in active for a, b in links) or counts.shape[0] < 2:
        return None
    sub = counts[:, active][:, :, active]
    fit = fit_btd(sub.sum(axis=0))
    if not fit.converged:
        return None
    where = {int(k): q for q, k in enumerate(active)}
    pairs = [(where[a], where[b]) for a, b in links]
    d = np.array([fit.theta[a] - fit.theta[b] for a, b in pairs])
    people = sub[canonical_participant_order(sub)]
    p, m = people.shape[0], active.size
    boot = resampled_sums(people.reshape(p, -1), bootstrap, seed).reshape(-1, m, m, 3)
    beta, ok = fit_btd_many(boot)
    if ok.sum() < max(10, bootstrap // 2):
        return None
    reps = np.array([beta[ok][:, a] - beta[ok][:, b] for a, b in pairs])
    return d, reps.std(axis=1, ddof=1)


def drift_check(
    frame: pd.DataFrame,
    systems: Sequence[str],
    links: Sequence[tuple[str, str]],
    round_number: int,
    *,
    bootstrap: int,
    seed: int,
    alpha: float,
) -> dict[str, Any]:
    """The check of round ``round_number`` against the rounds before it, as JSON.

    ``frame`` is the pooled frame (:func:`app.leaderboard.votes.pooled_frame`); ``links`` the
    anchor pairs to compare. Returns ``{"round", "checked", "drifted", "alpha", "links":
    [{"anchors", "this_round", "earlier", "difference", "se", "p", "p_holm"}], "note"}`` with
    differences in Elo points; ``checked`` is false (and ``note`` says why) in the first round
    or when a fit is missing.
    """
    out: dict[str, Any] = {
        "round": round_number,
        "checked": False,
        "drifted": False,
        "alpha": alpha,
        "links": [],
        "note": None,
    }
    index = {s: k for k, s in enumerate(systems)}
    pairs = [(index[a], index[b]) for a, b in links if a in index and b in index]
    if round_number <= 1 or not pairs:
        out["note"] = "no earlier round to compare with" if round_number <= 1 else "no anchors"
        return out
    now = frame[frame["round"] == round_number]
    before = frame[frame["round"] < round_number]
    if now.empty or before.empty:
        out["note"] = "no votes in this round or before it"
        return out
    new = _differences(naturalness_counts(now, systems)[0], pairs, bootstrap, seed)
    old = _differences(naturalness_counts(before, systems)[0], pairs, bootstrap, seed + 1)
    if new is None or old is None:
        out["note"] = "an anchor was not compared, or a fit has no finite estimate"
        return out
    (d_new, se_new), (d_old, se_old) = new, old
    se = np.sqrt(se_new**2 + se_old**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(se > 0, (d_new - d_old) / se, 0.0)
    p = 2.0 * stats.norm.sf(np.abs(z))
    p_holm = holm(p)
    for k, (a, b) in enumerate(pairs):
        out["links"].append(
            {
                "anchors": [systems[a], systems[b]],
                "this_round": json_number(ELO_PER_LOG_WORTH * d_new[k]),
                "earlier": json_number(ELO_PER_LOG_WORTH * d_old[k]),
                "difference": json_number(ELO_PER_LOG_WORTH * (d_new[k] - d_old[k])),
                "se": json_number(ELO_PER_LOG_WORTH * se[k]),
                "p": json_number(p[k]),
                "p_holm": json_number(p_holm[k]),
            }
        )
    out["checked"] = True
    out["drifted"] = bool(np.any(np.asarray(p_holm) < alpha))
    return out
