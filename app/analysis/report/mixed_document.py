"""Report blocks for the Bradley-Terry-Davidson model with participant and clip random effects
(:mod:`app.analysis.mixed_btd`), beside the fixed model; placed by
:func:`app.analysis.report.inference_document.inference_blocks`."""

from __future__ import annotations

from typing import Any

from app.analysis.mixed_btd import MODEL
from app.analysis.report.blocks import Block, Heading, Paragraph, Table, fmt

MIXED_TEXT = (
    "Mixed model: the Bradley-Terry-Davidson model with the side factor, each participant's "
    "and each clip's worths shifted by normal random effects, a_pki = θ_i + b_pi + c_ki "
    "(participant × condition and clip × condition, crossed); between decided votes logit "
    "P(i over j) = log g + a_pki − a_pkj. Undecided votes stay Davidson ties. Fitted by "
    "penalised quasi-likelihood (Breslow & Clayton 1993) with REML variances by Schall's "
    "update (1991); Wald intervals from the fixed block of the inverse Hessian. Validated by "
    "simulation with known effects (coverage in docs/reference/analysis.md)."
)


def _ci(pair: list[float | None], digits: int = 2) -> str:
    return f"[{fmt(pair[0], digits)}, {fmt(pair[1], digits)}]"


def mixed_blocks(r: dict[str, Any]) -> list[Block]:
    """Heading, a paragraph and the table of the mixed model's scores next to the fixed
    model's; nothing when the analysis ran without it."""
    m = r["pooled"].get("mixed_btd")
    if not m:
        return []
    head = Heading(MODEL)  # the effects the methods text and Table 9b's note name
    if all(v is None for v in m["scores"].values()):
        return [head, Paragraph(f"The mixed model could not be fitted: {m['note']}.")]
    ci = int(round(100 * r["options"]["confidence"]))
    text = (
        f"Fitted to {m['n']} votes of {m['participants']} participants on {m['clips']} clips. "
        f"Standard deviation of the participant effects {fmt(m['sd_participant'], 3)}, of "
        f"the clip effects {fmt(m['sd_clip'], 3)} (log-worth units; 0 when the data show no "
        f"such variation). Side factor g = {fmt(m['gamma'], 3)} {_ci(m['gamma_ci'], 3)}, tie "
        f"parameter ν = {fmt(m['nu'])} {_ci(m['nu_ci'])}. These intervals allow for "
        "participants and clips that differ in what they prefer; the fixed model's treat every "
        "vote alike." + (f" Note: {m['note']}." if m["note"] else "")
    )
    fixed = r["pooled"]["btd"]
    rows = [
        [
            c,
            fmt(m["scores"][c]),
            _ci(m["ci"][c]),
            fmt(m["jod"][c]),
            _ci(m["jod_ci"][c]),
            fmt(fixed["jod"][c]),
            _ci(fixed["jod_ci"][c]),
        ]
        for c in r["conditions"]
    ]
    return [
        head,
        Paragraph(text),
        Table(
            f"Table 9b. Mixed-model scores pooled over clips (log worth, mean 0) with {ci} % "
            "Wald intervals, the same in JOD, and the fixed model's JOD with its bootstrap "
            "interval over participants.",
            ["condition", "score", f"{ci}% CI", "JOD", f"{ci}% CI (JOD)", "fixed JOD", "fixed CI"],
            rows,
            note=f"{m['estimator']}.",
            numeric=[False] + [True] * 6,
        ),
    ]


def objective_blocks(r: dict[str, Any]) -> list[Block]:
    """Objective measures against the per-clip scores (:mod:`app.analysis.objective`): the
    measures whose slope is most certain first; nothing when no measures were given."""
    o = r.get("objective")
    if not o:
        return []
    head = Heading("Objective measures and the preference")
    field = field_metric_blocks(o.get("field_metrics") or {})
    if not o["measures"]:
        return [
            head,
            Paragraph("No objective measure varied across the clips' conditions."),
            *field,
        ]
    ci = int(round(100 * o["confidence"]))
    shown = o["measures"][:15]
    text = (
        f"Each objective measure of the condition tracks (summary.json of the generated "
        f"stimuli) regressed on the per-clip Bradley-Terry-Davidson scores (JOD), one intercept "
        f"per clip, over {o['cells']} clip x condition cells of {o['clips']} clips: slope in "
        f"JOD per standard deviation of the measure, {ci} % t intervals, Holm over the "
        f"{len(o['measures'])} measures. With so few cells, read a measure as predictive only "
        "where its interval excludes 0 after Holm."
    )
    rows = [
        [
            m["measure"],
            fmt(m["slope"]),
            _ci(m["ci"]),
            fmt(m["p"], 4),
            fmt(m["p_holm"], 4),
            fmt(m["r2_within"]),
        ]
        for m in shown
    ]
    return [
        head,
        Paragraph(text),
        Table(
            f"Table 9c. Objective measures against the preference (the {len(shown)} with the "
            "smallest p).",
            ["measure", "slope (JOD/SD)", f"{ci}% CI", "p", "p (Holm)", "R² within clips"],
            rows,
            numeric=[False] + [True] * 5,
        ),
        *field,
    ]


def field_metric_blocks(field: dict[str, Any]) -> list[Block]:
    """The 3D talking-head field's metrics of the mesh conditions (LVE, FDD against a mesh
    ground truth: :mod:`app.stimuli.meshes.metrics`), per condition, beside the preference."""
    if not field:
        return []
    text = (
        "The mesh conditions against the clips' ground-truth vertex sequences, mean over clips: "
        "lip vertex error (LVE: per frame the largest lip-vertex distance, averaged; Fan et al. "
        "2022) and upper-face dynamics deviation (FDD: the ground truth's spread of upper-face "
        "motion minus the condition's; Xing et al. 2023), in millimetres, and as the projects' "
        "code squares them (file units squared, comparable with their tables). Objective "
        "measures beside the perceptual scale, not part of it."
    )

    def cell(v: dict[str, Any], key: str) -> str:
        if key not in v:
            return "-"
        return fmt(v[key], 3) if key.endswith("_mm") else f"{v[key]:.3e}"

    keys = ("lve_mm", "fdd_mm", "lve_squared", "fdd_squared")
    rows = [
        [name, str(v.get("clips", "")), *(cell(v, k) for k in keys)]
        for name, v in sorted(field.items())
    ]
    return [
        Paragraph(text),
        Table(
            "Table 9d. LVE and FDD of the mesh conditions.",
            ["condition", "clips", "LVE (mm)", "FDD (mm)", "LVE (squared)", "FDD (squared)"],
            rows,
            numeric=[False] + [True] * 5,
        ),
    ]
