"""Tracker files in each tool's exact layout, and marker videos, with known motion, for tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

AU_REG = (
    "AU01",
    "AU02",
    "AU04",
    "AU05",
    "AU06",
    "AU07",
    "AU09",
    "AU10",
    "AU12",
    "AU14",
    "AU15",
    "AU17",
    "AU20",
    "AU23",
    "AU25",
    "AU26",
    "AU45",
)
AU_CLASS = AU_REG[:-1] + ("AU28", "AU45")


def openface_header(eye_landmarks: int = 56) -> list[str]:
    """OpenFace 2.x RecorderCSV header for FeatureExtraction -pose -gaze -aus."""
    names = [
        "frame",
        "face_id",
        "timestamp",
        "confidence",
        "success",
        "gaze_0_x",
        "gaze_0_y",
        "gaze_0_z",
        "gaze_1_x",
        "gaze_1_y",
        "gaze_1_z",
        "gaze_angle_x",
        "gaze_angle_y",
    ]
    for axis in ("x", "y", "X", "Y", "Z"):
        names += [f"eye_lmk_{axis}_{i}" for i in range(eye_landmarks)]
    names += ["pose_Tx", "pose_Ty", "pose_Tz", "pose_Rx", "pose_Ry", "pose_Rz"]
    names += [f"{au}_r" for au in AU_REG] + [f"{au}_c" for au in AU_CLASS]
    return names


def write_openface(
    path: Path,
    times: np.ndarray,
    values: dict[str, np.ndarray],
    *,
    success: np.ndarray | None = None,
    confidence: np.ndarray | None = None,
    eye_landmarks: int = 56,
) -> Path:
    """One row per entry of ``times``; columns in ``values`` take those numbers, others 0.
    Numbers are printed with OpenFace's precisions, separated by ", "."""
    header = openface_header(eye_landmarks)
    n = len(times)
    success = np.ones(n, int) if success is None else success
    confidence = np.full(n, 0.98) if confidence is None else confidence
    lines = [", ".join(header)]
    for k in range(n):
        row = [f"{k + 1}", "0", f"{times[k]:.3f}", f"{confidence[k]:.2f}", f"{success[k]:d}"]
        for name in header[5:]:
            v = float(values[name][k]) if name in values else 0.0
            if name.startswith(("gaze_0", "gaze_1")):
                row.append(f"{v:.6f}")
            elif name.startswith(("gaze_angle", "pose_R")):
                row.append(f"{v:.3f}")
            elif name.endswith("_r"):
                row.append(f"{v:.2f}")
            else:
                row.append(f"{v:.1f}")
        lines.append(", ".join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


def write_live_link(
    path: Path,
    n: int,
    values: dict[str, np.ndarray],
    *,
    app_fps: int = 60,
    drop: tuple[int, ...] = (),
) -> Path:
    """A Live Link Face export: Timecode HH:MM:SS:FF.sss at ``app_fps``, BlendShapeCount 61,
    the 52 blendshapes and 9 rotations with 8 decimals; frames in ``drop`` missing."""
    from app.stimuli.capture.arkit import HEADER

    lines = [",".join(HEADER)]
    start = 14 * 3600 + 3 * 60 + 52  # takes carry the time of day
    for k in range(n):
        if k in drop:
            continue
        secs, ff = divmod(k, app_fps)
        s = start + secs
        stamp = f"{s // 3600:02d}:{s // 60 % 60:02d}:{s % 60:02d}:{ff:02d}.{(k * 7) % 1000:03d}"
        row = [stamp, "61"] + [
            f"{float(values[h][k]) if h in values else 0.0:.8f}" for h in HEADER[2:]
        ]
        lines.append(",".join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


def drop_video_frames(src, dst, frames):
    """Re-encode the video ``src`` without ``frames``, keeping every other frame's time stamp
    (a capture card that dropped them)."""
    import subprocess

    import imageio_ffmpeg

    keep = "*".join(f"not(eq(n\\,{k}))" for k in frames)
    subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(),
            "-y",
            "-loglevel",
            "error",
            "-i",
            str(src),
            "-vf",
            f"select='{keep}'",
            "-fps_mode",
            "passthrough",
            "-c:v",
            "libx264",
            "-crf",
            "12",
            "-pix_fmt",
            "yuv420p",
            str(dst),
        ],
        check=True,
    )
    return dst


def write_a2f3d_csv(path: Path, times: np.ndarray, values: dict[str, np.ndarray]) -> Path:
    """Audio2Face-3D's ``animation_frames.csv`` as its sample client writes it: one record
    ``{"timeCode": t, "blendShapes": {name: weight}}`` a frame, ``pandas.json_normalize``,
    ``to_csv`` with pandas' index (NVIDIA/Audio2Face-3D-Samples, a2f_3d/client/service.py).
    Names are the 52 ARKit blendshapes in Live Link Face's spelling."""
    import pandas

    from app.stimuli.capture.arkit import BLENDSHAPES

    frames = [
        {
            "timeCode": float(t),
            "blendShapes": {n: float(values[n][k]) if n in values else 0.0 for n in BLENDSHAPES},
        }
        for k, t in enumerate(times)
    ]
    pandas.json_normalize(frames).to_csv(path)
    return path


