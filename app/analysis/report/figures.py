"""The report's plots, drawn with matplotlib from an :func:`app.analysis.analyze` result.

Each function returns a new :class:`matplotlib.figure.Figure` (Agg canvas, no pyplot state), so
the HTML and PDF writers embed the very same drawing. The for/against/undecided bars follow Le,
Ma & Deng 2012, Fig. 9: black for the first condition, grey undecided, white for the second.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

BLACK, GREY, WHITE = "#222222", "#9a9a9a", "#ffffff"
PALETTE = ("#1b6ca8", "#d1495b", "#2e8b57", "#edae49", "#6a4c93", "#00798c", "#8d6e63", "#c0ca33")


def _colour(i: int) -> str:
    return PALETTE[i % len(PALETTE)]


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), dpi=100, layout="constrained")
    return fig


def stacked_bars(ax: Any, values: np.ndarray, colours: list[str], labels: list[str]) -> np.ndarray:
    """Horizontal bars, one per row of ``values`` (top first), stacked by its columns in
    ``colours`` with the legend's ``labels`` ("undecided" hatched); returns the bars' y."""
    y = np.arange(len(values))[::-1]
    start = np.zeros(len(values))
    for q, label in enumerate(labels):
        ax.barh(
            y,
            values[:, q],
            left=start,
            color=colours[q],
            edgecolor="white",
            linewidth=0.5,
            hatch="//" if label == "undecided" else None,
            label=label,
        )
        start += values[:, q]
    return y


def ballots_figure(results: dict[str, Any]) -> Figure:
    """Pooled ballots per condition (with undecided) and each clip's share of ballots."""
    names = results["conditions"]
    pooled = results["pooled"]
    clips = list(results["clips"])
    fig = _figure(7.2, 3.0 + 0.0 * len(clips))
    left, right = fig.subplots(1, 2, width_ratios=(1.0, 1.25))
    values = [pooled["ballots"][c] for c in names] + [pooled["undecided"]]
    labels = list(names) + ["undecided"]
    colours = [_colour(i) for i in range(len(names))] + [GREY]
    bars = left.bar(range(len(values)), values, color=colours, edgecolor=BLACK, linewidth=0.6)
    for i, b in enumerate(bars):
        if i == len(names):
            b.set_hatch("//")
    left.bar_label(bars, labels=[str(v) for v in values], fontsize=8, padding=2)
    left.set_xticks(range(len(values)), labels, rotation=30, ha="right", fontsize=8)
    left.set_ylabel("ballots (all clips)")
    left.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts: no 2.5 ballots
    left.set_ylim(0, max(values + [1]) * 1.15)
    left.set_title("Ballots per condition", fontsize=10)
    left.spines[["top", "right"]].set_visible(False)

    rows = clips + ["pooled"]
    sections = [results["clips"][c] for c in clips] + [pooled]
    shares = np.array(
        [[s["ballots"][c] for c in names] + [s["undecided"]] for s in sections], dtype=float
    )
    shares /= np.maximum(shares.sum(axis=1, keepdims=True), 1.0)
    y = stacked_bars(right, shares, colours, labels)
    right.set_yticks(y, rows, fontsize=8)
    right.set_xlim(0, 1)
    right.set_xlabel("share of votes")
    right.set_title("Share per clip", fontsize=10)
    right.legend(
        fontsize=7,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.22),
        ncol=min(len(labels), 3),
        frameon=False,
    )
    fig.set_figheight(max(3.0, 1.2 + 0.22 * len(rows) + 0.25 * (len(labels) // 3 + 1)))
    return fig


def preference_bars_figure(section: dict[str, Any], title: str = "") -> Figure:
    """Le et al. 2012 Fig. 9 style: for / undecided / against per pair; * = Holm p < .05."""
    tests = section["sign_tests"]
    fig = _figure(7.2, 0.9 + 0.42 * max(len(tests), 1))
    ax = fig.subplots()
    if not tests:
        ax.text(0.5, 0.5, "no pairs of different conditions", ha="center", va="center")
        ax.set_axis_off()
        return fig
    y = np.arange(len(tests))[::-1]
    wins = np.array([t["wins"] for t in tests], dtype=float)
    und = np.array([t["undecided"] for t in tests], dtype=float)
    losses = np.array([t["losses"] for t in tests], dtype=float)
    total = np.maximum(wins + und + losses, 1.0)
    parts = (
        (wins, BLACK, "white", "first condition preferred"),
        (und, GREY, "black", "undecided"),
        (losses, WHITE, "black", "second condition preferred"),
    )
    start = np.zeros(len(tests))
    for values, colour, ink, label in parts:
        share = values / total
        ax.barh(
            y,
            share,
            left=start,
            color=colour,
            edgecolor=BLACK,
            linewidth=0.7,
            label=label,
            height=0.62,
        )
        for yy, x0, w, v in zip(y, start, share, values, strict=True):
            if w > 0.06:
                ax.text(
                    x0 + w / 2, yy, f"{int(v)}", ha="center", va="center", color=ink, fontsize=8
                )
        start += share
    ax.axvline(0.5, color="#555555", linewidth=0.6, linestyle=":")
    ax.set_yticks(y, [f"{t['a']} vs {t['b']}" for t in tests], fontsize=8)
    for yy, t in zip(y, tests, strict=True):
        star = " *" if (t.get("p_holm") is not None and t["p_holm"] < 0.05) else ""
        text = _p(t["p"])
        ax.text(
            1.01,
            yy,
            f"p {text}{star}" if text.startswith("<") else f"p = {text}{star}",
            va="center",
            fontsize=7.5,
            transform=ax.get_yaxis_transform(),
        )
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of votes on the pair")
    ax.spines[["top", "right"]].set_visible(False)
    ax.legend(fontsize=7, ncol=3, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    if title:
        ax.set_title(title, fontsize=10, pad=22)
    return fig


def confusion_figure(section: dict[str, Any]) -> Figure:
    """Heat map: share of decisive votes for the left condition; cells annotated L/U/R."""
    conf = section["confusion"]
    names = conf["conditions"]
    left, right, und = (np.asarray(conf[k], dtype=float) for k in ("left", "right", "undecided"))
    decisive = left + right
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(decisive > 0, left / np.where(decisive > 0, decisive, 1), np.nan)
    n = len(names)
    side = 1.6 + 0.85 * n
    fig = _figure(side + 1.6, side)
    ax = fig.subplots()
    image = ax.imshow(np.ma.masked_invalid(share), cmap="RdBu", vmin=0, vmax=1)
    for i in range(n):
        for j in range(n):
            text = f"{int(left[i, j])} / {int(und[i, j])} / {int(right[i, j])}"
            dark = not np.isnan(share[i, j]) and abs(share[i, j] - 0.5) > 0.3
            ax.text(
                j,
                i,
                text,
                ha="center",
                va="center",
                fontsize=7 if n < 7 else 5.5,
                color="white" if dark else "black",
            )
    ax.set_xticks(range(n), names, rotation=30, ha="right", fontsize=8)
    ax.set_yticks(range(n), names, fontsize=8)
    ax.set_xlabel("right panel")
    ax.set_ylabel("left panel")
    ax.set_title("Votes left / undecided / right", fontsize=10)
    bar = fig.colorbar(image, ax=ax, shrink=0.8)
    bar.set_label("share of decisive votes for the left panel", fontsize=8)
    return fig


def scale_figure(results: dict[str, Any]) -> Figure:
    """Case V scale with bootstrap intervals: pooled (black) and each clip (coloured)."""
    names = results["conditions"]
    pooled = {r["condition"]: r for r in results["pooled"]["scale"]}
    order = sorted(
        names, key=lambda c: -np.inf if pooled[c]["score"] is None else pooled[c]["score"]
    )
    clips = list(results["clips"])
    fig = _figure(7.2, 1.2 + 0.5 * len(names))
    ax = fig.subplots()
    y = np.arange(len(order), dtype=float)
    offsets = np.linspace(-0.3, 0.3, len(clips) + 2)[1:-1]
    for q, clip in enumerate(clips):
        rows = {r["condition"]: r for r in results["clips"][clip]["scale"]}
        _points(ax, [rows[c] for c in order], y + offsets[q], _colour(q), 3.0, clip, 0.55)
    _points(ax, [pooled[c] for c in order], y, BLACK, 6.0, "pooled", 1.0)
    if not ax.get_legend_handles_labels()[0]:
        note = results["pooled"].get("scale_note") or "no scale could be fitted"
        ax.text(
            0.5,
            0.5,
            f"No scale: {note}.",
            ha="center",
            va="center",
            transform=ax.transAxes,
            fontsize=9,
        )
        ax.set_axis_off()
        return fig
    ax.axvline(0.0, color="#999999", linewidth=0.6)
    ax.set_yticks(y, order, fontsize=8)
    anchor = results["options"].get("anchor")
    ax.set_xlabel(
        "Thurstone Case V scale (JOD; 1 JOD = 75 % preference"
        + (f"; {anchor} = 0)" if anchor else "; mean 0)")
    )
    ax.spines[["top", "right"]].set_visible(False)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False)
    return fig


def _points(
    ax: Any,
    rows: list[dict[str, Any]],
    y: np.ndarray,
    colour: str,
    size: float,
    label: str,
    alpha: float,
) -> None:
    score = np.array([np.nan if r["score"] is None else r["score"] for r in rows])
    low = np.array([np.nan if r["ci_low"] is None else r["ci_low"] for r in rows])
    high = np.array([np.nan if r["ci_high"] is None else r["ci_high"] for r in rows])
    ok = ~np.isnan(score)
    if not ok.any():
        return
    # A percentile bootstrap interval need not contain the point estimate (few votes, a skewed
    # resampling distribution), so the interval is drawn as given, not as +/- error bars.
    span = ok & ~np.isnan(low) & ~np.isnan(high)
    ax.hlines(
        y[span],
        low[span],
        high[span],
        color=colour,
        alpha=alpha,
        linewidth=1.0 if size < 5 else 1.6,
    )
    ax.plot(score[ok], y[ok], "o", color=colour, markersize=size, alpha=alpha, label=label)


def consistence_figure(results: dict[str, Any]) -> Figure:
    """Histogram of the participants' coefficients of consistence zeta."""
    z = np.array(
        [
            p["consistence"]["zeta"]
            for p in results["participants"].values()
            if p["consistence"]["zeta"] is not None
        ],
        dtype=float,
    )
    fig = _figure(4.6, 2.6)
    ax = fig.subplots()
    counts, _, _ = ax.hist(
        z,
        bins=np.linspace(min(0.0, float(z.min()) if z.size else 0.0), 1.0, 11).tolist(),
        color=_colour(0),
        edgecolor="white",
    )
    ax.set_ylim(0, max(1.0, float(np.max(counts))) * 1.1)  # whole participants, even none
    ax.set_xlabel("coefficient of consistence ζ")
    ax.set_ylabel("participants")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.spines[["top", "right"]].set_visible(False)
    return fig


def _p(p: float | None) -> str:
    """p-value as papers print it."""
    if p is None:
        return "n/a"
    if p < 0.001:
        return "< .001"
    return f"{p:.3f}".lstrip("0") if p < 1 else "1"


def power_figure(plan: dict[str, Any], test: str = "wilcoxon") -> Figure:
    """Power of one planned test against participants, one line per pair; 80 % and alpha."""
    levels = plan["levels"]
    x = [lv["participants"] for lv in levels]
    fig = _figure(6.4, 3.6)
    ax = fig.subplots()
    for q, pair in enumerate(levels[0]["power"][test]):
        ax.plot(
            x,
            [lv["power"][test][pair] for lv in levels],
            "o-",
            color=_colour(q),
            label=pair,
            markersize=4,
        )
    ax.axhline(0.8, color="#555555", linewidth=0.8, linestyle="--")
    ax.axhline(plan["alpha"], color="#999999", linewidth=0.6, linestyle=":")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("participants")
    ax.set_ylabel(f"power (Holm-adjusted p < {plan['alpha']:g})")
    title = {
        "wilcoxon": "Participant-level Wilcoxon signed-rank test",
        "sign_per_participant": "Sign test, one judgement per participant",
        "sign_pooled": "Pooled sign test",
    }.get(test, test)
    ax.set_title(f"{title}; {plan['simulations']} simulated studies per point", fontsize=10)
    ax.spines[["top", "right"]].set_visible(False)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False)
    return fig


def btd_figure(results: dict[str, Any]) -> Figure:
    """One panel per clip and pooled: model scores in JOD with their intervals (filled) and
    the Thurstone Case V scale (open circles) for comparison."""
    names = results["conditions"]
    sections = [*results["clips"].items(), ("pooled", results["pooled"])]
    cols = min(3, len(sections))
    rows = -(-len(sections) // cols)
    height = 0.7 + rows * (0.75 + 0.32 * len(names))
    # A fixed grid: constrained layout costs more than the drawing for a dozen panels.
    fig = Figure(figsize=(7.2, height), dpi=100)
    fig.subplots_adjust(
        left=0.16, right=0.98, wspace=0.75, hspace=0.55, top=1 - 0.3 / height, bottom=0.75 / height
    )
    axes = np.atleast_1d(fig.subplots(rows, cols, sharex=True, squeeze=False)).ravel()
    y = np.arange(len(names), dtype=float)[::-1]
    for ax, (label, section) in zip(axes, sections, strict=False):
        model = section["btd"]
        jod = np.array([np.nan if model["jod"][c] is None else model["jod"][c] for c in names])
        ci = np.array([[np.nan if v is None else v for v in model["jod_ci"][c]] for c in names])
        thurstone = np.array(
            [np.nan if s["score"] is None else s["score"] for s in section["scale"]]
        )
        span = ~np.isnan(ci).any(axis=1)
        ax.hlines(y[span], ci[span, 0], ci[span, 1], color=BLACK, linewidth=1.4)
        ax.plot(jod, y, "o", color=BLACK, markersize=5, label="Bradley-Terry-Davidson")
        ax.plot(
            thurstone,
            y,
            "o",
            markerfacecolor="none",
            markeredgecolor=_colour(1),
            markersize=6,
            label="Thurstone Case V",
        )
        ax.axvline(0.0, color="#999999", linewidth=0.6)
        ax.set_yticks(y, names, fontsize=7)
        ax.set_title(label + ("" if model["note"] is None else " (no fit)"), fontsize=9)
        ax.tick_params(axis="x", labelsize=7)
        ax.spines[["top", "right"]].set_visible(False)
    for ax in axes[len(sections) :]:
        ax.set_axis_off()
    for ax in axes[(rows - 1) * cols : len(sections)]:
        ax.set_xlabel("score (JOD)", fontsize=8)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=2, frameon=False)
    return fig
