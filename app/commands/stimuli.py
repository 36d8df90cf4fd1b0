"""``facepair stimuli``: speech + ground truth -> the motion tracks of each condition."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from app.commands.meshopts import mesh_options, mesh_settings

if TYPE_CHECKING:
    from app.stimuli.track import MotionTrack


@click.group()
def stimuli() -> None:
    """Generate and inspect the motion tracks of experimental conditions."""


_greta_option = click.option(
    "--greta",
    is_flag=True,
    help="Write .fap files in Greta's dialect (69-value masks) instead of Xface's (68).",
)


@stimuli.command("convert")
@click.argument("source", type=click.Path(dir_okay=False))
@click.argument("target", type=click.Path(dir_okay=False))
@click.option(
    "--fps",
    type=float,
    default=None,
    help="Frame rate of a CSV source without a '# fps=' line; or resample to it.",
)
@_greta_option
def convert(source: str, target: str, fps: float | None, greta: bool) -> None:
    """Convert a motion track between .fap and .csv (by extension), optionally resampling.

    A .fap source may be in either dialect (Xface or Greta); its mask length tells which.
    """
    from app.stimuli.io import load_track, save_track

    track = load_track(source, fps=fps if source.lower().endswith(".csv") else None)
    if fps is not None and fps != track.fps:
        track = track.resample(fps)
    save_track(track, target, greta=greta)
    click.echo(
        f"{target}: {track.n_frames} frames at {track.fps:g} fps, "
        f"FAPs {', '.join(map(str, track.channels)) or 'none'}"
    )
    for note in convert_notes(track):
        click.echo(f"  note: {note}")


def convert_notes(track: MotionTrack) -> list[str]:
    """The lines a conversion owes its user: high-level FAPs kept, a capture's losses."""
    from app.stimuli.fapfile import high_level_note
    from app.stimuli.summary import capture_note

    notes = []
    high = high_level_note(track)
    if high:
        notes.append(high)
    capture = track.metadata.get("capture")
    if isinstance(capture, dict) and {"samples", "capture_fps"} <= capture.keys():
        notes.append(capture_note(track.source, capture))
    return notes


def _name_value_pairs(items: tuple[str, ...], option: str, form: str) -> dict[str, str]:
    """``NAME=VALUE`` options as a mapping, or one line naming the option."""
    from app.errors import InputError

    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise InputError(f"expected {form}, got {item!r}", field=option)
        out[name.strip()] = value.strip()
    return out


def _speech_options(f):
    """Options shared by the commands that analyse speech."""
    f = click.option(
        "--fps", type=float, default=30.0, show_default=True, help="Video frame rate of the tracks."
    )(f)
    f = click.option(
        "--pitch-floor",
        type=float,
        default=None,
        help="Lowest F0 of the speaker, Hz [default: estimated from the "
        "recording in two passes, 0.75 x first quartile].",
    )(f)
    f = click.option(
        "--pitch-ceiling",
        type=float,
        default=None,
        help="Highest F0 of the speaker, Hz [default: estimated, 1.5 x third quartile].",
    )(f)
    return f


@stimuli.command("reference")
@click.option(
    "--audio",
    required=True,
    type=click.Path(dir_okay=False),
    help="Speech recording: WAV, FLAC, MP3, M4A/AAC or Ogg, mono or stereo (decoded to mono).",
)
@click.option(
    "--out", required=True, type=click.Path(dir_okay=False), help="Track to write (.fap or .csv)."
)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option(
    "--version",
    "version",
    type=click.Choice(["1", "2"]),
    default="1",
    show_default=True,
    help="1: the shipped demo ground truth's (speech drives a third of the head's pitch, little "
    "of its yaw and roll); 2: speech drives about half of each angle (docs/reference/live.md).",
)
@_speech_options
def reference(
    audio: str,
    out: str,
    seed: int,
    version: str,
    fps: float,
    pitch_floor: float,
    pitch_ceiling: float,
) -> None:
    """Write the SYNTHETIC reference speaker's motion for a recording (a ground-truth stand-in)."""
    from app.stimuli.io import save_track
    from app.stimuli.reference_speaker import synthesize_reference
    from app.stimuli.speech import extract_features

    feats = extract_features(audio, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling)
    track = synthesize_reference(feats, seed=seed, version=int(version))
    save_track(track, out)
    click.echo(
        f"{out}: {track.n_frames} frames at {track.fps:g} fps of the SYNTHETIC "
        f"reference speaker (seed {seed}, version {version}); not a recording"
    )


