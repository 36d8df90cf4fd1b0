"""A mesh or FLAME sequence as a condition's track: the files, read once, and the track.

A condition (or a clip's ground truth) may be a vertex sequence (``.npy``/``.npz`` and a
template beside it, :mod:`app.stimuli.meshes.vertexfile`), a FLAME parameter sequence
(:mod:`app.stimuli.meshes.flameparams`, with the user's own FLAME model) or a mesh bundle.
:func:`mesh_track` reads it into a :class:`~app.stimuli.track.MotionTrack` whose channels are
what the study shares and tests like every face's (the head's turn, FAPs 48-50; a FLAME
sequence's gaze, 23-26) and whose ``metadata["mesh"]`` says where the vertices are (a JSON-able
:data:`MeshSpec`); :func:`mesh_of` gives the :class:`~app.stimuli.meshes.sequence.MeshSequence`
back (read once per file version).

The template is looked for beside the vertex file under its name (``face.npy`` with
``face.obj`` or ``face.ply``) unless one is given; the sequence's frame rate must be given
(``fps``, or an ``fps`` number in the ``.npz``), as the files do not say it (FaceFormer writes
VOCASET at 30 fps and BIWI at 25, EMOTE and DiffPoseTalk at 25).

Example
-------
>>> from app.stimuli.meshes.source import is_mesh_path
>>> is_mesh_path("out/face.npy"), is_mesh_path("out/face.fap")
(True, False)
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.stimuli.meshes import flame as flame_model
from app.stimuli.meshes.flameparams import (
    file_fps,
    is_flame_mapping,
    params_from_arrays,
    read_param_mapping,
)
from app.stimuli.meshes.meshfile import MESH_SUFFIXES, read_mesh
from app.stimuli.meshes.regions import Regions, find_eyeballs, read_regions
from app.stimuli.meshes.sequence import (
    MeshSequence,
    gaze_channels,
    head_channels,
    read_bundle,
    stabilise,
    write_bundle,
)
from app.stimuli.meshes.vertexfile import (
    UNITS,
    detect_units,
    load_array,
    read_pose_array,
    read_vertex_array,
)
from app.stimuli.track import MotionTrack

#: Suffixes of the files a mesh or FLAME condition is given as.
MESH_TRACK_SUFFIXES: tuple[str, ...] = (".npy", ".npz", ".pkl")
#: A generated condition's mesh bundle beside its track: ``<name>.mesh.npz``.
BUNDLE_SUFFIX = ".mesh.npz"
#: What ``metadata["mesh"]`` holds: file paths (absolute), the options, the label.
MeshSpec = dict[str, Any]


@dataclass(frozen=True)
class MeshOptions:
    """How to read a mesh or FLAME sequence: ``template`` (else the one beside the file),
    ``fps`` (the sequence's frame rate), ``units`` (``auto`` or one of
    :data:`~app.stimuli.meshes.vertexfile.UNITS`), ``regions`` (a region file or folder,
    :mod:`app.stimuli.meshes.regions`), ``pose`` (a head pose per frame, else ``<stem>.pose.npy``
    beside the file if there is one), ``flame_model`` (else ``FACEPAIR_FLAME_MODEL``)."""

    template: str | None = None
    fps: float | None = None
    units: str = "auto"
    regions: str | None = None
    pose: str | None = None
    flame_model: str | None = None

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, base: Path | None = None) -> MeshOptions:
        """Options from a study file's ``[meshes]`` table or a condition's ``mesh`` table
        (paths relative to ``base``); unknown keys are left to the study-file reader."""
        data = dict(data or {})
        paths = {}
        for key in ("template", "regions", "pose", "flame_model"):
            if data.get(key):
                p = Path(str(data[key])).expanduser()
                paths[key] = str(p if p.is_absolute() or base is None else base / p)
        fps = data.get("fps")
        return cls(
            template=paths.get("template"),
            fps=float(fps) if fps is not None else None,
            units=str(data.get("units", "auto")),
            regions=paths.get("regions"),
            pose=paths.get("pose"),
            flame_model=paths.get("flame_model"),
        )


def is_mesh_path(path: str | Path) -> bool:
    """Whether ``path`` names a mesh, FLAME or bundle file by its suffix."""
    return Path(path).suffix.lower() in MESH_TRACK_SUFFIXES


def template_beside(path: Path) -> Path | None:
    """The template under ``path``'s name: ``face.npy`` -> ``face.obj`` or ``face.ply``."""
    for suffix in MESH_SUFFIXES:
        for candidate in (path.with_suffix(suffix), path.with_suffix(suffix.upper())):
            if candidate.is_file():
                return candidate
    return None


