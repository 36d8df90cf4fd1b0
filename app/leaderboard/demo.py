"""The demo season's inputs: a benchmark from the demo speech and systems in several formats.

``facepair leaderboard demo`` runs a whole season from what this module writes:

- :func:`write_benchmark`: the demo speech (CMU ARCTIC ``arctic_a0007``, 4 s) cut at its
  pauses into two segments with their transcripts, the shipped synthetic ground truth cut the
  same way, and a season file with small frames (96 px, 12 fps) so that a round's 70 clips
  render in a few minutes on two cores;
- :func:`write_systems`: the tracks of four systems as their makers would send them, each in
  another format facepair imports: an MPEG-4 ``.fap`` (the speech-driven head model), an ARKit
  blendshape CSV in Live Link Face's layout (random motion), a BVH skeleton with three
  samples per segment (a stochastic system: the ground truth's head, smoothed and shifted by a
  different lag per sample) and, for the second round, a FAP CSV (the live head-and-eye
  model).

The simulated participants' preferences (:data:`TRUE_STRENGTHS`) are set by system, not
read from the motion: the demo checks that the board recovers them, whatever the faces show.
"""

from __future__ import annotations

import wave
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.data import data_path
from app.stimuli.fap import AU_RADIANS, HEAD
from app.stimuli.io import load_track, save_track
from app.stimuli.speechaudio import read_speech_audio
from app.stimuli.track import MotionTrack

#: Where the demo speech is cut (seconds): the pause after "ever" (energy minimum).
CUT_S = 1.85
SEGMENTS = (("s01", 0.0, CUT_S, "Will we ever"), ("s02", CUT_S, None, "forget it."))


@dataclass(frozen=True)
class DemoSystem:
    """A demo system: its name, how it is described, which round it joins, its files' maker."""

    name: str
    model: str
    fmt: str
    round: int
    samples: int = 1
    paper: str = ""
    training_data: str = "the demo's synthetic reference speaker (app/data/demo)"


SYSTEMS = (
    DemoSystem("ProsodyARX", "speech_driven", "fap", 1, paper="https://example.org/prosody-arx"),
    DemoSystem("BlendRandom", "random", "arkit", 1),
    DemoSystem("SkeletonLag", "lagged_truth", "bvh", 1, samples=3),
    DemoSystem("LiveGMM", "live_gmm", "csv", 2, paper="https://example.org/live-gmm"),
)
#: The simulated listeners' log worths (Bradley-Terry scale) and how often each system's matched
#: face wins a mismatched-speech pair: the truth the published board must recover.
TRUE_STRENGTHS: Mapping[str, float] = {
    "ground_truth": 1.4,
    "ProsodyARX": 0.7,
    "LiveGMM": 0.2,
    "BlendRandom": -0.3,
    "SkeletonLag": -0.8,
    "none": -1.5,
}
TRUE_COHERENCE: Mapping[str, float] = {
    "ground_truth": 0.8,
    "ProsodyARX": 0.7,
    "LiveGMM": 0.6,
    "BlendRandom": 0.5,
    "SkeletonLag": 0.65,
    "none": 0.5,
}


def _write_wav(path: Path, samples: np.ndarray, rate: int) -> None:
    pcm = np.clip(np.round(samples * 32767.0), -32768, 32767).astype("<i2")
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(pcm.tobytes())


def write_benchmark(folder: Path, *, organiser: str, min_votes: int = 200) -> Path:
    """The demo's segments and season file in ``folder``; returns the season file."""
    folder.mkdir(parents=True, exist_ok=True)
    speech = read_speech_audio(data_path("demo", "speech.wav"))
    rate = int(speech.sample_rate)
    truth = load_track(data_path("demo", "ground_truth.fap"))
    blocks = []
    for name, start, end, transcript in SEGMENTS:
        stop = len(speech.samples) if end is None else int(round(end * rate))
        _write_wav(folder / f"{name}.wav", speech.samples[int(round(start * rate)) : stop], rate)
        first = int(round(start * truth.fps))
        last = truth.n_frames if end is None else int(round(end * truth.fps))
        save_track(truth.replace(values=truth.values[first:last].copy()), folder / f"{name}_gt.fap")
        blocks.append(
            f'[[segments]]\nname = "{name}"\naudio = "{name}.wav"\n'
            f'ground_truth = "{name}_gt.fap"\ntranscript = "{transcript}"\n'
        )
    text = f'''# The demo season (facepair leaderboard demo): two segments of the demo speech.
name = "demo"
title = "facepair demo leaderboard"
organiser = "{organiser}"
seed = 2026
description = "A whole season on the demo speech, voted by simulated participants."

{chr(10).join(blocks)}
[render]
size = 96
mosaic_block = 12
fps = 12
look = "textured"

[test]
consent = "This is a demonstration with simulated participants."
eyes = "generated"
catch = {{ trials = 2, kind = "identical" }}
undecided = {{ allowed = true, label = "Cannot decide" }}

[rounds]
anchors = ["ground_truth", "none"]
top = 2
participants = 30

[submissions]
samples = 3
require = ["head"]

[publish]
min_votes = {min_votes}
bootstrap = 500
'''
    path = folder / "season.toml"
    path.write_text(text, encoding="utf-8")
    return path


