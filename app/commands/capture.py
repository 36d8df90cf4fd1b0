"""``facepair capture``: motion captured by trackers or markers -> FAP tracks (ground truth)."""

from __future__ import annotations

import click


@click.group()
def capture() -> None:
    """Turn captured motion (OpenFace 2.0, Live Link Face, marker videos) into FAP tracks."""


def _save(track, out: str, samples: str) -> dict:
    """Write ``track`` and print what it holds; returns its capture report."""
    from app.stimuli.io import save_track

    save_track(track, out)
    report = track.metadata["capture"]
    click.echo(
        f"{out}: {track.n_frames} frames at {track.fps:g} fps from {report['samples']} "
        f"{samples} at {report['capture_fps']:g} fps; FAPs "
        f"{', '.join(map(str, track.channels))}"
    )
    return report


@capture.command("import")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option(
    "--from",
    "kind",
    type=click.Choice(
        [
            "auto",
            "openface",
            "arkit",
            "a2f-csv",
            "a2f-json",
            "openfacefx-json",
            "openfacefx-csv",
            "bvh",
        ]
    ),
    default="auto",
    show_default=True,
    help="The tool that wrote SOURCE (auto: from its header or extension).",
)
@click.option(
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="Track to write (.fap, .csv, or an ARKit .csv with --to-arkit).",
)
@click.option(
    "--fps", type=float, default=30.0, show_default=True, help="Frame rate of the written track."
)
@click.option(
    "--max-gap",
    type=float,
    default=0.5,
    show_default=True,
    help="Longest run of lost frames filled by interpolation, seconds.",
)
@click.option(
    "--min-confidence",
    type=float,
    default=0.75,
    show_default=True,
    help="OpenFace: frames under this landmark confidence count as lost.",
)
@click.option(
    "--flip",
    multiple=True,
    metavar="COLUMN",
    help="ARKit: turn the sign of a rotation column (e.g. HeadPitch); repeatable.",
)
@click.option(
    "--neutral",
    metavar="median|none|START-END",
    default=None,
    help="OpenFace and BVH: the head's neutral pose: the take's median (OpenFace's default), "
    "none (the camera's or the skeleton's rest pose, BVH's default) or the median over a "
    "calibration window in seconds.",
)
@click.option(
    "--gaze-neutral",
    type=click.Choice(["none", "median"]),
    default=None,
    help="OpenFace: take the take's median gaze out of the eyes (median; a camera below the "
    "eyes' line makes a take look down throughout) or keep it (none, the default); the "
    "summary says what it was.",
)
@click.option(
    "--brow-neutral",
    type=click.Choice(["median", "none"]),
    default=None,
    help="ARKit / Live Link Face: the brows relative to the take's rest (median, the default) "
    "or as recorded (none).",
)
def import_(
    source: str,
    kind: str,
    out: str,
    fps: float,
    max_gap: float,
    min_confidence: float,
    flip: tuple[str, ...],
    neutral: str | None,
    gaze_neutral: str | None,
    brow_neutral: str | None,
) -> None:
    """Import SOURCE (a tracker's or a tool's file) as a FAP track, reporting lost frames,
    gaps, the neutral pose and what could not be imported."""
    from app.errors import InputError
    from app.stimuli.capture import FORMATS, import_track, sniff
    from app.stimuli.capture.arkit import ROTATIONS
    from app.stimuli.capture.headframe import Neutral

    if kind == "auto":
        kind = sniff(source) or ""
        if not kind:
            raise InputError(
                f"not a file facepair imports ({', '.join(FORMATS)}; give --from)",
                path=source,
                line=1,
            )
    unknown = [f for f in flip if f.lower() not in {r.lower() for r in ROTATIONS}]
    if unknown or (flip and kind != "arkit"):
        raise InputError(
            f"--flip takes ARKit rotation columns ({', '.join(ROTATIONS)})", field="--flip"
        )
    if neutral is not None and kind not in ("openface", "bvh"):
        raise InputError("--neutral is for OpenFace and BVH files", field="--neutral")
    if gaze_neutral is not None and kind != "openface":
        raise InputError("--gaze-neutral is for OpenFace files", field="--gaze-neutral")
    if brow_neutral is not None and kind != "arkit":
        raise InputError(
            "--brow-neutral is for ARKit / Live Link Face files", field="--brow-neutral"
        )
    track = import_track(
        source,
        kind,
        fps,
        max_gap_s=max_gap,
        min_confidence=min_confidence,
        flip=flip,
        neutral=Neutral.parse(neutral) if neutral is not None else None,
        brow_neutral=brow_neutral,
        gaze_neutral=gaze_neutral,
    )
    report = _save(track, out, "samples")
    if report["invalid_samples"] or report["filled_frames"]:
        click.echo(f"  {lost_and_filled(report)}")
    if "neutral" in report:
        n = report["neutral"]
        click.echo(
            f"  head relative to {n['described']} (pitch {n['pitch_deg']:g}, yaw "
            f"{n['yaw_deg']:g}, roll {n['roll_deg']:g} deg from {n.get('from', 'the camera axis')})"
        )
    if "gaze" in report:
        offset = report.get("gaze_offset")
        said = (
            f" (median: {offset['pitch_deg']:g} deg down, {offset['yaw_deg']:g} deg to the "
            "face's left)"
            if offset
            else ""
        )
        click.echo(f"  gaze: {report['gaze']}{said}")
    for line in report.get("warnings", []):
        click.echo(f"  {line}")
    for column, faps in report["missing"].items():
        click.echo(f"  no column {column}: FAP {', '.join(map(str, faps))} not imported")