def _stamp(path: str | None) -> tuple[int, int] | None:
    if not path:
        return None
    try:
        st = Path(path).stat()
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


def spec_for(path: str | Path, options: MeshOptions) -> MeshSpec:
    """The :data:`MeshSpec` of a mesh or FLAME file read with ``options``."""
    p = Path(path).resolve()
    if p.name.endswith(BUNDLE_SUFFIX):
        return {"bundle": str(p), "label": p.name}
    spec: MeshSpec = {"file": str(p), "label": p.name, **asdict(options)}
    pose = options.pose or (
        str(p.with_suffix(".pose.npy")) if p.with_suffix(".pose.npy").is_file() else None
    )
    spec["pose"] = pose
    if options.flame_model is None:
        import os

        spec["flame_model"] = os.environ.get(flame_model.MODEL_VARIABLE) or None
    return spec


def mesh_of(track: MotionTrack) -> MeshSequence | None:
    """The mesh sequence of a mesh condition's track, None for a track of FAPs."""
    spec = track.metadata.get("mesh")
    if not isinstance(spec, Mapping):
        return None
    return load_spec(spec)


def load_spec(spec: Mapping[str, Any]) -> MeshSequence:
    """The mesh sequence a :data:`MeshSpec` names (read once per version of its files)."""
    key = json.dumps(dict(spec), sort_keys=True, default=str)
    files = [spec.get(k) for k in ("bundle", "file", "template", "regions", "pose", "flame_model")]
    return _load(key, tuple(_stamp(f) for f in files))[0]


def head_motion(spec: Mapping[str, Any]) -> dict[int, np.ndarray]:
    """The head (and gaze) channels of a spec's sequence, at its own frame rate."""
    key = json.dumps(dict(spec), sort_keys=True, default=str)
    files = [spec.get(k) for k in ("bundle", "file", "template", "regions", "pose", "flame_model")]
    return _load(key, tuple(_stamp(f) for f in files))[1]


@functools.lru_cache(maxsize=4)
def _load(key: str, _stamps: tuple) -> tuple[MeshSequence, dict[int, np.ndarray]]:
    spec = json.loads(key)
    if spec.get("bundle"):
        return read_bundle(spec["bundle"]), {}
    options = MeshOptions(
        **{k: spec.get(k) for k in ("template", "fps", "regions", "pose", "flame_model")},
        units=spec.get("units") or "auto",
    )
    path = Path(spec["file"])
    label = spec.get("label") or path.name
    suffix = path.suffix.lower()
    if suffix == ".pkl":
        return _flame_sequence(path, label, options, read_param_mapping(path, label))
    if suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                keys = set(z.files)
                if "format" in keys and str(z["format"]).startswith("facepair-mesh"):
                    return read_bundle(path), {}
                flame = is_flame_mapping(dict.fromkeys(keys))
                data = {k: z[k] for k in z.files} if flame else None
        except (OSError, ValueError) as exc:
            raise InputError(f"not a readable .npz ({exc})", path=label) from None
        if data is not None:
            return _flame_sequence(path, label, options, data)
    elif suffix == ".npy" and options.flame_model and _is_unitalker(path):
        return _flame_sequence(path, label, options, read_param_mapping(path, label))
    return _vertex_sequence(path, label, options)


