"""``facepair capture``: motion captured by trackers -> FAP tracks (ground truth)."""

from __future__ import annotations

import click


@click.group()
def capture() -> None:
    """Turn captured motion (OpenFace 2.0, Live Link Face) into FAP tracks."""


@capture.command("import")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option("--from", "kind", type=click.Choice(["openface", "arkit", "auto"]),
              default="auto", show_default=True,
              help="The tracker that wrote SOURCE (auto: from its header).")
@click.option("--out", required=True, type=click.Path(dir_okay=False),
              help="Track to write (.fap, .csv, or an ARKit .csv with --to-arkit).")
@click.option("--fps", type=float, default=30.0, show_default=True,
              help="Frame rate of the written track.")
@click.option("--max-gap", type=float, default=0.5, show_default=True,
              help="Longest run of lost frames filled by interpolation, seconds.")
@click.option("--min-confidence", type=float, default=0.75, show_default=True,
              help="OpenFace: frames under this landmark confidence count as lost.")
@click.option("--flip", multiple=True, metavar="COLUMN",
              help="ARKit: turn the sign of a rotation column (e.g. HeadPitch); repeatable.")
def import_(source: str, kind: str, out: str, fps: float, max_gap: float,
            min_confidence: float, flip: tuple[str, ...]) -> None:
    """Import SOURCE (a tracker's CSV) as a FAP track, reporting lost frames and gaps."""
    from app.errors import InputError
    from app.stimuli.capture import sniff_csv
    from app.stimuli.capture.arkit import ROTATIONS, arkit_mapping, read_arkit_csv
    from app.stimuli.capture.openface import read_openface
    from app.stimuli.io import save_track

    if kind == "auto":
        kind = sniff_csv(source) or ""
        if not kind:
            raise InputError("not an OpenFace or Live Link Face CSV (give --from)",
                             path=source, line=1)
    unknown = [f for f in flip if f.lower() not in {r.lower() for r in ROTATIONS}]
    if unknown or (flip and kind != "arkit"):
        raise InputError(f"--flip takes ARKit rotation columns ({', '.join(ROTATIONS)})",
                         field="--flip")
    if kind == "openface":
        track = read_openface(source, fps, min_confidence=min_confidence, max_gap_s=max_gap)
    else:
        track = read_arkit_csv(source, fps, max_gap_s=max_gap, mapping=arkit_mapping(flip=flip))
    save_track(track, out)
    report = track.metadata["capture"]
    click.echo(f"{out}: {track.n_frames} frames at {fps:g} fps from {report['samples']} "
               f"samples at {report['capture_fps']:g} fps; FAPs "
               f"{', '.join(map(str, track.channels))}")
    if report["invalid_samples"] or report["filled_frames"]:
        spans = ", ".join(f"{a:.2f}-{b:.2f} s" for a, b in report["gaps"][:5])
        click.echo(f"  {report['invalid_samples']} lost samples; {report['filled_frames']} "
                   f"frames filled by interpolation ({spans}"
                   f"{', ...' if len(report['gaps']) > 5 else ''})")
    for column, faps in report["missing"].items():
        click.echo(f"  no column {column}: FAP {', '.join(map(str, faps))} not imported")


@capture.command("export")
@click.argument("track_path", metavar="TRACK", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(dir_okay=False),
              help="ARKit blendshape CSV to write (Live Link Face's layout).")
def export(track_path: str, out: str) -> None:
    """Write a FAP track (.fap or .csv) as an ARKit blendshape CSV for ARKit rigs."""
    from app.stimuli.capture.arkit import write_arkit_csv
    from app.stimuli.io import load_track

    track = load_track(track_path)
    write_arkit_csv(track, out)
    click.echo(f"{out}: {track.n_frames} frames of 52 ARKit blendshapes and 9 rotations")