@stimuli.command("fit-head-model")
@click.option("--audio", required=True, type=click.Path(dir_okay=False))
@click.option(
    "--ground-truth",
    "ground_truth",
    required=True,
    type=click.Path(dir_okay=False),
    help="Head motion to learn from (.fap or .csv).",
)
@click.option(
    "--out", required=True, type=click.Path(dir_okay=False), help="Model file to write (JSON)."
)
@click.option(
    "--ridge",
    type=float,
    default=0.0,
    show_default=True,
    help="Ridge penalty, relative to the regressors' energy.",
)
@click.option(
    "--label",
    default=None,
    help="What the model was fitted on, kept in the model file and shown in summaries.",
)
@_speech_options
def fit_head_model(
    audio: str,
    ground_truth: str,
    out: str,
    ridge: float,
    label: str | None,
    fps: float,
    pitch_floor: float,
    pitch_ceiling: float,
) -> None:
    """Fit the speech-driven head ARX model (na=4, nb=4, nk=1) and save it as JSON.

    This is how app/data/models/head_arx_default.json is made from the demo data.
    """
    from app.stimuli.conditions.head_arx import HeadPoseArx
    from app.stimuli.io import load_track
    from app.stimuli.speech import extract_features
    from app.stimuli.track import align_to_features

    feats = extract_features(audio, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling)
    gt = load_track(ground_truth, fps=fps)
    model = HeadPoseArx.fit(feats, align_to_features(gt, feats), ridge=ridge)
    synthetic = "synthetic" in gt.source.lower()
    model.provenance.update(
        fitted_on=label
        or (
            f"{Path(audio).name} with {Path(ground_truth).name}"
            + (" (synthetic reference speaker)" if synthetic else "")
        ),
        audio=Path(audio).name,
        ground_truth=Path(ground_truth).name,
        ridge=ridge,
        fps=fps,
        pitch_floor=pitch_floor,
        pitch_ceiling=pitch_ceiling,
    )
    model.save(out)
    info = model.arx.info
    click.echo(
        f"{out}: head ARX model from {feats.n_frames} frames; spectral radius "
        f"{info['spectral_radius']:.3f}; free-run RMSE (AU) "
        + ", ".join(f"{v:.0f}" for v in info["free_run_rmse"])
    )