def _is_unitalker(path: Path) -> bool:
    try:
        a = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError):
        return False
    from app.stimuli.meshes.flameparams import UNITALKER_WIDTH

    return a.ndim == 2 and a.shape[1] == UNITALKER_WIDTH


def _rate(options: MeshOptions, found: float | None, label: str) -> float:
    fps = options.fps or found
    if fps is None:
        raise InputError(
            "give the sequence's frame rate (--mesh-fps, or fps in the study file's [meshes]): "
            "the file does not say it (FaceFormer writes VOCASET at 30 fps, BIWI at 25)",
            path=label,
        )
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"the frame rate must be positive, got {fps!r}", path=label)
    return float(fps)


def _regions(options: MeshOptions, n_vertices: int) -> Regions:
    return read_regions(options.regions, n_vertices) if options.regions else Regions()


def _vertex_sequence(
    path: Path, label: str, options: MeshOptions
) -> tuple[MeshSequence, dict[int, np.ndarray]]:
    template_path = Path(options.template) if options.template else template_beside(path)
    if template_path is None:
        raise InputError(
            f"no template mesh: put {path.stem}.obj or {path.stem}.ply beside it, or name one "
            "(--template, or template in the study file)",
            path=label,
        )
    mesh = read_mesh(template_path, template_path.name)
    raw = load_array(path, label)
    found_fps = None
    if path.suffix.lower() == ".npz":
        with np.load(path, allow_pickle=False) as z:
            found_fps = file_fps({k: z[k] for k in z.files if k == "fps"})
    fps = _rate(options, found_fps, label)
    frames = read_vertex_array(raw, n_vertices=len(mesh.vertices), name=label)
    units = detect_units(mesh.vertices, name=template_path.name, declared=options.units)
    scale = UNITS[units]
    template = mesh.vertices * scale
    frames = frames * np.float32(scale)
    regions = _regions(options, len(template))
    eyes = regions.eyeballs or find_eyeballs(template, mesh.triangles)
    notes = [
        f"{label}: {len(frames)} frames of {len(template)} vertices at {fps:g} fps, in {units}"
    ]
    channels: dict[int, np.ndarray] = {}
    if options.pose:
        pose = read_pose_array(load_array(options.pose), len(frames), name=Path(options.pose).name)
        channels = head_channels(pose)
        notes.append(f"{label}: head pose from {Path(options.pose).name}")
    else:
        y = template[:, 1]
        upper = np.flatnonzero(y >= np.quantile(y, 0.6))
        frames, rot = stabilise(template, frames, upper)
        if rot is not None:
            channels = head_channels(rot)
            notes.append(
                f"{label}: the upper head turns in the vertices; taken out as the head's turn "
                "(its travel is left out: facepair's heads turn in place)"
            )
    seq = MeshSequence(
        template=template,
        triangles=mesh.triangles,
        frames=frames,
        fps=fps,
        label=label,
        units=units,
        lips=regions.lips,
        upper=regions.upper,
        eyeballs=eyes,
        kind="vertices",
        notes=notes,
    )
    return seq, channels


