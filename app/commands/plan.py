"""``facepair plan``: power of the planned tests and expected interval widths before a study."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import click
import numpy as np

from app.errors import InputError


def parse_participants(text: str) -> list[int]:
    """``"10-50"`` (step 10), ``"10-50:5"`` or ``"10,20,40"`` -> participant counts.

    >>> parse_participants("10-50"), parse_participants("8-20:4"), parse_participants("12, 30")
    ([10, 20, 30, 40, 50], [8, 12, 16, 20], [12, 30])
    """
    m = re.fullmatch(r"\s*(\d+)\s*-\s*(\d+)\s*(?::\s*(\d+)\s*)?", text)
    if m:
        low, high = int(m.group(1)), int(m.group(2))
        step = int(m.group(3)) if m.group(3) else 10
        if low > high or step < 1:
            raise InputError(
                f"expected LOW-HIGH[:STEP] with LOW <= HIGH, got {text!r}", field="participants"
            )
        counts = list(range(low, high + 1, step))
        return counts if counts[-1] == high else [*counts, high]
    parts = [p.strip() for p in text.split(",")]
    if not all(p.isascii() and p.isdigit() for p in parts):
        raise InputError(
            f"expected LOW-HIGH[:STEP] or a list such as 10,20,40, got {text!r}",
            field="participants",
        )
    return [int(p) for p in parts]


def parse_effects(text: str) -> tuple[list[str], list[float]]:
    """``"none=-0.8,random=0.1"`` -> condition names and scores (JOD)."""
    names, values = [], []
    for part in text.split(","):
        name, eq, value = part.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not eq or not name.strip() or number != number or abs(number) == float("inf"):
            raise InputError(f"expected CONDITION=SCORE, got {part.strip()!r}", field="effects")
        names.append(name.strip())
        values.append(number)
    if len(set(names)) != len(names):
        raise InputError("a condition is named twice", field="effects")
    return names, values


def _print(result: dict[str, Any]) -> str:
    names = result["conditions"]
    lines = [
        f"{result['simulations']} simulated studies per row; {result['design']} design, "
        f"{result['votes_per_participant']} votes per participant; scores (JOD) "
        + ", ".join(f"{c} {v:+.2f}" for c, v in result["jod"].items())
        + f"; g = {result['gamma']:.3f}, nu = {result['nu']:.3f} ({result['source']})"
    ]
    pairs = list(result["levels"][0]["power"]["wilcoxon"])
    width = max(len(p) for p in pairs)
    for lv in result["levels"]:
        lines.append(f"\n{lv['participants']} participants: power (Holm p < {result['alpha']:g})")
        lines.append(f"  {'pair':<{width}}  wilcoxon  sign/participant  sign/pooled")
        for p in pairs:
            pw = [lv["power"][t][p] for t in ("wilcoxon", "sign_per_participant", "sign_pooled")]
            lines.append(f"  {p:<{width}}  {pw[0]:8.3f}  {pw[1]:16.3f}  {pw[2]:11.3f}")
        ci = int(round(100 * result["confidence"]))
        widths = ", ".join(
            f"{c} " + ("-" if lv["ci_width_jod"][c] is None else f"{lv['ci_width_jod'][c]:.2f}")
            for c in names
        )
        lines.append(f"  expected {ci}% interval width of the scores (JOD): {widths}")
    return "\n".join(lines)


def _print_adaptive(results: list[dict[str, Any]]) -> str:
    first = results[0]
    lines = [
        f"adaptive (expected information gain, ASAP) against the full design: "
        f"{first['simulations']} simulated studies per row, true scores evenly spread over "
        f"{first['spread_jod']:g} JOD, nu = {first['nu']:g}; votes each design needs to reach "
        f"the full design's accuracy after {first['passes']} participants",
        f"  {'conditions':>10}  {'measure':<20} {'target':>7} {'full':>7} {'adaptive':>8} "
        f"{'ratio':>6}",
    ]
    labels = {
        "kendall": "Kendall tau",
        "spearman": "Spearman rho",
        "ci_width_jod": "95% CI width (JOD)",
    }
    for r in results:
        for metric, label in labels.items():
            row = r["reached"][metric]
            full, adaptive = row["full"], row["adaptive"]
            ratio = "-" if full is None or adaptive is None else f"{adaptive / full:.2f}"
            lines.append(
                f"  {r['conditions']:>10}  {label:<20} {row['target']:7.3f} "
                + ("      -" if full is None else f"{full:7.0f}")
                + (" " * 8 + "-" if adaptive is None else f" {adaptive:8.0f}")
                + f" {ratio:>6}"
            )
    return "\n".join(lines)


MAX_ADAPTIVE_CONDITIONS = 30  # beyond, one simulated study takes minutes


def _plan_adaptive(
    text: str, spread: float, passes: int, simulations: int, seed: int, json_path: str | None
) -> None:
    from app.analysis.adaptive_plan import AdaptivePlan, compare_designs
    from app.trials.adaptive import MIN_CONDITIONS

    parts = [p.strip() for p in text.split(",")]
    if not all(p.isascii() and p.isdigit() for p in parts) or any(
        not 3 <= int(p) <= MAX_ADAPTIVE_CONDITIONS for p in parts
    ):
        raise InputError(
            f"expected condition counts from 3 to {MAX_ADAPTIVE_CONDITIONS} such as 8,12, "
            f"got {text!r}",
            field="adaptive",
        )
    if not (np.isfinite(spread) and spread > 0):
        raise InputError(f"must be a number > 0, got {spread}", field="spread-jod")
    results = [
        compare_designs(
            AdaptivePlan(
                conditions=int(p),
                spread_jod=spread,
                participants=passes + 3,
                simulations=simulations,
            ),
            passes=passes,
            seed=seed,
        )
        for p in parts
    ]
    if json_path is not None:
        Path(json_path).write_text(
            json.dumps(results, indent=1, allow_nan=False) + "\n", encoding="utf-8"
        )
    small = [p for p in parts if int(p) < MIN_CONDITIONS]
    if small:
        click.echo(
            f"note: a study file's adaptive design needs {MIN_CONDITIONS} or more conditions"
        )
    click.echo(_print_adaptive(results))


@click.command("plan")
@click.option(
    "--adaptive",
    "adaptive_text",
    default=None,
    metavar="N,N",
    help="Instead of power: simulate the adaptive design against the full one for these "
    "numbers of conditions, e.g. '8,12'.",
)
@click.option(
    "--spread-jod",
    type=float,
    default=3.0,
    show_default=True,
    help="With --adaptive: range of the true scores (JOD).",
)
@click.option(
    "--passes",
    type=click.IntRange(1, 20),
    default=2,
    show_default=True,
    help="With --adaptive: the accuracy to reach is the full design's after this many "
    "participants.",
)
@click.option(
    "--effects",
    default=None,
    metavar="C=JOD,...",
    help="Assumed scores in JOD per condition, e.g. 'none=-0.8,random=0.1,gt=0.6'.",
)
@click.option(
    "--pilot",
    type=click.Path(dir_okay=False),
    default=None,
    help="Pilot votes CSV: fit the model (scores, g, nu) to it instead of --effects.",
)
@click.option("--conditions", default=None, help="With --pilot: the conditions, in order.")
@click.option(
    "--design",
    type=click.Choice(["all_ordered", "unordered"]),
    default="all_ordered",
    show_default=True,
    help="Every ordered pair, or every pair once (random side).",
)
@click.option(
    "--participants",
    "participants_text",
    default="10-50",
    show_default=True,
    help="Participant counts: LOW-HIGH[:STEP] or a list such as 10,20,40.",
)
@click.option(
    "--votes-per-participant",
    "votes",
    type=click.IntRange(1, 100000),
    default=None,
    help="Trials per participant (default: one pass through the design's pairs).",
)
@click.option(
    "--gamma",
    type=float,
    default=1.0,
    show_default=True,
    help="Side factor g (left worth multiplied by g); ignored with --pilot.",
)
@click.option(
    "--nu",
    type=float,
    default=0.4,
    show_default=True,
    help="Tie parameter nu (undecided votes); ignored with --pilot.",
)
@click.option(
    "--simulations",
    type=click.IntRange(10, 1000000),
    default=None,
    help="Simulated studies per row (default 1000; 100 with --adaptive).",
)
@click.option("--alpha", type=float, default=0.05, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the result as JSON here.",
)
@click.option(
    "--plot",
    "plot_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the power-against-participants plot (PNG) here.",
)
def plan(
    adaptive_text: str | None,
    spread_jod: float,
    passes: int,
    effects: str | None,
    pilot: str | None,
    conditions: str | None,
    design: str,
    participants_text: str,
    votes: int | None,
    gamma: float,
    nu: float,
    simulations: int | None,
    alpha: float,
    seed: int,
    json_path: str | None,
    plot_path: str | None,
) -> None:
    """Simulate studies: power of each planned test and expected CI widths by participants
    (or, with --adaptive, the votes the adaptive design needs against the full one)."""
    if adaptive_text is not None:
        if json_path is not None and not Path(json_path).resolve().parent.is_dir():
            raise InputError("folder does not exist", path=Path(json_path).parent)
        _plan_adaptive(adaptive_text, spread_jod, passes, simulations or 100, seed, json_path)
        return
    simulations = simulations or 1000
    from app.analysis.counts import count_votes
    from app.analysis.plan import StudyPlan, plan_from_pilot, plan_study
    from app.analysis.votes import read_votes

    if (effects is None) == (pilot is None):
        raise InputError("give either --effects or --pilot", field="effects")
    counts = parse_participants(participants_text)
    if pilot is not None:
        names = (
            None if conditions is None else [c.strip() for c in conditions.split(",") if c.strip()]
        )
        vc = count_votes(read_votes(pilot, conditions=names), names)
        spec = plan_from_pilot(
            vc.tensor.sum(axis=(0, 1)), vc.conditions, design=design, votes=votes, source=str(pilot)
        )
    else:
        assert effects is not None
        names, values = parse_effects(effects)
        spec = StudyPlan(
            tuple(names), tuple(values), gamma=gamma, nu=nu, design=design, votes=votes
        )
    for target in (json_path, plot_path):
        if target is not None and not Path(target).resolve().parent.is_dir():
            raise InputError("folder does not exist", path=Path(target).parent)
    result = plan_study(spec, counts, simulations=simulations, alpha=alpha, seed=seed)
    if json_path is not None:
        Path(json_path).write_text(
            json.dumps(result, indent=1, allow_nan=False) + "\n", encoding="utf-8"
        )
    if plot_path is not None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        from app.analysis.report.figures import power_figure

        fig = power_figure(result)
        FigureCanvasAgg(fig)
        fig.savefig(plot_path, format="png", dpi=130)
    click.echo(_print(result))
