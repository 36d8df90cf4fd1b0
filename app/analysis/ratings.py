"""Rating tests: mean opinion scores from a linear mixed model with crossed participant and
clip random effects.

For single-stimulus ratings (ITU-T P.910, absolute category rating: 5 labelled levels, or a
0-100 slider) and side-by-side sliders with a hidden reference (MUSHRA-like, ITU-R BS.1534),
each rating y of condition i by participant p on clip k is

    y_pki = mu_i + u_p + v_k + e_pki,   u_p ~ N(0, s_p^2), v_k ~ N(0, s_k^2), e ~ N(0, s^2)

(participants and clips crossed; Baayen, Davidson & Bates 2008, J. Mem. Lang. 59, 390-412).
Fitted by REML as lme4 fits it, on the sparse structure of the crossed effects
(:mod:`app.analysis.crossed_lmm`: linear in the ratings; 10,000 participants in a fraction of a
second, the same estimates as ``lme4::lmer`` to 1e-6). The MOS of
a condition is mu_i with its Wald interval; pairwise contrasts mu_a - mu_b with Wald z tests,
Holm (1979) over the pairs. The raw MOS (mean of the ratings) with the t interval of
ITU-T P.910 sec. 12 (here over the participants' means, which treats participants as the
sampled unit) stands beside it.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from app.analysis.json_values import json_number, json_row
from app.analysis.ttest import holm
from app.errors import InputError


def mixed_mos(
    ratings: pd.DataFrame, conditions: Sequence[str] | None = None, confidence: float = 0.95
) -> dict[str, Any]:
    """MOS per condition from a table with columns ``participant``, ``clip``, ``condition``,
    ``rating`` (one row per rating).

    Returns ``{"conditions", "mos": {c: value}, "ci": {c: [low, high]}, "raw_mos",
    "raw_ci", "sd_participant", "sd_clip", "sd_residual", "contrasts": [{"a", "b",
    "difference", "ci", "z", "p", "p_holm"}], "n", "converged"}``.
    """
    missing = {"participant", "clip", "condition", "rating"} - set(ratings.columns)
    if missing:
        raise InputError(f"missing columns: {', '.join(sorted(missing))}", field="ratings")
    data = ratings.dropna(subset=["rating"]).copy()
    names = list(conditions) if conditions is not None else sorted(data["condition"].unique())
    data = data[data["condition"].isin(names)]
    if data.empty or data["condition"].nunique() < 1:
        raise InputError("no ratings of the named conditions", field="ratings")
    present = [c for c in names if (data["condition"] == c).any()]
    fixed = pd.Categorical(data["condition"], categories=present).codes.astype(np.int64)
    x = np.eye(len(present))[fixed]
    y = data["rating"].to_numpy(float)
    groups = {
        key: pd.factorize(data[key], sort=True)[0]
        for key in ("participant", "clip")
        if data[key].nunique() > 1
    }
    z = float(stats.norm.ppf(0.5 + confidence / 2))
    fitted = _fit_mixed(y, fixed, groups) if groups else None
    note = None
    if fitted is None:
        # no random effect in the design, or too few ratings to estimate one: the condition
        # means with the pooled residual variance (ordinary least squares)
        beta = np.array([y[x[:, q] > 0].mean() for q in range(len(present))])
        resid = y - x @ beta
        dof = max(len(y) - len(present), 1)
        s2 = float(resid @ resid) / dof
        cov = np.diag(s2 / x.sum(axis=0))
        sd: dict[str, float] = {}
        residual, converged = float(np.sqrt(s2)), True
        if groups:
            note = "too few ratings for the random effects: condition means, least squares"
    else:
        beta, cov, sd, residual, converged = fitted
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    mos = {c: json_number(beta[q]) for q, c in enumerate(present)}
    ci = {
        c: [json_number(beta[q] - z * se[q]), json_number(beta[q] + z * se[q])]
        for q, c in enumerate(present)
    }
    contrasts = []
    for a, b in combinations(range(len(present)), 2):
        diff = float(beta[a] - beta[b])
        var = float(cov[a, a] + cov[b, b] - 2 * cov[a, b])
        s = np.sqrt(max(var, 0.0))
        zz = diff / s if s > 0 else np.nan
        contrasts.append(
            {
                "a": present[a],
                "b": present[b],
                "difference": diff,
                "ci": [diff - z * s, diff + z * s],
                "z": zz,
                "p": float(2 * stats.norm.sf(abs(zz))) if np.isfinite(zz) else np.nan,
            }
        )
    for row, adjusted in zip(contrasts, holm([r["p"] for r in contrasts]).tolist(), strict=True):
        row["p_holm"] = adjusted
    raw, raw_ci = _raw_mos(data, present, confidence)
    return {
        "model": "linear mixed model, participant and clip random intercepts (crossed), REML",
        "conditions": present,
        "mos": mos,
        "ci": ci,
        "raw_mos": raw,
        "raw_ci": raw_ci,
        "sd_participant": json_number(sd.get("participant", np.nan)),
        "sd_clip": json_number(sd.get("clip", np.nan)),
        "sd_residual": json_number(residual),
        "contrasts": [json_row(r) for r in contrasts],
        "n": int(len(y)),
        "converged": converged,
        "note": note,
    }


def _fit_mixed(
    y: np.ndarray, fixed: np.ndarray, groups: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, dict[str, float], float, bool] | None:
    """REML fit with crossed random intercepts for ``groups`` (:mod:`app.analysis.crossed_lmm`);
    None where the model cannot be fitted (no more ratings than conditions, no residual
    variance left)."""
    from app.analysis.crossed_lmm import fit_crossed

    try:
        fit = fit_crossed(y, fixed, list(groups.values()))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return None
    if not (np.all(np.isfinite(fit.beta)) and np.all(np.isfinite(fit.cov))):
        return None
    sd = dict(zip(groups, fit.sd.tolist(), strict=True))
    return fit.beta, fit.cov, sd, fit.residual, fit.converged


def _raw_mos(
    data: pd.DataFrame, present: Sequence[str], confidence: float
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Mean rating per condition, and the t interval over the participants' means."""
    raw, raw_ci = {}, {}
    for c in present:
        means = data[data["condition"] == c].groupby("participant")["rating"].mean().to_numpy()
        m = float(data.loc[data["condition"] == c, "rating"].mean())
        raw[c] = json_number(m)
        if len(means) > 1:
            half = float(
                stats.t.ppf(0.5 + confidence / 2, len(means) - 1)
                * means.std(ddof=1)
                / np.sqrt(len(means))
            )
            centre = float(means.mean())
            raw_ci[c] = [json_number(centre - half), json_number(centre + half)]
        else:
            raw_ci[c] = [None, None]
    return raw, raw_ci
