"""Where a mesh's lips, upper face and eyeballs are: from a region file, else from the mesh.

The field's metrics and the mouth mosaic need the lips; FDD needs the upper face. The projects
use fixed vertex lists: CodeTalker's BIWI ``regions/lve.txt`` and ``regions/fdd.txt`` (comma-
separated indices: Doubiiu/CodeTalker ``main/cal_metric.py``), FLAME's ``FLAME_masks.pkl``
(a dict of index arrays: ``lips``, ``forehead``, ``eye_region``, ``left_eyeball``, ...; part of
FLAME, licence-gated), UniTalker's ``*_mouth_idx.npy``. :func:`read_regions` reads any of them:

* a folder with ``lve.txt`` (lips) and ``fdd.txt`` (upper face), CodeTalker's layout;
* a mapping (``.json``, ``.npz`` or a data ``.pkl``): lips under ``lips``, ``lve`` or ``mouth``;
  the upper face under ``upper``, ``fdd`` or ``upper_face``, else FLAME's ``forehead`` and
  ``eye_region`` together; eyeballs under ``left_eyeball`` and ``right_eyeball``;
* a list (``.txt`` of integers separated by commas or white space, ``.npy``, a ``.json`` list):
  the lips.

Without a region file (:func:`find_lips`) the lips are found from the motion correlated with
the speech's energy, bounded by the head's size; the upper face is what lies above the middle of
the nose (:func:`upper_face_band`); eyeballs are two mirrored small closed parts of the mesh
(:func:`find_eyeballs`). All sizes are fractions of the head's width W (the template's x
extent): an adult's mouth is about 0.33 W wide (0.8 of the pupil distance, which is about 0.41 W:
Farkas, Anthropometry of the Head and Face, 1994), the eyes about 0.45 W above the mouth.

Example
-------
>>> import io
>>> parse_index_text("1, 2, 3\\n7", "lve.txt").tolist()
[1, 2, 3, 7]
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError

#: Fractions of the head's width W (see the module's docstring).
EYE_SPACING_W = 0.41
EYES_ABOVE_MOUTH_W = 0.45
HALF_MOUTH_W = 0.165
_LIP_KEYS = ("lips", "lve", "mouth")
_UPPER_KEYS = ("upper", "fdd", "upper_face")


@dataclass(frozen=True)
class Regions:
    """Vertex indices: ``lips`` and ``upper`` (either may be None: not given), ``eyeballs``
    (left, right: the face's own sides) or None."""

    lips: np.ndarray | None = None
    upper: np.ndarray | None = None
    eyeballs: tuple[np.ndarray, np.ndarray] | None = None


def parse_index_text(text: str, name: str) -> np.ndarray:
    """Integers separated by commas or white space (CodeTalker's ``lve.txt``)."""
    tokens = [t for t in re.split(r"[\s,;\[\]]+", text) if t]
    try:
        return np.array([int(t) for t in tokens], dtype=np.int64)
    except ValueError:
        raise InputError("expected vertex indices separated by commas", path=name) from None


def _indices(value: Any, n_vertices: int, name: str, what: str) -> np.ndarray:
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected vertex indices", path=name) from None
    if a.dtype == bool and a.ndim == 1 and len(a) == n_vertices:
        a = np.flatnonzero(a)
    if a.ndim != 1 or (len(a) and a.dtype.kind not in "iu" and not np.all(a == np.round(a))):
        raise InputError(f"{what}: expected a list of vertex indices", path=name)
    a = a.astype(np.int64)
    if not len(a):
        raise InputError(f"{what}: no vertex", path=name)
    if a.min() < 0 or a.max() >= n_vertices:
        raise InputError(
            f"{what}: vertex {int(a.max() if a.max() >= n_vertices else a.min())} is not among "
            f"the mesh's {n_vertices}",
            path=name,
        )
    return np.unique(a)


def _mapping(path: Path) -> Mapping[str, Any] | list | np.ndarray:
    suffix = path.suffix.lower()
    if suffix == ".json":
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"not valid JSON: {exc}", path=path.name) from None
    if suffix in (".npz", ".npy"):
        try:
            loaded = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise InputError(f"not a readable numpy file ({exc})", path=path.name) from None
        if isinstance(loaded, np.ndarray):
            return loaded
        with loaded:
            return {k: loaded[k] for k in loaded.files}
    if suffix == ".pkl":
        from app.stimuli.meshes.pickles import load_data_pickle

        return load_data_pickle(path, path.name)
    return parse_index_text(path.read_text(encoding="latin-1"), path.name)


