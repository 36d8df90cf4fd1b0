"""``facepair analyze``: votes CSV -> statistics (JSON), report (HTML, PDF) and a summary table."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import tempfile
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from app.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Iterator

    from app.analysis.package import StudyPackage


def _summary(results: dict[str, Any]) -> str:
    """A short terminal table: ballots, scale and the agreement test, pooled over clips."""
    pooled, info = results["pooled"], results["input"]
    scale = {s["condition"]: s for s in pooled["scale"]}
    width = max(len(c) for c in [*results["conditions"], "condition"])
    lines = [
        f"{info['votes']} votes, {info['participants']} participants, "
        f"{len(info['clips'])} clips; skipped bad rows: {info['skipped_rows']}; "
        f"undecided: {results['options']['undecided']}",
        f"{'condition':<{width}}  ballots  scale (JOD)  95% CI",
    ]
    for c in results["conditions"]:
        s = scale[c]
        value = "-" if s["score"] is None else f"{s['score']:+.2f}"
        ci = "-" if s["ci_low"] is None else f"[{s['ci_low']:+.2f}, {s['ci_high']:+.2f}]"
        lines.append(f"{c:<{width}}  {pooled['ballots'][c]:>7}  {value:>11}  {ci}")
    lines.append(f"{'undecided':<{width}}  {pooled['undecided']:>7}")
    ag = pooled["agreement"]
    if ag["u"] is not None:
        lines.append(
            f"agreement u = {ag['u']:.3f}, chi2({ag['df']:.2f}) = {ag['chi2']:.2f}, "
            f"p = {ag['p']:.3g} (corrected p = {ag['p_corrected']:.3g})"
        )
    sig = [s for s in pooled["sign_tests"] if s["p_holm"] is not None and s["p_holm"] < 0.05]
    lines.append(
        f"sign tests: {len(sig)} of {len(pooled['sign_tests'])} pairs differ (Holm p < .05)"
    )
    wil = [w for w in pooled["participant_level"] if w["p_holm"] is not None and w["p_holm"] < 0.05]
    lines.append(
        f"participant-level Wilcoxon tests: {len(wil)} of "
        f"{len(pooled['participant_level'])} pairs differ (Holm p < .05)"
    )
    mixed = pooled.get("mixed_btd")
    if mixed and mixed["sd_participant"] is not None:
        lines.append(
            f"mixed model (participant × condition and clip × condition random effects): "
            f"sd participant "
            f"{mixed['sd_participant']:.3f}, sd clip "
            + ("-" if mixed["sd_clip"] is None else f"{mixed['sd_clip']:.3f}")
            + "; JOD "
            + ", ".join(
                f"{c} {mixed['jod'][c]:+.2f}"
                for c in results["conditions"]
                if mixed["jod"][c] is not None
            )
        )
    elif mixed:
        lines.append(f"mixed model: not fitted ({mixed['note']})")
    excluded = results["quality"]["excluded"]
    if results["quality"]["rules"]:
        lines.append(
            f"excluded by {', '.join(results['quality']['rules'])}: "
            + (", ".join(excluded) if excluded else "nobody")
        )
    return "\n".join(lines)


def read_summaries(items: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """``("CLIP=PATH", ...)`` -> ``{clip: summary.json}``; a bad item is one line."""
    out: dict[str, dict[str, Any]] = {}
    for item in items:
        clip, eq, path = item.partition("=")
        if not eq or not clip.strip() or not path.strip():
            raise InputError(f"expected CLIP=SUMMARY.json, got {item!r}", field="measures")
        try:
            data = json.loads(Path(path).read_text(encoding="utf-8"))
        except OSError as exc:
            raise InputError(f"cannot read: {exc.strerror}", path=Path(path)) from None
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"not JSON: {exc}", path=Path(path)) from None
        if not isinstance(data, dict) or not isinstance(data.get("conditions"), dict):
            raise InputError("expected a summary.json with 'conditions'", path=Path(path))
        out[clip.strip()] = data
    return out


@contextlib.contextmanager
def _table_file(package: StudyPackage) -> Iterator[Path]:
    """The package's table (votes or ratings) as a file of its own name in a temporary folder:
    read as the file it is, by the one reader of its format."""
    with tempfile.TemporaryDirectory() as folder:
        copy = Path(folder) / package.table
        copy.write_text(package.table_text, encoding="utf-8", newline="")
        yield copy


def package_votes(
    package: StudyPackage, path: str, names: list[str] | None, exclude: str | None
) -> tuple[Any, list[str] | None, str | None]:
    """A study package (``app.analysis.package``, read from ``path``) in place of a votes CSV:
    its votes, with the conditions and exclusion rules its report used unless the command line
    gives others."""
    from app.analysis import read_votes
    from app.analysis.package import VOTES

    names = names if names is not None else package.conditions
    with _table_file(package) as copy:
        votes = read_votes(copy, conditions=names)
    # the report names the file it analysed by its name: the same one
    votes = dataclasses.replace(votes, source=f"{Path(path).name}/{VOTES}")
    return votes, names, exclude if exclude is not None else package.exclude


@click.command("analyze")
@click.argument("votes", type=click.Path(dir_okay=False))
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    help="Write every statistic as JSON here.",
)
@click.option(
    "--report",
    "html_path",
    type=click.Path(dir_okay=False),
    help="Write the self-contained HTML report here.",
)
@click.option(
    "--pdf", "pdf_path", type=click.Path(dir_okay=False), help="Also write the report as PDF."
)
@click.option(
    "--undecided",
    type=click.Choice(["exclude", "split"]),
    default="exclude",
    show_default=True,
    help="Undecided votes: left out, or half to each side.",
)
@click.option(
    "--skip-bad-rows",
    is_flag=True,
    help="Drop invalid rows (their count is reported) instead of stopping.",
)
@click.option(
    "--conditions",
    default=None,
    help="Comma-separated condition names, in the order to report them.",
)
@click.option(
    "--bootstrap",
    type=click.IntRange(0, 100000),
    default=1000,
    show_default=True,
    help="Bootstrap replicates for the scale's intervals (0: none).",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Bootstrap seed.")
@click.option("--anchor", default=None, help="Fix this condition at 0 on the scale.")
@click.option(
    "--exclude",
    default=None,
    metavar="RULES",
    help="Leave out participants matching any rule, e.g. 'catch<1.0,side_p<0.001' "
    "(fields: side_left, side_p, undecided, tau, catch, median_ms, outlier).",
)
@click.option(
    "--mixed-model/--no-mixed-model",
    default=True,
    show_default=True,
    help="Also fit Bradley-Terry-Davidson with participant and clip random effects "
    "(its time grows with participants x clips).",
)
@click.option(
    "--measures",
    "measures_paths",
    multiple=True,
    metavar="CLIP=SUMMARY",
    help="The objective measures of a clip's conditions (summary.json of facepair stimuli "
    "generate), e.g. 's1=out/s1/summary.json'; repeat per clip. Regressed on the scores.",
)
@click.option(
    "--reference-below",
    type=click.FloatRange(0, 100),
    default=90,
    show_default=True,
    help="Ratings (parallel design): post-screening score the hidden reference must reach "
    "(ITU-R BS.1534-3 sec. 4.1.2).",
)
@click.option(
    "--reference-share",
    type=click.FloatRange(0, 1),
    default=0.15,
    show_default=True,
    help="Ratings (parallel design): leave out a participant below --reference-below on "
    "more than this share of clips.",
)
def analyze(
    votes: str,
    json_path: str | None,
    html_path: str | None,
    pdf_path: str | None,
    undecided: str,
    skip_bad_rows: bool,
    conditions: str | None,
    bootstrap: int,
    seed: int,
    anchor: str | None,
    exclude: str | None,
    mixed_model: bool,
    measures_paths: tuple[str, ...],
    reference_below: float,
    reference_share: float,
) -> None:
    """Analyse the votes of a paired-comparison study (CSV) and report the results; a
    ratings table (the rating design's ratings.csv) gets its MOS analysis instead.

    VOTES may also be a study package (the zip a study's page or 'facepair study export
    --package' writes): its votes are analysed with the conditions and exclusion rules of its
    report, so the numbers are the report's."""
    from tqdm import tqdm

    from app.analysis import analyze as run_analysis
    from app.analysis import read_votes
    from app.analysis.report.writer import write_report

    if pdf_path is not None and html_path is None:
        raise click.UsageError("--pdf needs --report (both come from the same content)")
    names = None if conditions is None else [c.strip() for c in conditions.split(",") if c.strip()]
    from app.analysis.rating_results import is_ratings_file

    screening = (reference_below, reference_share)
    if is_ratings_file(votes):
        _analyze_ratings(votes, names, json_path, html_path, pdf_path, screening)
        return
    package = None
    if zipfile.is_zipfile(votes):
        from app.analysis.package import RATINGS, read_package

        package = read_package(votes)
        if package.table == RATINGS:  # a rating study's package: its ratings, as the report
            with _table_file(package) as copy:
                _analyze_ratings(
                    str(copy),
                    names if names is not None else package.conditions,
                    json_path,
                    html_path,
                    pdf_path,
                    screening,
                    source=f"{Path(votes).name}/{RATINGS}",
                )
            return
    summaries = read_summaries(measures_paths)
    # reading, the statistics (each clip, the pooled votes, the mixed model's updates: the
    # analysis says how many) and the report
    writes = (html_path is not None) + (pdf_path is not None and html_path is not None)
    steps = 2 + writes
    with tqdm(total=steps, desc="analyze", unit="step", disable=None) as bar:

        def statistics(done: int, total: int) -> None:
            bar.total = 1 + total + writes
            bar.n = 1 + done
            bar.refresh()

        if package is not None:  # read once, above
            table, names, exclude = package_votes(package, votes, names, exclude)
        else:
            table = read_votes(votes, skip_bad_rows=skip_bad_rows, conditions=names)
        bar.update()
        if table.skipped:
            click.echo(
                f"facepair: skipped {table.skipped} bad rows; first: {table.problems[0]}", err=True
            )
        results = run_analysis(
            table,
            conditions=names,
            undecided=undecided,
            bootstrap=bootstrap,
            seed=seed,
            anchor=anchor,
            exclude=exclude,
            mixed_model=mixed_model,
            progress=statistics,
        )
        if summaries:
            from app.analysis.objective import (
                field_metrics,
                measures_from_summaries,
                objective_to_perceptual,
                report_scores,
            )

            measures = measures_from_summaries(summaries)
            results["objective"] = objective_to_perceptual(
                measures, report_scores(results), confidence=results["options"]["confidence"]
            )
            results["objective"]["field_metrics"] = field_metrics(measures)
        bar.n = bar.total - writes
        bar.refresh()
        if json_path is not None:
            Path(json_path).write_text(
                json.dumps(results, indent=1, allow_nan=False) + "\n", encoding="utf-8"
            )
        if html_path is not None:
            write_report(results, html_path, pdf_path)
            bar.n = bar.total
            bar.refresh()
    click.echo(_summary(results))


def _analyze_ratings(
    path: str,
    names: list[str] | None,
    json_path: str | None,
    html_path: str | None,
    pdf_path: str | None,
    screening: tuple[float, float],
    source: str | None = None,
) -> None:
    """``facepair analyze ratings.csv``: MOS with intervals and Holm-adjusted contrasts
    (:func:`app.analysis.rating_results.analyze_ratings`), written as the votes' are;
    ``source`` names the file in the results (``path`` unless given)."""
    from app.analysis.rating_results import analyze_ratings, read_ratings
    from app.analysis.report.rating_document import summary_text
    from app.analysis.report.writer import write_report

    below, share = screening
    results = analyze_ratings(
        read_ratings(path),
        conditions=names,
        source=source or path,
        reference_below=below,
        reference_share=share,
    )
    if json_path is not None:
        Path(json_path).write_text(
            json.dumps(results, indent=1, allow_nan=False) + "\n", encoding="utf-8"
        )
    if html_path is not None:
        write_report(results, html_path, pdf_path)
    click.echo(summary_text(results))
