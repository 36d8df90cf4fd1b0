"""Motion tracks as CSV: a ``frame`` column and one column per FAP (``fap48_head_pitch``).

An optional first line ``# fps=30`` (with ``name=``, ``source=``, ``speaker=`` fields separated
by ``;``) carries the frame rate; without it the caller gives ``fps``. Values are written with
Python's shortest round-trip float repr, so a write-read round trip is exact. The FAP
column names come from :mod:`app.stimuli.fap`.

Example
-------
>>> import io, numpy as np
>>> from app.stimuli.track import MotionTrack
>>> t = MotionTrack.from_channels(30, {49: np.array([0.5, -1.25])}, name="demo")
>>> buf = io.StringIO(); write_track_csv(t, buf); print(buf.getvalue().splitlines()[1])
frame,fap49_head_yaw
>>> read_track_csv(io.StringIO(buf.getvalue())).equals(t)
True
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import IO

import numpy as np

from app.errors import InputError
from app.stimuli.fap import column_name, parse_column_name
from app.stimuli.track import MotionTrack

_FIELDS = ("fps", "name", "source", "speaker")


def write_track_csv(track: MotionTrack, target: str | Path | IO[str]) -> None:
    """Write ``track`` as CSV with a ``# fps=...`` first line."""
    out = io.StringIO()
    parts = [f"fps={track.fps!r}"] + [
        f"{k}={' '.join(str(getattr(track, k)).replace(';', ',').split())}"
        for k in _FIELDS[1:]
        if getattr(track, k)
    ]
    out.write("# " + "; ".join(parts) + "\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["frame", *map(column_name, track.channels)])
    for i, row in enumerate(track.values.tolist()):
        writer.writerow([i, *map(repr, row)])
    if isinstance(target, (str, Path)):
        Path(target).write_text(out.getvalue(), encoding="utf-8")
    else:
        target.write(out.getvalue())


def read_track_csv(source: str | Path | IO[str], fps: float | None = None) -> MotionTrack:
    """Read a CSV motion track; ``fps`` overrides (or supplies) the file's ``# fps=`` line.

    Rows are placed by their ``frame`` value (0-based, increasing); missing frames are
    interpolated as in :func:`app.stimuli.fapfile.read_fap`. Errors name the line and column.
    """
    if isinstance(source, (str, Path)):
        path = str(source)
        try:
            text = Path(source).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"cannot read as CSV text: {exc}", path=path) from None
    else:
        path = getattr(source, "name", "<stream>")
        text = source.read()
    lines = text.splitlines()
    meta: dict[str, str] = {}
    start = 0
    if lines and lines[0].startswith("#"):
        for part in lines[0][1:].split(";"):
            key, _, value = part.strip().partition("=")
            if key.strip() in _FIELDS:
                meta[key.strip()] = value.strip()
        start = 1
    if fps is None:
        if "fps" not in meta:
            raise InputError("no '# fps=...' first line: give the frame rate (--fps)", path=path)
        try:
            fps = float(meta["fps"])
        except ValueError:
            raise InputError(
                f"fps is {meta['fps']!r}, expected a number", path=path, line=1
            ) from None
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"fps is {fps}, expected a number > 0", path=path)
    rows = list(csv.reader(lines[start:]))
    if not rows:
        raise InputError("no header row: expected 'frame,fap48_head_pitch,...'", path=path)
    header = [h.strip() for h in rows[0]]
    header_line = start + 1
    if not header or header[0] != "frame":
        raise InputError(
            f"first column is {header[0] if header else ''!r}, expected 'frame'",
            path=path,
            line=header_line,
        )
    try:
        channels = [parse_column_name(h) for h in header[1:]]
    except ValueError as exc:
        raise InputError(str(exc), path=path, line=header_line) from None
    if len(set(channels)) != len(channels):
        raise InputError("a FAP appears in two columns", path=path, line=header_line)
    frames, data = [], []
    for k, row in enumerate(rows[1:], start=header_line + 1):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise InputError(f"expected {len(header)} columns, got {len(row)}", path=path, line=k)
        try:
            frames.append(int(row[0]))
        except ValueError:
            raise InputError(
                f"frame is {row[0]!r}, expected an integer",
                path=path,
                line=k,
            ) from None
        vals = []
        for name, cell in zip(header[1:], row[1:], strict=True):
            try:
                v = float(cell)
            except ValueError:
                raise InputError(
                    f"{name} is {cell!r}, expected a number", path=path, line=k
                ) from None
            if not np.isfinite(v):
                raise InputError(f"{name} is {cell!r}, expected a finite number", path=path, line=k)
            vals.append(v)
        data.append(vals)
    if frames and (frames[0] < 0 or np.any(np.diff(frames) <= 0)):
        raise InputError("frame numbers must start at >= 0 and increase", path=path)
    n = frames[-1] + 1 if frames else 0
    values = np.full((n, len(channels)), np.nan)
    if frames:
        values[frames] = np.asarray(data)
    grid = np.arange(n)
    have = np.zeros(n, dtype=bool)
    have[frames] = True
    for j in range(len(channels)):
        values[~have, j] = np.interp(grid[~have], grid[have], values[have, j])
    order = np.argsort(channels)
    return MotionTrack(
        fps,
        values[:, order],
        tuple(sorted(channels)),
        name=meta.get("name", ""),
        source=meta.get("source", path),
        speaker=meta.get("speaker", ""),
    )
