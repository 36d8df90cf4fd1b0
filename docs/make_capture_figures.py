"""The marker capture's closed loop at full size, its error table and the README figures.

    python docs/make_capture_figures.py

Renders the built-in head in the marker look at 368 px (sensor noise 2 grey levels, lens blur
0.6 px) as H.264 clips: a calibration clip (neutral face nodding to +/-17 degrees, then
turning to +/-8, 8 s) and a test clip of known motion (renderer.markers.known_motion, 8 s).
Captures both from the files, calibrates kp, ky and the eyebrows' pitch coupling on the
first, and prints the RMS recovery error per channel on the second: with the thesis'
constants, with the calibrated ones, with the calibrated ones and the thesis' Gaussian
squashing, and with binary centres of gravity. Writes docs/img/marker-look.png (a frame of
the test clip) and docs/img/marker-recovery.png (true and recovered tracks).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from app.stimuli.capture.calibration import calibrate
from app.stimuli.capture.marker_faps import MarkerConstants
from app.stimuli.capture.markers import label_frames, tracks_to_faps
from app.stimuli.capture.video import read_grey_frames
from renderer.headmodel import builtin_face
from renderer.markers import MarkerLook, calibration_motion, known_motion, write_marker_clip

OUT = Path(__file__).resolve().parent / "img"
SIZE, SECONDS = 368, 8.0
LOOK = MarkerLook(noise=2.0)


def main() -> None:
    face = builtin_face()
    base = MarkerConstants(squash=False, fapu_mm={k: face.fapu[k] for k in ("ENS0", "MNS0", "MW0")})
    known, truth = calibration_motion(seconds=SECONDS), known_motion(seconds=SECONDS)
    with tempfile.TemporaryDirectory() as tmp:
        cal_clip = write_marker_clip(known, Path(tmp) / "cal.mp4", SIZE, look=replace(LOOK, seed=1))
        test_clip = write_marker_clip(
            truth, Path(tmp) / "test.mp4", SIZE, look=replace(LOOK, seed=2)
        )
        calibrated = calibrate(label_frames(read_grey_frames(cal_clip)), known, base)
        start = time.perf_counter()
        tracks = label_frames(read_grey_frames(test_clip))
        seconds = time.perf_counter() - start
        binary = label_frames(read_grey_frames(test_clip), weights="binary")
        frames = [g for _, g in read_grey_frames(test_clip)]
    print(
        f"capture: {len(tracks.times) / seconds:.0f} frames/s at {SIZE} px (decode, segment, label)"
    )
    print(
        f"calibrated: kp {calibrated.kp:.4f} (thesis 0.15), ky {calibrated.ky:.4f} "
        f"(thesis 0.05), eyebrow pitch coupling {calibrated.brow_pitch_inner:.0f} / "
        f"{calibrated.brow_pitch_middle:.0f} ENS units per radian"
    )
    runs = {
        "thesis constants": (tracks, base),
        "calibrated": (tracks, calibrated),
        "calibrated + squashing": (tracks, replace(calibrated, squash=True)),
        "calibrated, binary centres": (binary, calibrated),
    }
    header = "| channel | " + " | ".join(runs) + " |"
    print(header + "\n|" + "---|" * (len(runs) + 1))
    recovered = {}
    for name, (t, c) in runs.items():
        recovered[name] = tracks_to_faps(t, constants=c)
    for fap, label, scale in (
        (48, "pitch (deg)", np.degrees(1e-5)),
        (49, "yaw (deg)", np.degrees(1e-5)),
        (50, "roll (deg)", np.degrees(1e-5)),
        (31, "inner brows 31/32 (ENS)", 1.0),
        (33, "middle brows 33/34 (ENS)", 1.0),
    ):
        cells = [
            f"{scale * np.sqrt(np.mean((r[fap] - truth[fap]) ** 2)):.2f}"
            for r in recovered.values()
        ]
        print(f"| {label} | " + " | ".join(cells) + " |")
    figures(frames, truth, recovered["calibrated"], recovered["thesis constants"])


def figures(frames, truth, rec, thesis) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    k = int(np.argmax(truth[31] + np.abs(truth[48]) * 1e-3))
    Image.fromarray(frames[k]).save(OUT / "marker-look.png")
    fig, axes = plt.subplots(2, 1, figsize=(6.4, 4.8), sharex=True)
    t = truth.times
    for fap, name in ((48, "pitch"), (49, "yaw"), (50, "roll")):
        (line,) = axes[0].plot(t, np.degrees(truth[fap] * 1e-5), lw=2.5, alpha=0.35)
        axes[0].plot(t, np.degrees(rec[fap] * 1e-5), lw=1, color=line.get_color(), label=name)
    axes[0].plot(
        t, np.degrees(thesis[48] * 1e-5), lw=1, ls=":", color="C0", label="pitch, thesis kp"
    )
    axes[0].set_ylabel("degrees")
    for fap, name in ((31, "inner brows"), (33, "middle brows")):
        (line,) = axes[1].plot(t, truth[fap], lw=2.5, alpha=0.35)
        axes[1].plot(t, rec[fap], lw=1, color=line.get_color(), label=name)
    axes[1].set_ylabel("ENS units")
    axes[1].set_xlabel("seconds (wide: true, thin: recovered)")
    for ax in axes:
        ax.axvline(k / truth.fps, color="0.6", lw=0.8)
        ax.legend(fontsize=7, ncol=4, loc="lower left")
    fig.tight_layout()
    fig.savefig(OUT / "marker-recovery.png", dpi=80)


if __name__ == "__main__":
    main()
