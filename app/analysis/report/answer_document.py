"""The report's section on the answer details: the 5-level strengths and the reason tags
(:mod:`app.analysis.answer_details`), as tables and figures, when the votes carry them."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from app.analysis.report.blocks import Block, Heading, Paragraph, Plot, Table, fmt
from app.analysis.report.figures import GREY, PALETTE, stacked_bars

#: Diverging colours of the five levels: clearly / slightly the first condition (blue), cannot
#: decide (grey), slightly / clearly the second (red).
LEVEL_COLOURS = ("#1b4f8a", "#8db4dd", GREY, "#eba3a8", "#a8323e")


def strength_figure(strengths: dict[str, Any]) -> Figure:
    """One stacked bar per pair: the share of each level, the first condition's to the left."""
    pairs = strengths["pairs"]
    labels = [f"{p['a']} vs {p['b']}" for p in pairs] + ["all pairs"]
    counts = np.array([p["counts"] for p in pairs] + [strengths["pooled"]], dtype=float)
    shares = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1.0)
    fig = Figure(figsize=(7.2, 1.4 + 0.32 * len(labels)), dpi=100, layout="constrained")
    ax = fig.subplots()
    y = stacked_bars(ax, shares, list(LEVEL_COLOURS), strengths["levels"])
    ax.set_yticks(y, labels, fontsize=8)
    ax.set_xlim(0, 1)
    ax.axvline(0.5, color="#444444", linewidth=0.6, linestyle=":")
    ax.set_xlabel("share of votes (first condition of each pair on the left)")
    ax.spines[["top", "right"]].set_visible(False)
    fig.legend(fontsize=7, loc="outside lower center", ncol=5, frameon=False)
    return fig


def reasons_figure(reasons: dict[str, Any], conditions: list[str]) -> Figure:
    """One stacked bar per tag: how often it was ticked, by the condition chosen."""
    tags = list(reasons["tags"])
    columns = [*conditions, "undecided"]
    fig = Figure(figsize=(7.2, 1.4 + 0.3 * len(tags)), dpi=100, layout="constrained")
    ax = fig.subplots()
    values = np.array([[reasons["tags"][t].get(c, 0) for c in columns] for t in tags], float)
    colours = [PALETTE[i % len(PALETTE)] for i in range(len(conditions))] + [GREY]
    y = stacked_bars(ax, values, colours, columns)
    ax.set_yticks(y, tags, fontsize=8)
    ax.set_xlabel("times ticked")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # counts: no 2.5 ticks
    ax.spines[["top", "right"]].set_visible(False)
    fig.legend(
        fontsize=7,
        loc="outside lower center",
        ncol=min(len(columns), 5),
        frameon=False,
        title="condition chosen",
        title_fontsize=7,
    )
    return fig


def answer_detail_blocks(r: dict[str, Any]) -> list[Block]:
    """The strengths and reasons section of the report; empty when neither was asked."""
    strengths, reasons = r.get("strengths"), r.get("reasons")
    if not strengths and not reasons:
        return []
    doc: list[Block] = [Heading("Answer details")]
    if strengths:
        levels = strengths["levels"]
        rows = [
            [f"{p['a']} vs {p['b']}", *map(str, p["counts"]), str(p["votes"]), fmt(p["mean"])]
            for p in strengths["pairs"]
        ]
        pooled = strengths["pooled"]
        rows.append(
            ["all pairs", *map(str, pooled), str(strengths["votes"]), fmt(strengths["mean"])]
        )
        doc += [
            Paragraph(
                "Votes on the 5-level scale (HEMVIP2: clearly / slightly one face, cannot "
                "decide), per pair turned to its first condition. The graded mean scores "
                "the levels +2 (clearly the first) to -2 (clearly the second); it describes "
                "the strengths and enters no test."
            ),
            Table(
                "Strength of preference per pair (a vs b): votes per level, their number and "
                "the graded mean.",
                [
                    "Pair",
                    *(lev.replace("first", "a").replace("second", "b") for lev in levels),
                    "Votes",
                    "Mean",
                ],
                rows,
                numeric=[False, True, True, True, True, True, True, True],
            ),
            Plot(
                "Strength of preference per pair: the share of each level, the pair's first "
                "condition's levels on the left (blue), cannot decide grey, the second's red.",
                strength_figure(strengths),
            ),
        ]
    if reasons:
        columns = [*r["conditions"], "undecided"]
        rows = [
            [tag, str(t["total"]), *(str(t.get(c, 0)) for c in columns)]
            for tag, t in reasons["tags"].items()
        ]
        doc += [
            Paragraph(
                f"Reason tags: {reasons['votes']} of {reasons['of']} votes carry at least "
                "one; a vote may carry several."
            ),
            Table(
                "Reason tags: times ticked, in total and by the condition chosen.",
                ["Tag", "Total", *(f"chose {c}" if c != "undecided" else c for c in columns)],
                rows,
                numeric=[False, True, *([True] * len(columns))],
            ),
            Plot(
                "Reason tags: times each was ticked, by the condition chosen (hatched: undecided).",
                reasons_figure(reasons, r["conditions"]),
            ),
        ]
    return doc
