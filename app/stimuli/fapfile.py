"""Read and write MPEG-4 FAP stream files (.fap), the text format Greta and Xface play.

Format (see ``docs/formats.md``)::

    # comment lines start with '#'
    2.1 <name, may contain spaces> <fps> <number of frames>
    <mask: 68 values of 0/1, FAP 1..68>          (Greta writes 69: a leading null FAP 0)
    <frame index> <one integer per FAP whose mask bit is 1, in FAP order>
    ...                                           (a mask line and a value line per frame)

Reading rules, chosen so that a file never yields a silently wrong track:

* The header's first token is the version, its last two the fps and the frame count; what lies
  between is the name.
* A 69-value mask is Greta's: its first value is the null FAP 0. If that bit is 1 the value line
  carries one extra leading value, which is dropped.
* FAP 1 (viseme) and FAP 2 (expression) are high-level parameters carrying 4 and 6 values in a
  frame (ISO/IEC 14496-2); they are read past and not kept.
* Frames are placed by their index. Indices must increase. Frames missing from the sequence,
  and a channel masked off in some frames, are linearly interpolated from its neighbours;
  frames before the first index hold the first frame. A file whose last index is below the
  header's frame count - 1 is truncated and refused.
* Any malformed line raises :class:`app.errors.InputError` naming the file, the line number and
  what was expected.

Example
-------
>>> import io
>>> text = "2.1 demo 25 2\\n" + " ".join(["0"] * 47 + ["1"] + ["0"] * 20) + "\\n0 100\\n"
>>> text += " ".join(["0"] * 47 + ["1"] + ["0"] * 20) + "\\n1 200\\n"
>>> track = read_fap(io.StringIO(text))
>>> track.fps, track.channels, track[48].tolist()
(25.0, (48,), [100.0, 200.0])
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import IO

import numpy as np

from app.errors import InputError
from app.stimuli.fap import N_FAPS
from app.stimuli.track import MotionTrack

#: Values a frame carries for the high-level FAPs (viseme: select1, select2, blend, def;
#: expression: select1, intensity1, select2, intensity2, init_face, def).
_HIGH_LEVEL_WIDTH = {1: 4, 2: 6}
_META_KEYS = ("source", "speaker")


def _lines(f: IO[str]):
    """Yield (line number, stripped text) for non-blank, non-comment lines; collect comments."""
    for number, raw in enumerate(f, start=1):
        text = raw.strip()
        if text:
            yield number, text


def read_fap(source: str | Path | IO[str]) -> MotionTrack:
    """Read a .fap file into a :class:`MotionTrack` (values in FAPU, channels = union of masks).

    Raises :class:`InputError` for a malformed file: header, mask, values, truncation.
    """
    if isinstance(source, (str, Path)):
        path = str(source)
        try:
            with open(source, encoding="utf-8", errors="strict") as f:
                return _parse(f, path)
        except UnicodeDecodeError:
            raise InputError("not a text .fap file (undecodable bytes)", path=path) from None
        except OSError as exc:
            raise InputError(f"cannot read: {exc.strerror}", path=path) from None
    return _parse(source, getattr(source, "name", "<stream>"))


def _ints(tokens: list[str], path: str, line: int, what: str) -> list[int]:
    out = []
    for k, tok in enumerate(tokens, start=1):
        try:
            out.append(int(tok))
        except ValueError:
            raise InputError(
                f"{what}: value {k} is {tok!r}, expected an integer", path=path, line=line
            ) from None
    return out


def _parse(f: IO[str], path: str) -> MotionTrack:
    meta: dict[str, str] = {}
    lines = []
    for number, text in _lines(f):
        if text.startswith("#"):
            key, _, value = text[1:].strip().partition(":")
            if key.strip() in _META_KEYS and value.strip():
                meta[key.strip()] = value.strip()
            continue
        lines.append((number, text))
    if not lines:
        raise InputError("empty file: expected a header '2.1 <name> <fps> <nframes>'", path=path)

    number, header = lines[0]
    tokens = header.split()
    if len(tokens) < 3:
        raise InputError(
            f"header {header!r}: expected '2.1 <name> <fps> <nframes>'", path=path, line=number
        )
    try:
        fps = float(tokens[-2])
    except ValueError:
        raise InputError(f"header: fps is {tokens[-2]!r}, expected a number", path=path,
                         line=number) from None
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"header: fps is {tokens[-2]}, expected a number > 0", path=path,
                         line=number)
    try:
        n_frames = int(tokens[-1])
    except ValueError:
        raise InputError(f"header: frame count is {tokens[-1]!r}, expected an integer",
                         path=path, line=number) from None
    if n_frames < 0:
        raise InputError(f"header: frame count is {n_frames}, expected >= 0", path=path,
                         line=number)
    name = " ".join(tokens[1:-2])

    body = lines[1:]
    if len(body) % 2:
        last_line = body[-1][0]
        raise InputError(
            "truncated: a mask line without its value line at the end of the file",
            path=path, line=last_line,
        )
    values = np.full((n_frames, N_FAPS), np.nan)
    present = np.zeros(N_FAPS, dtype=bool)
    last_index = -1
    for k in range(0, len(body), 2):
        mask_no, mask_text = body[k]
        value_no, value_text = body[k + 1]
        mask = _ints(mask_text.split(), path, mask_no, "mask line")
        if len(mask) not in (N_FAPS, N_FAPS + 1):
            raise InputError(
                f"mask line: expected 68 (Xface) or 69 (Greta) values of 0/1, got {len(mask)}",
                path=path, line=mask_no,
            )
        if any(m not in (0, 1) for m in mask):
            raise InputError("mask line: expected only 0 and 1", path=path, line=mask_no)
        null_fap = mask[0] if len(mask) == N_FAPS + 1 else 0
        bits = mask[-N_FAPS:]
        width = null_fap + sum(_HIGH_LEVEL_WIDTH.get(i + 1, 1) for i, b in enumerate(bits) if b)
        vals = _ints(value_text.split(), path, value_no, "value line")
        if len(vals) != width + 1:
            raise InputError(
                f"value line: expected the frame index and {width} values for the "
                f"{sum(bits)} masked FAPs, got {len(vals)} numbers",
                path=path, line=value_no,
            )
        index = vals[0]
        if index <= last_index:
            raise InputError(
                f"frame index {index} after {last_index}: indices must increase",
                path=path, line=value_no,
            )
        if index >= n_frames:
            raise InputError(
                f"frame index {index} outside 0..{n_frames - 1} (header says {n_frames} frames)",
                path=path, line=value_no,
            )
        last_index = index
        pos = 1 + null_fap
        for i, bit in enumerate(bits):
            if not bit:
                continue
            fap = i + 1
            if fap in _HIGH_LEVEL_WIDTH:
                pos += _HIGH_LEVEL_WIDTH[fap]
                continue
            values[index, i] = vals[pos]
            present[i] = True
            pos += 1
    if last_index < n_frames - 1:
        where = body[-1][0] if body else number
        raise InputError(
            f"truncated: header says {n_frames} frames, the last frame index is {last_index}",
            path=path, line=where,
        )
    channels = tuple(int(i) + 1 for i in np.flatnonzero(present))
    kept = values[:, present]
    _fill_gaps(kept)
    return MotionTrack(fps, kept, channels, name=name, source=meta.get("source", path),
                       speaker=meta.get("speaker", ""))


def _fill_gaps(values: np.ndarray) -> None:
    """Linear interpolation over NaN runs per column, in place; ends hold the nearest value."""
    frames = np.arange(values.shape[0])
    for j in range(values.shape[1]):
        col = values[:, j]
        missing = np.isnan(col)
        if missing.any():
            col[missing] = np.interp(frames[missing], frames[~missing], col[~missing])


def write_fap(track: MotionTrack, target: str | Path | IO[str], *, greta: bool = False) -> None:
    """Write ``track`` as a .fap file; values are rounded to integers (the format's type).

    ``greta=True`` writes 69-value masks (a leading 0 for the null FAP), as Greta does; the
    default 68-value masks are what Xface reads. Source and speaker go into comment lines, which
    :func:`read_fap` reads back.
    """
    out = io.StringIO()
    out.write("# MPEG-4 FAP stream written by facepair\n")
    for key in _META_KEYS:
        value = " ".join(str(getattr(track, key)).split())
        if value:
            out.write(f"# {key}: {value}\n")
    fps = int(track.fps) if float(track.fps).is_integer() else repr(track.fps)
    name = " ".join(track.name.split()) or "facepair"
    out.write(f"2.1 {name} {fps} {track.n_frames}\n")
    bits = ["0"] * N_FAPS
    for c in track.channels:
        bits[c - 1] = "1"
    if greta:
        bits = ["0", *bits]
    mask = " ".join(bits) + "\n"
    ints = np.rint(track.values).astype(np.int64)
    for i in range(track.n_frames):
        out.write(mask)
        out.write(" ".join([str(i), *map(str, ints[i].tolist())]) + "\n")
    text = out.getvalue()
    if isinstance(target, (str, Path)):
        Path(target).write_text(text, encoding="utf-8")
    else:
        target.write(text)