def read_regions(path: str | Path, n_vertices: int) -> Regions:
    """The regions of a region file or folder (see the module's docstring)."""
    p = Path(path)
    if p.is_dir():
        found = {k: p / f"{k}.txt" for k in ("lve", "fdd")}
        if not any(f.is_file() for f in found.values()):
            raise InputError("a region folder needs lve.txt (lips) or fdd.txt", path=p)
        read = {
            k: _indices(parse_index_text(f.read_text("latin-1"), f.name), n_vertices, f.name, k)
            for k, f in found.items()
            if f.is_file()
        }
        return Regions(read.get("lve"), read.get("fdd"))
    if not p.is_file():
        raise InputError("no such region file", path=p)
    data = _mapping(p)
    if not isinstance(data, Mapping):
        return Regions(_indices(data, n_vertices, p.name, "lips"))
    lips_key = next((k for k in _LIP_KEYS if k in data), None)
    upper_key = next((k for k in _UPPER_KEYS if k in data), None)
    lips = _indices(data[lips_key], n_vertices, p.name, lips_key) if lips_key else None
    upper = None
    if upper_key:
        upper = _indices(data[upper_key], n_vertices, p.name, upper_key)
    elif "forehead" in data and "eye_region" in data:  # FLAME_masks.pkl
        upper = np.union1d(
            _indices(data["forehead"], n_vertices, p.name, "forehead"),
            _indices(data["eye_region"], n_vertices, p.name, "eye_region"),
        )
    eyes = None
    if "left_eyeball" in data and "right_eyeball" in data:
        eyes = (
            _indices(data["left_eyeball"], n_vertices, p.name, "left_eyeball"),
            _indices(data["right_eyeball"], n_vertices, p.name, "right_eyeball"),
        )
    if lips is None and upper is None:
        raise InputError(
            f"no lips ({', '.join(_LIP_KEYS)}) or upper face ({', '.join(_UPPER_KEYS)}, or "
            "forehead and eye_region) among the keys",
            path=p.name,
        )
    return Regions(lips, upper, eyes)