def lost_and_filled(report: dict) -> str:
    """One line on a capture's lost samples and the frames filled between them.

    >>> lost_and_filled({"invalid_samples": 4, "filled_frames": 0, "gaps": []})
    '4 lost samples; no frame filled (each lost sample was at an end, or fell between frames)'
    >>> lost_and_filled({"invalid_samples": 3, "filled_frames": 2, "gaps": [(1.0, 1.1)]})
    '3 lost samples; 2 frames filled by interpolation (1.00-1.10 s)'
    """
    lost = f"{report['invalid_samples']} lost samples"
    if not report["filled_frames"]:
        return f"{lost}; no frame filled (each lost sample was at an end, or fell between frames)"
    spans = ", ".join(f"{a:.2f}-{b:.2f} s" for a, b in report["gaps"][:5])
    more = ", ..." if len(report["gaps"]) > 5 else ""
    return f"{lost}; {report['filled_frames']} frames filled by interpolation ({spans}{more})"


@capture.command("export")
@click.argument("track_path", metavar="TRACK", type=click.Path(dir_okay=False))
@click.option(
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="ARKit blendshape CSV to write (Live Link Face's layout).",
)
def export(track_path: str, out: str) -> None:
    """Write a FAP track (.fap or .csv) as an ARKit blendshape CSV for ARKit rigs."""
    from app.stimuli.capture.arkit import write_arkit_csv
    from app.stimuli.io import load_track

    track = load_track(track_path)
    write_arkit_csv(track, out)
    click.echo(f"{out}: {track.n_frames} frames of 52 ARKit blendshapes and 9 rotations")


def _constants(constants_path: str | None, fapu: str | None, squash: bool):
    """Marker constants from a JSON file, the subject's FAPU and the squashing switch."""
    from dataclasses import replace

    from app.errors import InputError
    from app.stimuli.capture.marker_faps import MarkerConstants

    c = MarkerConstants.from_json(constants_path) if constants_path else MarkerConstants()
    if fapu:
        values = dict(c.fapu_mm)
        for item in fapu.split(","):
            key, _, value = item.partition("=")
            try:
                number = float(value)
            except ValueError:
                number = float("nan")
            if key.strip() not in values or not number > 0 or number == float("inf"):
                raise InputError(
                    f"expected ENS0=mm,MNS0=mm,MW0=mm with positive numbers, got {item!r}",
                    field="--fapu",
                )
            values[key.strip()] = number
        c = replace(c, fapu_mm=values)
    return c if squash else replace(c, squash=False)