@stimuli.command("generate")
@click.option(
    "--audio",
    required=True,
    type=click.Path(dir_okay=False),
    help="Speech recording: WAV, FLAC, MP3, M4A/AAC or Ogg, mono or stereo (decoded to mono).",
)
@click.option(
    "--ground-truth",
    "ground_truth",
    type=click.Path(dir_okay=False),
    default=None,
    help="Captured motion (.fap or .csv), aligned and resampled to the audio.",
)
@click.option(
    "--conditions",
    default=None,
    help="Comma-separated condition names [default: none,random,speech_driven and, "
    "with --ground-truth, ground_truth].",
)
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for <condition>.fap, summary.json and summary.png.",
)
@click.option(
    "--normalize",
    is_flag=True,
    help="Scale and offset every condition's head angles (FAP 48-50) to the ground "
    "truth's mean and sd; eyebrows keep their own (thesis sec. 5.3, "
    "experiment 2).",
)
@click.option(
    "--eyes",
    type=click.Choice(["generated", "still", "ground_truth", "own"]),
    default="generated",
    show_default=True,
    help="Gaze and eyelids, the same in every condition of a clip: generated (blinks and "
    "gaze from the live model, or a live_gmm condition's own), still (no blinks, looking "
    "ahead: the thesis' faces), or the ground truth's; own keeps each condition's (every "
    "condition must then carry eye motion).",
)
@click.option(
    "--track",
    "imported",
    multiple=True,
    metavar="NAME=FILE",
    help="A condition imported from a file (your own system's output, a capture, any track "
    "facepair imports), sharing the eyes, posture and lower face of the others; repeat.",
)
@click.option(
    "--lips",
    type=click.Choice(["shared", "own"]),
    default="shared",
    show_default=True,
    help="Jaw, lips and the rest of the lower face: shared (the ground truth's, else the first "
    "condition's that moves them, in every condition: for clips under the mouth mosaic) or "
    "own (each condition's, for clips without the mosaic that compare lip motion).",
)
@click.option(
    "--brows",
    type=click.Choice(["own", "none", "rule"]),
    default="own",
    show_default=True,
    help="Eyebrows: each condition's own, none in any, or the thesis' speech-driven rule in "
    "every condition (a study of head and eyes alone; live_gmm moves no brow).",
)
@click.option(
    "--pad",
    is_flag=True,
    help="Pad (holding the last frame) or cut a ground truth or imported track whose length "
    "differs from the speech by more than 0.2 s, instead of refusing it.",
)
@click.option(
    "--posture",
    type=click.Choice(["shared", "per_condition"]),
    default="shared",
    show_default=True,
    help="Head rest posture: shared (every condition at the ground truth's median head "
    "pose) or per_condition (each its own, as in the thesis' experiment 1).",
)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option(
    "--f0-threshold",
    default="auto",
    show_default=True,
    help="Eyebrow rule F0 threshold in Hz (the thesis: 207), 'auto' (the percentile of the "
    "speaker's voiced F0 at which the brows are raised 30 % of the time, Table 8's share) or "
    "a percentile such as 'p75'.",
)
@click.option(
    "--intensity-threshold",
    default="auto",
    show_default=True,
    help="Eyebrow release threshold in dB (the thesis: 45), or 'auto' (the 30th "
    "percentile of this recording's voiced intensity).",
)
@click.option(
    "--model",
    "models",
    multiple=True,
    metavar="CONDITION=PATH",
    help="A fitted model file for one condition (head ARX JSON for speech_driven, "
    ".npz for live_gmm), used instead of fitting; repeat per condition.",
)
@click.option("--plot/--no-plot", default=True, show_default=True, help="Also draw summary.png.")
@_greta_option
@_speech_options
@mesh_options
def generate(
    audio: str,
    ground_truth: str | None,
    conditions: str | None,
    out_dir: str,
    normalize: bool,
    eyes: str,
    imported: tuple[str, ...],
    lips: str,
    brows: str,
    pad: bool,
    posture: str,
    seed: int,
    f0_threshold: str,
    intensity_threshold: str,
    models: tuple[str, ...],
    plot: bool,
    greta: bool,
    fps: float,
    pitch_floor: float | None,
    pitch_ceiling: float | None,
    template: str | None,
    mesh_fps: float | None,
    units: str,
    regions: str | None,
    flame_model: str | None,
    mesh_eyes: str,
) -> None:
    """Generate the motion track of each condition for a recording, with objective measures.

    Demo: facepair stimuli generate --audio app/data/demo/speech.wav
    --ground-truth app/data/demo/ground_truth.fap --out demo-out
    """
    import sys

    from tqdm import tqdm

    from app.errors import InputError
    from app.stimuli.generate import generate_conditions, write_outputs

    if conditions is None:
        conditions = "none,random,speech_driven" + (",ground_truth" if ground_truth else "")
    model_files = _name_value_pairs(models, "--model", "CONDITION=PATH")
    tracks = _name_value_pairs(imported, "--track", "NAME=FILE")
    bars: list[tqdm] = []  # made on the first report, so an early error prints alone

    def progress(done: int, total: int) -> None:
        if not bars:
            bars.append(
                tqdm(total=total, desc="stimuli", unit="step", file=sys.stderr, leave=False)
            )
        bars[0].update(done - bars[0].n)

    from app.stimuli.conditions import IMPORTED
    from app.stimuli.generate import parse_conditions

    requests = parse_conditions(conditions)
    for name, path in tracks.items():
        if name in requests:
            raise InputError(f"{name!r} is already a condition", field="--track")
        requests[name] = (IMPORTED, {"track": path})
    sd_params = {"f0_threshold": f0_threshold, "intensity_threshold": intensity_threshold}
    try:
        result = generate_conditions(
            audio,
            conditions=requests,
            ground_truth=ground_truth,
            fps=fps,
            seed=seed,
            normalize=normalize,
            eyes=eyes,
            posture=posture,
            lips=lips,
            brows=brows,
            pad=pad,
            models=model_files,
            progress=progress,
            pitch_floor=pitch_floor,
            pitch_ceiling=pitch_ceiling,
            condition_params={
                n: sd_params for n, (m, _) in requests.items() if m == "speech_driven"
            },
            meshes=mesh_settings(template, mesh_fps, units, regions, flame_model),
            mesh_eyes=mesh_eyes,
        )
        written = write_outputs(result, out_dir, plot=plot, greta=greta)
    finally:
        for bar in bars:
            bar.close()
    feats = result.features
    click.echo(
        f"{audio}: {feats.n_frames} frames at {feats.fps:g} fps, {feats.voiced.mean():.0%} voiced"
    )
    if feats.metadata.get("audio_file"):
        click.echo(f"  audio: {feats.metadata['audio_file']}")
    for path in written:
        click.echo(f"  wrote {path}")
    for note in result.summary["notes"]:
        click.echo(f"  note: {note}")


