"""The report of a ratings analysis (:func:`app.analysis.rating_results.analyze_ratings`): its
blocks (:mod:`app.analysis.report.writer` writes them as HTML and PDF), its MOS figure and the
terminal summary of ``facepair analyze ratings.csv``. Importing it loads matplotlib; reading and
analysing a ratings table does not.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from app.analysis.rating_results import screening_rule
from app.analysis.report.blocks import (
    Block,
    Heading,
    Paragraph,
    Plot,
    Table,
    counted,
    fmt,
    fmt_p,
)
from app.trials.rating import SCALE_RANGE


def mos_figure(results: dict[str, Any]) -> Figure:
    """MOS per condition with its confidence interval (mixed model, black) beside the raw mean
    with the t interval over participants (grey), best on top."""
    mos = results["mos"]
    order = sorted(mos["conditions"], key=lambda c: mos["mos"][c] or -np.inf)
    fig = Figure(figsize=(7.2, 1.2 + 0.5 * len(order)), dpi=100, layout="constrained")
    ax = fig.subplots()
    y = np.arange(len(order), dtype=float)
    for key, ci, colour, shift, label in (
        ("mos", "ci", "#222222", 0.12, "mixed model"),
        ("raw_mos", "raw_ci", "#9a9a9a", -0.12, "raw mean"),
    ):
        centre = np.array([mos[key][c] if mos[key][c] is not None else np.nan for c in order])
        bounds = np.array([[v if v is not None else np.nan for v in mos[ci][c]] for c in order])
        ax.errorbar(
            centre,
            y + shift,
            xerr=np.abs(bounds.T - centre),
            fmt="o",
            color=colour,
            capsize=3,
            label=label,
        )
    ax.set_yticks(y, order, fontsize=8)
    low, high = SCALE_RANGE[results["scale"]]
    ax.set_xlim(low - 0.05 * (high - low), high + 0.05 * (high - low))
    ax.set_xlabel(
        "MOS (ACR: 1 Bad ... 5 Excellent)" if results["scale"] == "acr5" else "MOS (0-100)"
    )
    ax.spines[["top", "right"]].set_visible(False)
    ax.legend(fontsize=7, loc="lower right", frameon=False)
    return fig


METHOD = (
    "Model: y_pki = mu_i + u_p + v_k + e_pki, the rating y of condition i by participant p on "
    "clip k, with participant and clip random intercepts u_p ~ N(0, s_p^2) and v_k ~ N(0, "
    "s_k^2), crossed (Baayen, Davidson & Bates 2008), fitted by REML as lme4 fits it (the "
    "profiled criterion on the sparse structure, Bates et al. 2015). "
    "The MOS of a condition is mu_i with its Wald interval; contrasts mu_a - mu_b with Wald z "
    "tests, Holm (1979) over the pairs. The raw MOS is the mean rating, its interval the t "
    "interval over the participants' means (ITU-T P.910, sec. 12). Ratings: ITU-T P.910 "
    "absolute category rating, 5 Excellent to 1 Bad, or a 0-100 slider."
)


def rating_blocks(r: dict[str, Any]) -> list[Block]:
    """The report of an :func:`analyze_ratings` result, in reading order."""
    mos, info = r["mos"], r["input"]
    source = Path(info["source"]).name if info["source"] else "in-memory ratings"
    doc: list[Block] = [Heading("Results", 1)]
    counts = (
        counted(info["ratings"], "rating"),
        counted(info["participants"], "participant"),
        counted(len(info["clips"]), "clip"),
    )
    checks = f"{info['catch']['failed']} of {info['catch']['trials']} missed"
    doc.append(
        Paragraph(
            f"Source: {source}. Scale: {r['scale']}. {counts[0]} of {counts[1]} on "
            f"{counts[2]}; attention checks: {checks}."
        )
    )
    if mos.get("note"):
        doc.append(Paragraph(f"Note: {mos['note']}."))
    if r.get("screening"):
        rule = r["screening"]
        caught = ", ".join(sorted(rule["excluded"])) or "nobody"
        doc.append(
            Paragraph(f"{screening_rule(rule['below'], rule['share'])}; left out by it: {caught}.")
        )
    if info["left_out"]:
        doc.append(
            Table(
                "Participants left out of the analysis.",
                ["Participant", "Why"],
                [[p, why] for p, why in sorted(info["left_out"].items())],
            )
        )
    doc.append(Heading("Mean opinion scores"))
    doc.append(
        Plot(
            "Figure 1. MOS per condition: the mixed model's estimate with its 95 % interval "
            "(black) and the raw mean with the t interval over participants (grey).",
            mos_figure(r),
        )
    )
    doc.append(
        Table(
            "Table 1. MOS per condition.",
            ["Condition", "MOS", "95 % CI", "Raw mean", "95 % CI (t)"],
            [
                [
                    c,
                    fmt(mos["mos"][c]),
                    f"[{fmt(mos['ci'][c][0])}, {fmt(mos['ci'][c][1])}]",
                    fmt(mos["raw_mos"][c]),
                    f"[{fmt(mos['raw_ci'][c][0])}, {fmt(mos['raw_ci'][c][1])}]",
                ]
                for c in mos["conditions"]
            ],
            note=f"sd participant {fmt(mos['sd_participant'])}, sd clip "
            f"{fmt(mos['sd_clip'])}, sd residual {fmt(mos['sd_residual'])}" + _convergence(r) + ".",
            numeric=[False, True, False, True, False],
        )
    )
    doc.append(
        Table(
            "Table 2. Pairwise contrasts of the MOS (Holm-adjusted).",
            ["Contrast", "Difference", "95 % CI", "z", "p", "p (Holm)"],
            [
                [
                    f"{c['a']} - {c['b']}",
                    fmt(c["difference"]),
                    f"[{fmt(c['ci'][0])}, {fmt(c['ci'][1])}]",
                    fmt(c["z"]),
                    fmt_p(c["p"]),
                    fmt_p(c["p_holm"]),
                ]
                for c in mos["contrasts"]
            ],
            numeric=[False, True, False, True, True, True],
        )
    )
    doc.append(Heading("Method"))
    doc.append(Paragraph(METHOD))
    return doc


def _convergence(r: dict[str, Any]) -> str:
    """Whether the mixed model converged, as the end of Table 1's note; nothing with one
    participant (no model's interval is reported: ``rating_results.ONE_PARTICIPANT``)."""
    if r["input"]["participants"] < 2:
        return ""
    return "; converged" if r["mos"]["converged"] else "; not converged"


def summary_text(r: dict[str, Any]) -> str:
    """A short terminal table of an :func:`analyze_ratings` result."""
    mos, info = r["mos"], r["input"]
    width = max(len(c) for c in [*r["conditions"], "condition"])
    lines = [
        f"{counted(info['ratings'], 'rating')}, {counted(info['participants'], 'participant')}, "
        f"{counted(len(info['clips']), 'clip')}; scale {r['scale']}; left out: "
        + (", ".join(sorted(info["left_out"])) or "nobody"),
        f"{'condition':<{width}}  MOS    95% CI",
    ]
    for c in r["conditions"]:
        low, high = mos["ci"][c]
        lines.append(f"{c:<{width}}  {fmt(mos['mos'][c]):>5}  [{fmt(low)}, {fmt(high)}]")
    if info["participants"] < 2:
        lines.append("contrasts: not tested (no interval with one participant)")
        return "\n".join(lines)
    differ = [c for c in mos["contrasts"] if c["p_holm"] is not None and c["p_holm"] < 0.05]
    lines.append(f"contrasts: {len(differ)} of {len(mos['contrasts'])} pairs differ (Holm p < .05)")
    return "\n".join(lines)