def _marker_options(fn):
    for option in reversed(
        [
            click.option(
                "--constants",
                "constants_path",
                type=click.Path(dir_okay=False),
                help="JSON of marker constants (kp, ky, apexes, ...; see docs/reference/capture.md)"
                ", e.g. written by `capture calibrate`.",
            ),
            click.option(
                "--fapu",
                metavar="ENS0=MM,MNS0=MM,MW0=MM",
                help="The subject's FAPU in mm, measured in the neutral pose.",
            ),
            click.option(
                "--threshold",
                type=click.FloatRange(1, 255),
                default=128.0,
                show_default=True,
                help="Segmentation threshold (grey level).",
            ),
            click.option(
                "--weights",
                type=click.Choice(["grey", "binary"]),
                default="grey",
                show_default=True,
                help="Centre-of-gravity weights.",
            ),
            click.option(
                "--max-gap",
                type=click.FloatRange(0, None),
                default=0.5,
                show_default=True,
                help="Longest time a marker may be lost (recovered by interpolation).",
            ),
        ]
    ):
        fn = option(fn)
    return fn


def _label(video: str, threshold: float, weights: str, max_gap: float):
    from app.commands.render import _progress_bar
    from app.stimuli.capture.markers import label_frames
    from app.stimuli.capture.video import read_grey_frames, video_info

    info = video_info(video)
    with _progress_bar("markers") as progress:
        return label_frames(
            read_grey_frames(video, info),
            threshold=threshold,
            weights=weights,
            max_gap_s=max_gap,
            path=video,
            progress=lambda k: progress(k, max(info["n_frames"], k)),
        )


@capture.command("markers")
@click.argument("video", type=click.Path(dir_okay=False))
@click.option(
    "--out", required=True, type=click.Path(dir_okay=False), help="Track to write (.fap or .csv)."
)
@click.option(
    "--fps",
    type=click.FloatRange(1, 1000),
    default=30.0,
    show_default=True,
    help="Frame rate of the written track.",
)
@click.option(
    "--no-squash", is_flag=True, help="Skip the thesis' Gaussian squashing: FAPs as measured."
)
@_marker_options
def markers(
    video: str,
    out: str,
    fps: float,
    no_squash: bool,
    constants_path: str | None,
    fapu: str | None,
    threshold: float,
    weights: str,
    max_gap: float,
) -> None:
    """Capture FAPs from an IR video of the thesis' 17 markers (head frame, brows, lips)."""
    from pathlib import Path

    from app.stimuli.capture.markers import tracks_to_faps

    c = _constants(constants_path, fapu, not no_squash)
    tracks = _label(video, threshold, weights, max_gap)
    track = tracks_to_faps(
        tracks, fps=fps, constants=c, max_gap_s=max_gap, path=video, name=Path(video).stem
    )
    report = _save(track, out, "video frames")
    if report["filled_frames"] or report["duplicates"]:
        click.echo(
            f"  {report['filled_frames']} dropped frames filled, "
            f"{report['duplicates']} duplicated frames dropped"
        )
    for name, a, b in report["marker_gaps"]:
        click.echo(f"  marker {name} lost in frames {a}-{b}: recovered by interpolation")


@capture.command("calibrate")
@click.argument("video", type=click.Path(dir_okay=False))
@click.option(
    "--truth",
    required=True,
    type=click.Path(dir_okay=False),
    help="The head's known motion (.fap or .csv): FAPs 48 (pitch) and 49 (yaw).",
)
@click.option(
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="JSON of constants to write (for `capture markers --constants`).",
)
@_marker_options
def calibrate(
    video: str,
    truth: str,
    out: str,
    constants_path: str | None,
    fapu: str | None,
    threshold: float,
    weights: str,
    max_gap: float,
) -> None:
    """Measure kp, ky and the eyebrows' pitch coupling on a neutral face of known pose."""
    from app.stimuli.capture.calibration import calibrate as fit
    from app.stimuli.io import load_track

    known = load_track(truth)
    c = fit(
        _label(video, threshold, weights, max_gap), known, _constants(constants_path, fapu, True)
    )
    c.to_json(out)
    click.echo(
        f"{out}: kp {c.kp:.4f} (thesis 0.15), ky {c.ky:.4f} (thesis 0.05), eyebrow "
        f"pitch coupling {c.brow_pitch_inner:.1f} / {c.brow_pitch_middle:.1f} ENS/rad"
    )