# -- live head-and-eye model (app/stimuli/live) --------------------------------------------------


@stimuli.command("train-live")
@click.option(
    "--audio",
    "audio",
    multiple=True,
    required=True,
    type=click.Path(dir_okay=False),
    help="Speech recording (.wav); repeat the option for several takes.",
)
@click.option(
    "--ground-truth",
    "ground_truth",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="Motion of each --audio take (.fap or .csv), in the same order: head 48-50 "
    "required, gaze 23-26 and eyelids 19-22 used when present.",
)
@click.option(
    "--reference",
    is_flag=True,
    help="Instead of --ground-truth: the synthetic reference speaker's motion for "
    "each take (app.stimuli.reference_speaker).",
)
@click.option("--reference-seed", type=int, default=0, show_default=True)
@click.option(
    "--reference-version",
    type=click.Choice(["1", "2"]),
    default="1",
    show_default=True,
    help="With --reference: the reference speaker's version (see 'stimuli reference').",
)
@click.option(
    "--repeat",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="With --reference: play each audio file N times in a row as one take "
    "(more motion, blinks and gaze shifts to learn from a short file).",
)
@click.option(
    "--out", required=True, type=click.Path(dir_okay=False), help="Model file to write (.npz)."
)
@_speech_options
@click.option(
    "--components",
    type=click.IntRange(min=1),
    default=10,
    show_default=True,
    help="Gaussian components per mixture (sec. 5.1).",
)
@click.option("--seed", type=int, default=0, show_default=True, help="EM initialisation seed.")
def train_live(
    audio: tuple[str, ...],
    ground_truth: tuple[str, ...],
    reference: bool,
    reference_seed: int,
    reference_version: str,
    repeat: int,
    out: str,
    fps: float,
    pitch_floor: float,
    pitch_ceiling: float,
    components: int,
    seed: int,
) -> None:
    """Train the live speech-driven head-and-eye model (Le, Ma & Deng 2012) and save it."""
    import sys

    import numpy as np
    from tqdm import tqdm

    from app.errors import InputError
    from app.stimuli.io import load_track
    from app.stimuli.live.model import train_live_model
    from app.stimuli.live.modelfile import save_model
    from app.stimuli.reference_speaker import synthesize_reference
    from app.stimuli.speech import SpeechFeatures, extract_features

    if reference and ground_truth:
        raise InputError("give either --ground-truth or --reference, not both", field="--reference")
    if not reference and len(ground_truth) != len(audio):
        raise InputError(
            f"give one --ground-truth per --audio ({len(audio)} audio, "
            f"{len(ground_truth)} ground truth), or --reference",
            field="--ground-truth",
        )
    if repeat > 1 and not reference:
        raise InputError(
            "--repeat needs --reference (a recorded ground truth does not repeat)", field="--repeat"
        )
    feats, truths = [], []
    with tqdm(
        total=len(audio) + 12, desc="train-live", unit="step", file=sys.stderr, disable=None
    ) as bar:
        for i, path in enumerate(audio):
            f = extract_features(path, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling)
            if repeat > 1:
                f = SpeechFeatures(
                    f.fps,
                    np.tile(f.f0, repeat),
                    np.tile(f.intensity, repeat),
                    np.tile(f.f0_conditioned, repeat),
                    {**f.metadata, "repeated": repeat},
                )
            feats.append(f)
            if reference:
                truths.append(
                    synthesize_reference(f, seed=reference_seed + i, version=int(reference_version))
                )
            else:
                truths.append(load_track(ground_truth[i]))
            bar.update()
        model = train_live_model(
            feats, truths, n_components=components, seed=seed, progress=bar.update
        )
    save_model(model, out)
    s = model.summary
    click.echo(
        f"{out}: {s['takes']} take(s), {s['frames']} frames at {s['fps']:g} fps, "
        f"{s['eyelids']['blinks']} blinks, gaze "
        f"{'on' if s['gaze_enabled'] else 'off (no gaze in the ground truth)'}"
    )