def write_a2f_json(
    path: Path, fps: float, values: dict[str, np.ndarray], n: int, names=None
) -> Path:
    """Audio2Face's blendshape-weights JSON ("Export blendshape weights as .json"; the layout
    OpenFaceFX's export_a2f writes too): camelCase ARKit names in ``facsNames``."""
    import json

    from app.stimuli.capture.arkit import BLENDSHAPES

    names = names or [b[0].lower() + b[1:] for b in BLENDSHAPES]
    pascal = {b.lower(): b for b in BLENDSHAPES}
    rows = [
        [
            float(values[pascal.get(m.lower(), m)][k])
            if pascal.get(m.lower(), m) in values
            else 0.0
            for m in names
        ]
        for k in range(n)
    ]
    doc = {
        "exportFps": fps,
        "trackPath": "C:/takes/speech.wav",
        "numPoses": len(names),
        "numFrames": n,
        "facsNames": names,
        "weightMat": rows,
    }
    path.write_text(json.dumps(doc, indent=2))
    return path


#: A GENEA-style skeleton (the joint names of the GENEA 2022/2023 data, from Talking With
#: Hands): name, parent, offset in cm, channels.
GENEA_JOINTS = (
    ("Hips", None, (0.0, 95.0, 0.0), "Xposition Yposition Zposition Zrotation Yrotation Xrotation"),
    ("Spine", "Hips", (0.0, 8.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("Spine1", "Spine", (0.0, 10.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("Spine2", "Spine1", (0.0, 10.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("Spine3", "Spine2", (0.0, 10.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("Neck", "Spine3", (0.0, 12.0, 1.0), "Zrotation Yrotation Xrotation"),
    ("Neck1", "Neck", (0.0, 5.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("Head", "Neck1", (0.0, 5.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("LeftShoulder", "Spine3", (4.0, 10.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("LeftArm", "LeftShoulder", (14.0, 0.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("RightShoulder", "Spine3", (-4.0, 10.0, 0.0), "Zrotation Yrotation Xrotation"),
    ("RightArm", "RightShoulder", (-14.0, 0.0, 0.0), "Zrotation Yrotation Xrotation"),
)


def write_bvh(
    path: Path,
    motion: dict[str, np.ndarray],
    n: int,
    *,
    fps: float = 30.0,
    joints=GENEA_JOINTS,
    mirror_x: bool = False,
) -> Path:
    """A BVH file: ``motion`` maps ``"Joint.Xrotation"`` (degrees) or ``"Joint.Xposition"``
    to per-frame values, other channels 0. ``mirror_x`` puts the skeleton's left on -X (a
    skeleton facing -Z)."""
    children: dict[str | None, list] = {}
    for joint in joints:
        children.setdefault(joint[1], []).append(joint)
    lines = ["HIERARCHY"]
    order: list[tuple[str, list[str]]] = []

    def emit(joint, depth):
        name, parent, offset, channels = joint
        pad = "\t" * depth
        x = -offset[0] if mirror_x else offset[0]
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {name}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {x:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        names = channels.split()
        lines.append(f"{pad}\tCHANNELS {len(names)} {' '.join(names)}")
        order.append((name, names))
        kids = children.get(name, [])
        for kid in kids:
            emit(kid, depth + 1)
        if not kids:
            lines.append(f"{pad}\tEnd Site")
            lines.append(f"{pad}\t{{")
            lines.append(f"{pad}\t\tOFFSET 0.000000 {8.0 if name == 'Head' else 2.0:.6f} 0.000000")
            lines.append(f"{pad}\t}}")
        lines.append(f"{pad}}}")

    emit(children[None][0], 0)
    lines += ["MOTION", f"Frames: {n}", f"Frame Time: {1.0 / fps:.7f}"]
    for k in range(n):
        row = []
        for name, names in order:
            for c in names:
                value = motion.get(f"{name}.{c}")
                row.append(f"{float(value[k]) if value is not None else 0.0:.6f}")
        lines.append(" ".join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


def write_openfacefx(path: Path, fps: float, keys: dict[str, list[tuple[float, float]]]) -> Path:
    """An OpenFaceFX track as its ``io_export`` writes it: ``to_dict`` for ``.json`` (format
    ``openfacefx.track`` version 1, keys ``[time, value]`` rounded to 4 decimals), ``write_csv``
    (``time,channel,value``, one row per key) otherwise."""
    import json

    if path.suffix == ".json":
        doc = {
            "format": "openfacefx.track",
            "version": 1,
            "fps": fps,
            "duration": round(max(t for k in keys.values() for t, _ in k), 4),
            "viseme_set": list(keys),
            "channels": [
                {"name": n, "keys": [[round(t, 4), v] for t, v in k]} for n, k in keys.items()
            ],
        }
        path.write_text(json.dumps(doc, indent=2))
    else:
        rows = ["time,channel,value"]
        rows += [f"{t:.4f},{n},{v:.4f}" for n, k in keys.items() for t, v in k]
        path.write_text("\n".join(rows) + "\n")
    return path