def write_bvh(track: MotionTrack, path: Path) -> None:
    """The head angles (FAP 48-50) of ``track`` as a BVH skeleton (hips, neck, head), the head
    joint's rotations in ``Zrotation Xrotation Yrotation`` order, degrees, Y up, facing +Z."""
    degrees = np.column_stack([track.get(c) for c in HEAD]) * AU_RADIANS * 180.0 / np.pi
    lines = [
        "HIERARCHY",
        "ROOT Hips",
        "{",
        "  OFFSET 0 90 0",
        "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
        "  JOINT LeftUpLeg",
        "  {",
        "    OFFSET 10 0 0",
        "    CHANNELS 3 Zrotation Xrotation Yrotation",
        "    End Site",
        "    {",
        "      OFFSET 0 -40 0",
        "    }",
        "  }",
        "  JOINT Neck",
        "  {",
        "    OFFSET 0 50 0",
        "    CHANNELS 3 Zrotation Xrotation Yrotation",
        "    JOINT Head",
        "    {",
        "      OFFSET 0 10 0",
        "      CHANNELS 3 Zrotation Xrotation Yrotation",
        "      End Site",
        "      {",
        "        OFFSET 0 15 0",
        "      }",
        "    }",
        "  }",
        "}",
        "MOTION",
        f"Frames: {track.n_frames}",
        f"Frame Time: {1.0 / track.fps:.8f}",
    ]
    for pitch, yaw, roll in degrees:
        lines.append(f"0 90 0 0 0 0 0 0 0 0 0 0 {roll:.5f} {pitch:.5f} {yaw:.5f}")
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def _lagged(truth: MotionTrack, lag_frames: int) -> MotionTrack:
    """The ground truth's head, smoothed and late by ``lag_frames``: a plausible but
    badly timed system."""
    head = truth.select(HEAD)
    kernel = np.ones(7) / 7.0
    values = np.column_stack(
        [np.convolve(np.pad(c, 3, mode="edge"), kernel, mode="valid") for c in head.values.T]
    )
    values = np.vstack([np.repeat(values[:1], lag_frames, axis=0), values])[: truth.n_frames]
    return head.replace(values=values)


def write_systems(benchmark: Path, out: Path) -> dict[str, list[Path]]:
    """Every demo system's files (one folder per system); returns system -> files."""
    from app.stimuli.capture.arkit import write_arkit_csv
    from app.stimuli.generate import generate_conditions

    made: dict[str, list[Path]] = {}
    for system in SYSTEMS:
        folder = out / system.name
        folder.mkdir(parents=True, exist_ok=True)
        files: list[Path] = []
        for name, *_ in SEGMENTS:
            audio, truth_path = benchmark / f"{name}.wav", benchmark / f"{name}_gt.fap"
            truth = load_track(truth_path)
            if system.model == "lagged_truth":
                for k in range(1, system.samples + 1):
                    path = folder / f"{name}_sample{k}.bvh"
                    write_bvh(_lagged(truth, 2 + 2 * k), path)
                    files.append(path)
                continue
            result = generate_conditions(
                audio,
                conditions={system.name: {"model": system.model}},
                ground_truth=truth,
                seed=7,
                eyes="own" if system.model == "live_gmm" else "still",
            )
            track = result.tracks[system.name]
            if system.fmt == "arkit":
                path = folder / f"{name}.csv"
                write_arkit_csv(track, path)
            else:
                path = folder / f"{name}.{system.fmt}"
                save_track(track, path)
            files.append(path)
        made[system.name] = files
    return made