@stimuli.command("evaluate")
@click.option(
    "--audio",
    "audio",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="A test recording; repeat for several (with --ground-truth in the same order).",
)
@click.option(
    "--ground-truth",
    "ground_truth",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="The captured motion of each --audio.",
)
@click.option(
    "--train-audio",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="A training recording (never measured); repeat for several.",
)
@click.option(
    "--train-ground-truth",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="The captured motion of each --train-audio.",
)
@click.option(
    "--split",
    type=float,
    default=None,
    help="Without --train-*: train on this leading fraction of each recording and "
    "test on the rest (e.g. 0.5).",
)
@click.option(
    "--conditions",
    default="none,random,speech_driven,ground_truth",
    show_default=True,
    help="Comma-separated condition names.",
)
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for evaluation.json and evaluation.png; a summary.json there gains "
    "an 'evaluation' section.",
)
@click.option("--seed", type=int, default=0, show_default=True)
@_speech_options
def evaluate(
    audio: tuple[str, ...],
    ground_truth: tuple[str, ...],
    train_audio: tuple[str, ...],
    train_ground_truth: tuple[str, ...],
    split: float | None,
    conditions: str,
    out_dir: str,
    seed: int,
    fps: float,
    pitch_floor: float | None,
    pitch_ceiling: float | None,
) -> None:
    """Measure every condition on held-out speech: coupling with F0 and intensity, correlation
    with the held-out ground truth, kinematics and jitter, against null baselines."""
    import json
    import sys

    from tqdm import tqdm

    from app.errors import InputError
    from app.stimuli.evaluate import evaluate_conditions, load_takes, plot_evaluation, split_take
    from app.stimuli.summary import jsonable

    for given, truths, flag in (
        (audio, ground_truth, "--ground-truth"),
        (train_audio, train_ground_truth, "--train-ground-truth"),
    ):
        if len(given) != len(truths):
            raise InputError(
                f"give one {flag} per recording ({len(given)} audio, {len(truths)} ground truth)",
                field=flag,
            )
    if not audio:
        raise InputError("give at least one --audio with its --ground-truth", field="--audio")
    if bool(train_audio) == (split is not None):
        raise InputError(
            "give either --train-audio/--train-ground-truth or --split", field="--split"
        )
    opts = dict(fps=fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling)
    test = load_takes(list(zip(audio, ground_truth, strict=True)), **opts)
    if split is not None:
        halves = [split_take(take, split) for take in test]
        train, test = [h[0] for h in halves], [h[1] for h in halves]
    else:
        train = load_takes(list(zip(train_audio, train_ground_truth, strict=True)), **opts)
    with tqdm(
        total=len(conditions.split(",")) + 2,
        desc="evaluate",
        unit="step",
        file=sys.stderr,
        disable=None,
    ) as bar:
        report = jsonable(
            evaluate_conditions(
                train,
                test,
                conditions=conditions,
                seed=seed,
                progress=lambda done, total: bar.update(done - bar.n),
            )
        )
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "evaluation.json").write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    plot_evaluation(report, out / "evaluation.png")
    summary = out / "summary.json"
    if summary.is_file():
        data = json.loads(summary.read_text(encoding="utf-8"))
        data["evaluation"] = report
        summary.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    click.echo(
        f"trained on {report['train']['frames']} frames, tested on "
        f"{report['test']['frames']}; wrote {out / 'evaluation.json'} and "
        f"{out / 'evaluation.png'}"
    )
    for name, row in report["conditions"].items():
        head, yaw = row["coupling"]["head"]["mean"], row["channels"]["49"]
        click.echo(
            f"  {name:14s} head-speech CCA {_fmt(head)}  yaw r(truth) "
            f"{_fmt(yaw['r_truth']['mean'])}  yaw sd {_fmt(yaw['sd']['mean'], 0)} AU  "
            f">4 Hz {_fmt(yaw['power_above_4hz']['mean'])}"
        )


def _fmt(x: float | None, digits: int = 2) -> str:
    return "  -  " if x is None else f"{x:.{digits}f}"