def _flame_sequence(
    path: Path, label: str, options: MeshOptions, data: Mapping[str, Any]
) -> tuple[MeshSequence, dict[int, np.ndarray]]:
    try:
        model_file = flame_model.model_path(options.flame_model)
    except InputError as exc:
        raise InputError(exc.message, path=label) from None
    model = _model(str(model_file), _stamp(str(model_file)))
    params = params_from_arrays(data, name=label)
    fps = _rate(options, file_fps(data), label)
    pose = params.pose.copy()
    head = flame_model.rodrigues(pose[:, 0]) @ flame_model.rodrigues(pose[:, 1])
    eyes_rot = flame_model.rodrigues(pose[:, 3]), flame_model.rodrigues(pose[:, 4])
    # the head's turn and the gaze become the track's channels; the vertices keep the jaw
    pose[:, [0, 1, 3, 4]] = 0.0
    shape = params.shape
    rest = flame_model.FlameParams(
        np.zeros((1, 0)), np.zeros((1, 5, 3)), shape if shape.ndim == 1 else shape[:1]
    )
    template = flame_model.flame_vertices(model, rest)[0]
    moving = flame_model.FlameParams(params.expression, pose, shape, None)
    frames = flame_model.flame_vertices(model, moving).astype(np.float32)
    joints = flame_model.rest_joints(model, shape)
    owner = np.argmax(model.weights, axis=1)
    eye_l, eye_r = np.flatnonzero(owner == 3), np.flatnonzero(owner == 4)
    left_first = (
        len(eye_l) and len(eye_r) and template[eye_l, 0].mean() >= template[eye_r, 0].mean()
    )
    eyes = (eye_l, eye_r) if left_first else (eye_r, eye_l)
    channels = head_channels(head)
    if (np.abs(params.pose[:, 3:]) > 0).any():
        gaze_l, gaze_r = (eyes_rot[0], eyes_rot[1]) if left_first else (eyes_rot[1], eyes_rot[0])
        channels.update(gaze_channels(gaze_l, gaze_r))
    regions = _regions(options, model.n_vertices)
    seq = MeshSequence(
        template=template,
        triangles=model.faces,
        frames=frames,
        fps=fps,
        label=label,
        units="m",
        lips=regions.lips,
        upper=regions.upper,
        eyeballs=(regions.eyeballs or eyes) if len(eye_l) and len(eye_r) else regions.eyeballs,
        head_weights=1.0 - model.weights[:, 0],
        pivot=joints[1],
        kind="flame",
        notes=[f"{label}: {params.n_frames} FLAME frames at {fps:g} fps on {model.name}"],
    )
    return seq, channels


@functools.lru_cache(maxsize=2)
def _model(path: str, _stamp: tuple | None) -> flame_model.FlameModel:
    return flame_model.read_flame_model(path)


def mesh_track(
    path: str | Path, options: MeshOptions | None = None, fps: float = 30.0
) -> MotionTrack:
    """The track of a mesh or FLAME sequence at ``fps`` (see the module's docstring): its head
    (and gaze) channels resampled, as long as the sequence, ``metadata["mesh"]`` its spec."""
    p = Path(path)
    if not p.is_file():
        raise InputError("no such file", path=p.name)
    spec = spec_for(p, options or MeshOptions())
    seq = load_spec(spec)
    channels = head_motion(spec)
    own = (
        MotionTrack.from_channels(seq.fps, channels)
        if channels
        else MotionTrack.zeros(seq.fps, seq.n_frames)
    )
    track = own.resample(fps) if fps != seq.fps else own
    return track.replace(
        name=p.stem,
        source=p.name,
        metadata={
            "mesh": spec,
            "file": p.name,
            "mesh_eyes": seq.eyeballs is not None,
            "mesh_notes": list(seq.notes),
        },
    )


def save_bundle_beside(track: MotionTrack, track_path: str | Path) -> Path | None:
    """Write the mesh of ``track`` (a mesh condition's) beside ``track_path`` as a bundle on
    the track's own timeline (:func:`app.stimuli.meshes.sequence.sample` at its frames, with
    the ``offset_s`` its alignment recorded); returns the bundle's path, None for a FAP track
    (and a stale bundle there is removed)."""
    from app.stimuli.meshes.sequence import sample

    target = Path(track_path).with_suffix(BUNDLE_SUFFIX)
    seq = mesh_of(track)
    if seq is None:
        target.unlink(missing_ok=True)
        return None
    offset = float(track.metadata.get("offset_s", 0.0) or 0.0)
    timed = MeshSequence(
        template=seq.template,
        triangles=seq.triangles,
        frames=sample(seq, track.n_frames, track.fps, offset),
        fps=track.fps,
        label=seq.label,
        units=seq.units,
        lips=seq.lips,
        upper=seq.upper,
        eyeballs=seq.eyeballs,
        head_weights=seq.head_weights,
        pivot=seq.pivot,
        kind=seq.kind,
    )
    return write_bundle(timed, target)
