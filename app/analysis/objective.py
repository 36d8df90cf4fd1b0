"""Objective to perceptual: which objective measure of a condition's motion predicts what
people preferred.

The objective measures are those ``facepair stimuli generate`` writes per clip and condition
(``summary.json``: :func:`app.stimuli.measures.measure_track`: channel statistics, head
kinematics, correlation with the speech, RMSE and correlation with the ground truth). The
perceptual value is the condition's score on that clip in the report (the per-clip
Bradley-Terry-Davidson scores in JOD, :mod:`app.analysis.btd`).

Each measure is regressed on its own, with one intercept per clip (a clip's scores are only
defined up to a shift, mean 0 in the report):

    score_kc = a_k + beta z_kc + e_kc,    e ~ N(0, s^2)

z the measure standardised over all (clip, condition) cells, so beta is the JOD per standard
deviation of the measure. Ordinary least squares; the interval is beta +- t(df) SE with
df = cells - clips - 1, p two-sided, Holm (1979) over the measures; R^2 within clips is the
share of the scores' within-clip variance the measure explains. This is the analysis of
variance with a covariate (Fisher's ANCOVA; e.g. Montgomery, Design and Analysis of
Experiments, ch. 15): a measure whose interval excludes 0 predicts the preference beyond
chance, with as many cells as clips x conditions, which is few; the report says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy import stats

from app.analysis.json_values import json_row
from app.analysis.ttest import holm

MIN_CELLS_BEYOND_CLIPS = 2  # at least one residual degree of freedom after slope and intercepts


def flatten_measures(measures: Mapping[str, Any], prefix: str = "") -> dict[str, float]:
    """Nested measures (dicts and lists of numbers) as ``{"dotted.name": value}``; None and
    non-numbers are left out.

    >>> flatten_measures({"head": {"speed": 2.0, "max": None}, "cc": [0.5, 0.1]})
    {'head.speed': 2.0, 'cc.0': 0.5, 'cc.1': 0.1}
    """
    out: dict[str, float] = {}
    items = measures.items() if isinstance(measures, Mapping) else enumerate(measures)
    for key, value in items:
        name = f"{prefix}{key}"
        if isinstance(value, bool):
            continue
        if isinstance(value, int | float):
            number = float(value) if abs(value) < 1e300 else float("nan")
            if np.isfinite(number):
                out[name] = number
        elif isinstance(value, Mapping | list | tuple):
            out.update(flatten_measures(value, name + "."))  # type: ignore[arg-type]
    return out


def measures_from_summaries(
    summaries: Mapping[str, Mapping[str, Any]],
) -> dict[tuple[str, str], dict[str, float]]:
    """``{clip: summary.json}`` -> ``{(clip, condition): {measure: value}}`` from each
    condition's ``measures``."""
    return {
        (clip, condition): flatten_measures(entry.get("measures", {}))
        for clip, summary in summaries.items()
        for condition, entry in summary.get("conditions", {}).items()
    }