def find_eyeballs(
    vertices: np.ndarray, triangles: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Two eyeballs: the two largest mirrored parts of the mesh (connected components) that are
    small (at most a quarter of the vertices and a third of the head's width across) and round
    (extents within a factor of two), at one height and 0.2 to 0.6 W apart; (left, right) with
    the face's own left at +x; None where the mesh has none (BIWI's scans)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v = np.asarray(vertices, dtype=np.float64)
    n = len(v)
    t = np.asarray(triangles)
    rows = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    cols = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    width = float(np.ptp(v[:, 0])) or 1.0
    used = np.zeros(n, bool)
    used[t.ravel()] = True
    parts = []
    for label in np.unique(labels[used]):
        idx = np.flatnonzero(labels == label)
        if not 8 <= len(idx) <= n // 4:
            continue
        ext = np.ptp(v[idx], axis=0)
        if ext.max() > width / 3 or ext.min() <= 0 or ext.max() / ext.min() > 2.0:
            continue
        parts.append((idx, (v[idx].min(axis=0) + v[idx].max(axis=0)) / 2.0))
    best = None
    for i, (a, ca) in enumerate(parts):
        for b, cb in parts[i + 1 :]:
            apart = abs(ca[0] - cb[0])
            if not 0.2 * width <= apart <= 0.6 * width or abs(ca[1] - cb[1]) > 0.1 * apart:
                continue
            if max(len(a), len(b)) > 1.5 * min(len(a), len(b)):
                continue
            if best is None or len(a) + len(b) > len(best[0]) + len(best[1]):
                best = (a, b) if ca[0] > cb[0] else (b, a)
    return best


@dataclass(frozen=True)
class MouthPoints:
    """The mouth found on a mesh: the upper and lower lip's middles and the corners (vertex
    indices), the lip vertices, and the midline's x."""

    upper: int
    lower: int
    corners: tuple[int, int]  # (left, right)
    lips: np.ndarray
    midline: float


def speech_driven_motion(
    template: np.ndarray, frames: np.ndarray, energy: np.ndarray | None
) -> np.ndarray:
    """Per vertex, how much of its motion follows the speech: the standard deviation over
    frames of its distance from the template, times its correlation with the speech's energy
    (0 where negative); without ``energy``, the standard deviation alone."""
    m = np.linalg.norm(frames.astype(np.float64) - template, axis=2)  # (T, V)
    sd = m.std(axis=0)
    if energy is None or len(energy) != len(m) or np.std(energy) == 0 or len(m) < 3:
        return sd
    e = (energy - energy.mean()) / energy.std()
    mc = m - m.mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = (e @ mc) / (len(e) * np.where(sd > 0, sd, np.inf))
    return sd * np.clip(np.nan_to_num(r), 0.0, 1.0)


def find_lips(
    template: np.ndarray,
    frames: np.ndarray,
    energy: np.ndarray | None = None,
    *,
    exclude: np.ndarray | None = None,
    name: str = "the mesh",
) -> MouthPoints:
    """The mouth of a mesh from its motion (see the module's docstring).

    The lower lip's middle is the highest of the most speech-driven vertices (at least half the
    largest score) near the midline, among the front-most of them (the jaw moves the chin as
    much, below it); the upper lip's the nearest vertex above it, not behind it, that moves
    less than 0.6 as much; the corners half a mouth's width to either side. The lip vertices
    are those within the ellipse the corners and 0.07 W above and below the lips' middle span,
    not behind the corners.
    """
    v = np.asarray(template, dtype=np.float64)
    width = float(np.ptp(v[:, 0]))
    score = speech_driven_motion(v, frames, energy)
    if exclude is not None and len(exclude):
        score[exclude] = 0.0
    top = float(score.max(initial=0.0))
    if top <= 0.0:
        raise InputError(
            "no vertex moves, so the lips cannot be found: give a region file naming them",
            path=name,
        )
    core = score >= 0.5 * top
    midline = float(np.median(v[core, 0]))
    near = np.abs(v[:, 0] - midline) < 0.05 * width
    central = core & near
    if not central.any():
        central = core
    front = central & (v[:, 2] > v[central, 2].max() - 0.1 * width)
    lower = int(np.flatnonzero(front)[np.argmax(v[front, 1])])
    above = (
        near
        & (v[:, 1] >= v[lower, 1])
        & (v[:, 1] < v[lower, 1] + 0.12 * width)
        & (v[:, 2] > v[lower, 2] - 0.04 * width)
        & (score < 0.6 * score[lower])
    )
    if above.any():
        idx = np.flatnonzero(above)
        upper = int(idx[np.argmin(np.linalg.norm(v[idx] - v[lower], axis=1))])
    else:
        upper = _nearest(v, v[lower] + [0.0, 0.02 * width, 0.0])
    centre = (v[upper] + v[lower]) / 2.0
    centre[0] = midline
    half = HALF_MOUTH_W * width
    corners = (
        _nearest(v, centre + [half, 0.0, -0.06 * width]),
        _nearest(v, centre + [-half, 0.0, -0.06 * width]),
    )
    inside = ((v[:, 0] - midline) / (1.15 * half)) ** 2 + (
        (v[:, 1] - centre[1]) / (0.07 * width)
    ) ** 2
    lips = np.flatnonzero((inside <= 1.0) & (v[:, 2] >= centre[2] - 0.08 * width))
    lips = np.union1d(lips, [upper, lower, *corners])
    return MouthPoints(upper, lower, corners, lips, midline)


def mouth_points_of(template: np.ndarray, lips: np.ndarray) -> MouthPoints:
    """The mouth's points from given lip vertices: the middles are the lip vertices nearest
    the midline at the top and bottom of the lips' middle third, the corners the outermost."""
    v = np.asarray(template, dtype=np.float64)[lips]
    midline = float((v[:, 0].min() + v[:, 0].max()) / 2.0)
    span = float(np.ptp(v[:, 0])) or 1.0
    middle = np.abs(v[:, 0] - midline) <= span / 6.0
    mid_idx = np.flatnonzero(middle) if middle.any() else np.arange(len(v))
    order = mid_idx[np.argsort(v[mid_idx, 1])]
    # the mouth's line: where the lips' middle third is thinnest in z-weighted height
    upper, lower = int(order[-1]), int(order[0])
    centre_y = float(np.median(v[mid_idx, 1]))
    above = mid_idx[v[mid_idx, 1] >= centre_y]
    below = mid_idx[v[mid_idx, 1] < centre_y]
    if len(above) and len(below):
        upper = int(above[np.argmin(v[above, 1])])
        lower = int(below[np.argmax(v[below, 1])])
    left, right = int(np.argmax(v[:, 0])), int(np.argmin(v[:, 0]))
    return MouthPoints(
        int(lips[upper]), int(lips[lower]), (int(lips[left]), int(lips[right])), lips, midline
    )


def upper_face_band(template: np.ndarray, mouth: MouthPoints) -> np.ndarray:
    """The vertices above the middle of the nose (0.33 W above the mouth): the eyes, lids,
    brows and forehead, for FDD where no region file names the upper face."""
    v = np.asarray(template, dtype=np.float64)
    width = float(np.ptp(v[:, 0]))
    mouth_y = (v[mouth.upper, 1] + v[mouth.lower, 1]) / 2.0
    return np.flatnonzero(v[:, 1] > mouth_y + 0.33 * width)


def speech_energy(audio_path: str | Path, fps: float, n_frames: int) -> np.ndarray:
    """The speech's RMS energy (dB) in each video frame of ``fps`` (``n_frames`` of them), for
    :func:`find_lips`."""
    from app.stimuli.audiofile import read_audio
    from app.stimuli.speechaudio import MAX_DURATION_S

    audio = read_audio(audio_path, max_duration=MAX_DURATION_S)
    x = np.asarray(audio.samples, dtype=np.float64)
    if x.ndim > 1:
        x = x.mean(axis=1)
    hop = audio.sample_rate / fps
    edges = np.minimum((np.arange(n_frames + 1) * hop).astype(np.int64), len(x))
    power = np.concatenate([[0.0], np.cumsum(x * x)])
    count = np.diff(edges)
    mean = (power[edges[1:]] - power[edges[:-1]]) / np.maximum(count, 1)
    return np.where(count > 0, 10.0 * np.log10(mean + 1e-12), -120.0)


def _nearest(v: np.ndarray, point: np.ndarray) -> int:
    return int(np.argmin(np.linalg.norm(v - point, axis=1)))