def objective_to_perceptual(
    measures: Mapping[tuple[str, str], Mapping[str, float]],
    scores: Mapping[tuple[str, str], float | None],
    confidence: float = 0.95,
) -> dict[str, Any]:
    """Slope of the perceptual score on each standardised measure, with clip intercepts.

    Parameters
    ----------
    measures:
        ``{(clip, condition): {measure: value}}`` (:func:`measures_from_summaries`).
    scores:
        ``{(clip, condition): score}`` (JOD); None where the report has no score.

    Returns
    -------
    ``{"cells", "clips", "measures": [{"measure", "slope", "ci", "se", "t", "df", "p",
    "p_holm", "r2_within", "cells"} ...]}`` sorted by p (most predictive first); measures
    that are constant or present in too few cells are listed under ``skipped``.

    >>> m = {(k, c): {"x": float(i)} for k in "ab" for i, c in enumerate("pqr")}
    >>> s = {(k, c): float(i) - 1 for k in "ab" for i, c in enumerate("pqr")}
    >>> out = objective_to_perceptual(m, s)
    >>> round(out["measures"][0]["slope"], 6), round(out["measures"][0]["r2_within"], 6)
    (0.816497, 1.0)
    """
    cells = [key for key, v in scores.items() if v is not None and key in measures]
    names = sorted({name for key in cells for name in measures[key]})
    rows: list[dict[str, Any]] = []
    skipped: list[str] = []
    for name in names:
        have = [key for key in cells if name in measures[key]]
        clips = sorted({k for k, _ in have})
        x = np.array([measures[key][name] for key in have])
        y = np.array([float(scores[key]) for key in have])  # type: ignore[arg-type]
        df = len(have) - len(clips) - 1
        if df < MIN_CELLS_BEYOND_CLIPS - 1 or np.ptp(x) <= 1e-12 * max(1.0, np.abs(x).max()):
            skipped.append(name)
            continue
        with np.errstate(over="ignore", invalid="ignore"):
            z = (x - x.mean()) / x.std()
        if not np.all(np.isfinite(z)):
            skipped.append(name)  # values beyond what a float's arithmetic holds
            continue
        clip_of = np.array([clips.index(k) for k, _ in have])
        # within clips: subtracting each clip's means removes the intercepts (Frisch-Waugh)
        zc = z - np.bincount(clip_of, z)[clip_of] / np.bincount(clip_of)[clip_of]
        yc = y - np.bincount(clip_of, y)[clip_of] / np.bincount(clip_of)[clip_of]
        sxx = float(zc @ zc)
        if sxx <= 1e-12:
            skipped.append(name)  # constant within every clip
            continue
        slope = float(zc @ yc) / sxx
        resid = yc - slope * zc
        s2 = float(resid @ resid) / df
        se = float(np.sqrt(s2 / sxx))
        syy = float(yc @ yc)
        if se > 0:
            t = slope / se
        else:  # an exact fit: no slope at all, or one without residual
            t = 0.0 if slope == 0 else float(np.copysign(np.inf, slope))
        p = float(2 * stats.t.sf(abs(t), df)) if np.isfinite(t) else 0.0
        q = float(stats.t.ppf(0.5 + confidence / 2, df))
        rows.append(
            {
                "measure": name,
                "slope": slope,
                "se": se,
                "ci": [slope - q * se, slope + q * se],
                "t": t,
                "df": df,
                "p": p,
                "r2_within": 1.0 - float(resid @ resid) / syy if syy > 0 else None,
                "cells": len(have),
            }
        )
    adjusted: list[float] = holm([r["p"] for r in rows]).tolist() if rows else []
    for r, p_holm in zip(rows, adjusted, strict=True):
        r["p_holm"] = float(p_holm)
    rows.sort(key=lambda r: (r["p"], -abs(r["t"])))
    return {
        "cells": len(cells),
        "clips": len({k for k, _ in cells}),
        "confidence": confidence,
        "measures": [json_row(r) for r in rows],
        "skipped": skipped,
    }


#: The 3D talking-head field's metrics a mesh condition's summary holds (``measures.mesh``:
#: :mod:`app.stimuli.meshes.metrics`), in the order the report lists them.
FIELD_METRICS: tuple[str, ...] = ("lve_mm", "fdd_mm", "lve_squared", "fdd_squared")


def field_metrics(
    measures: Mapping[tuple[str, str], Mapping[str, float]],
) -> dict[str, dict[str, Any]]:
    """Per condition, the mean over its clips of each of :data:`FIELD_METRICS` (LVE and FDD of
    a mesh condition against a mesh ground truth) and the number of clips; conditions without
    them are left out. Reported beside the preference, never mixed into it.

    >>> m = {("a", "ff"): {"mesh.lve_mm": 2.0}, ("b", "ff"): {"mesh.lve_mm": 4.0}, ("a", "x"): {}}
    >>> field_metrics(m)
    {'ff': {'clips': 2, 'lve_mm': 3.0}}
    """
    out: dict[str, dict[str, Any]] = {}
    conditions = sorted({c for _, c in measures})
    for condition in conditions:
        rows = [v for (_, c), v in measures.items() if c == condition]
        entry: dict[str, Any] = {}
        for name in FIELD_METRICS:
            values = [r[f"mesh.{name}"] for r in rows if f"mesh.{name}" in r]
            if values:
                entry["clips"] = max(entry.get("clips", 0), len(values))
                entry[name] = float(np.mean(values))
        if entry:
            out[condition] = entry
    return out


def report_scores(results: Mapping[str, Any]) -> dict[tuple[str, str], float | None]:
    """The per-clip Bradley-Terry-Davidson scores (JOD) of an analysis
    (:func:`app.analysis.results.analyze`) as ``{(clip, condition): score}``."""
    return {
        (clip, condition): value
        for clip, section in results["clips"].items()
        for condition, value in section["btd"]["jod"].items()
    }
