"""Read and write MPEG-4 FAP stream files (.fap) in the two dialects Xface and Greta play.

Format (``docs/reference/stimuli.md``, "The .fap format"; ISO/IEC 14496-2 for the FAPs)::

    # comment lines start with '#'
    2.1 <name, may contain spaces> <fps> <number of frames>
    <mask: 68 (Xface, MPEG-4) or 69 (Greta) values of 0/1>
    <frame index> <the values of the masked positions, in mask order>
    ...                                           (a mask line and a value line per frame)

The mask's length says the dialect, and the dialect says how to count values: Xface/MPEG-4's
68 positions give FAP 1 four values and FAP 2 six, Greta's 69 one value each
(:mod:`app.stimuli.fapdialects` has the table).

Reading rules, chosen so that a file never yields a silently wrong track:

* The header's first token is the version, its last two the fps and the frame count (at most
  :data:`MAX_FRAMES`); what lies between is the name.
* The first mask line sets the dialect; every mask line of the file must have its length.
* FAP 1 (viseme) and FAP 2 (expression) are high-level parameters, not motion: they are not
  channels of the track (nothing draws them), but their values are kept with it, frame by
  frame as the file gave them, in ``metadata["high_level"]`` (:func:`high_level_note` says
  what a file held), and :func:`write_fap` writes them back into the masks, so a rewrite in
  the same dialect keeps them. Greta's extra entry is read past. Values are integers in the
  32-bit range.
* Files that facepair wrote in Greta style before this layout was known (first comment line
  exactly :data:`~app.stimuli.fapdialects.WRITER_LINE`, 69-value masks) put a null FAP 0 first
  and FAP i at position i + 1, with the MPEG-4 widths; they are read that way, so they read
  back unchanged.
* Frames are placed by their index. Indices must increase. Frames missing from the sequence,
  and a channel masked off in some frames, are linearly interpolated from its neighbours;
  frames before the first index hold the first frame. A file whose last index is below the
  header's frame count - 1 is truncated and refused.
* Any malformed line raises :class:`app.errors.InputError` naming the file, the line number and
  what was expected (for a value line, what each dialect would have expected).

Example
-------
>>> import io
>>> mask = ["0"] * 68
>>> mask[47] = "1"                                       # position 48: head_pitch
>>> text = "2.1 demo 25 2\\n" + " ".join(mask) + "\\n0 100\\n" + " ".join(mask) + "\\n1 200\\n"
>>> track = read_fap(io.StringIO(text))
>>> track.fps, track.channels, track[48].tolist()
(25.0, (48,), [100.0, 200.0])
>>> greta = "2.1 g 25 1\\n" + " ".join(["1"] + mask[1:] + ["0"]) + "\\n0 7 100\\n"
>>> read_fap(io.StringIO(greta))[48].tolist()     # FAP 1 masked: one value in Greta's dialect
[100.0]
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import IO

import numpy as np

from app.errors import InputError
from app.stimuli.fap import FAPS
from app.stimuli.fapdialects import (
    GRETA,
    GRETA_WRITER_LINE,
    HIGH_LEVEL_WIDTH,
    WRITER_LINE,
    XFACE,
    Dialect,
    count_error,
    dialect_of,
    mask_layout,
)
from app.stimuli.track import MotionTrack

#: Largest frame count a header may give: over 2 hours at 120 Hz; a bound on memory.
MAX_FRAMES = 1_000_000
#: FAP values are 32-bit integers in both players.
_INT32 = 2**31 - 1
_META_KEYS = ("source", "speaker")


def _lines(f: IO[str]):
    """Yield (line number, stripped text) for the non-blank lines."""
    for number, raw in enumerate(f, start=1):
        text = raw.strip()
        if text:
            yield number, text


def read_fap(source: str | Path | IO[str]) -> MotionTrack:
    """Read a .fap file of either dialect into a :class:`MotionTrack` (values in FAPU).

    The channels are the union of the low-level FAPs masked in any frame. Raises
    :class:`InputError` for a malformed file: header, mask, values, truncation.
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
            value = int(tok)
        except ValueError:
            raise InputError(
                f"{what}: value {k} is {tok[:40]!r}, expected an integer", path=path, line=line
            ) from None
        if abs(value) > _INT32:
            raise InputError(
                f"{what}: value {k} is outside the 32-bit integer range", path=path, line=line
            )
        out.append(value)
    return out


def _header(text: str, path: str, line: int) -> tuple[str, float, int]:
    """Name, fps and frame count from the header line ``2.1 <name> <fps> <nframes>``."""
    tokens = text.split()
    if len(tokens) < 3:
        raise InputError(
            f"header {text[:60]!r}: expected '2.1 <name> <fps> <nframes>'", path=path, line=line
        )
    try:
        fps = float(tokens[-2])
    except ValueError:
        raise InputError(
            f"header: fps is {tokens[-2][:40]!r}, expected a number", path=path, line=line
        ) from None
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(
            f"header: fps is {tokens[-2][:40]}, expected a number > 0", path=path, line=line
        )
    try:
        n_frames = int(tokens[-1])
    except ValueError:
        raise InputError(
            f"header: frame count is {tokens[-1][:40]!r}, expected an integer", path=path, line=line
        ) from None
    if not 0 <= n_frames <= MAX_FRAMES:
        raise InputError(
            f"header: frame count is {n_frames}, expected 0..{MAX_FRAMES}", path=path, line=line
        )
    return " ".join(tokens[1:-2]), fps, n_frames


def _parse(f: IO[str], path: str) -> MotionTrack:
    meta: dict[str, str] = {}
    lines = []
    first_comment: str | None = None
    for number, text in _lines(f):
        if text.startswith("#"):
            comment = text[1:].strip()
            if first_comment is None:
                first_comment = comment
            key, _, value = comment.partition(":")
            if key.strip() in _META_KEYS and value.strip():
                meta[key.strip()] = value.strip()
            continue
        lines.append((number, text))
    if not lines:
        raise InputError("empty file: expected a header '2.1 <name> <fps> <nframes>'", path=path)
    number, header = lines[0]
    name, fps, n_frames = _header(header, path, number)

    body = lines[1:]
    if len(body) % 2:
        raise InputError(
            "truncated: a mask line without its value line at the end of the file",
            path=path,
            line=body[-1][0],
        )
    dialect: Dialect | None = None
    frames: list[tuple[int, np.ndarray, np.ndarray]] = []
    high_level: dict[str, list[list[int]]] = {}
    last_index = -1
    for k in range(0, len(body), 2):
        mask_no, mask_text = body[k]
        value_no, value_text = body[k + 1]
        mask = _ints(mask_text.split(), path, mask_no, "mask line")
        if dialect is None:
            dialect = dialect_of(mask, first_comment == WRITER_LINE, path, mask_no)
        elif len(mask) != len(dialect.faps):
            raise InputError(
                f"mask line: {len(mask)} values after {len(dialect.faps)}-value masks; "
                "a file holds one dialect (68: Xface, 69: Greta)",
                path=path,
                line=mask_no,
            )
        if any(m not in (0, 1) for m in mask):
            raise InputError("mask line: expected only 0 and 1", path=path, line=mask_no)
        bits = tuple(mask)
        columns, places, width, high = mask_layout(dialect, bits)
        vals = _ints(value_text.split(), path, value_no, "value line")
        if len(vals) != width + 1:
            raise count_error(dialect, bits, len(vals), path, value_no)
        index = vals[0]
        if index < 0 or index <= last_index:
            after = f" after {last_index}" if last_index >= 0 else ""
            raise InputError(
                f"frame index {index}{after}: indices must start at >= 0 and increase",
                path=path,
                line=value_no,
            )
        if index >= n_frames:
            raise InputError(
                f"frame index {index} outside 0..{n_frames - 1} (header says {n_frames} frames)",
                path=path,
                line=value_no,
            )
        last_index = index
        frames.append((index, columns, np.asarray(vals, dtype=np.float64)[places]))
        for fap, place, n in high:
            high_level.setdefault(str(fap), []).append([index, *vals[place : place + n]])
    if last_index < n_frames - 1:
        raise InputError(
            f"truncated: header says {n_frames} frames, the last frame index is {last_index}",
            path=path,
            line=body[-1][0] if body else number,
        )
    present = np.unique(
        np.concatenate([np.empty(0, np.intp)] + [columns for _, columns, _ in frames])
    )
    kept = np.full((n_frames, len(present)), np.nan)
    for index, columns, row in frames:
        kept[index, np.searchsorted(present, columns)] = row
    channels = tuple(int(i) + 1 for i in present)
    _fill_gaps(kept)
    metadata = {}
    if high_level and dialect is not None:
        metadata["high_level"] = {
            "widths": {str(f): dialect.width(f) for f in HIGH_LEVEL_WIDTH},
            "fps": fps,
            "n_frames": n_frames,
            "frames": high_level,
        }
    return MotionTrack(
        fps,
        kept,
        channels,
        name=name,
        source=meta.get("source", path),
        speaker=meta.get("speaker", ""),
        metadata=metadata,
    )


def high_level_note(track: MotionTrack) -> str | None:
    """One line on the FAP 1 / FAP 2 values a .fap file held, or ``None``.

    >>> text = "2.1 w 25 1\\n" + " ".join(["1"] + ["0"] * 68) + "\\n0 7\\n"
    >>> high_level_note(read_fap(io.StringIO(text)))
    'FAP 1 (viseme) in 1 frame kept with the track: high-level, not motion, so not drawn'
    """
    high = track.metadata.get("high_level")
    if not isinstance(high, dict) or not high.get("frames"):
        return None
    parts = [
        f"FAP {fap} ({FAPS[int(fap)].name}) in {len(rows)} frame{'s' if len(rows) != 1 else ''}"
        for fap, rows in sorted(high["frames"].items())
    ]
    return f"{' and '.join(parts)} kept with the track: high-level, not motion, so not drawn"


def _high_level_rows(
    track: MotionTrack, dialect: Dialect
) -> tuple[dict[int, dict[int, list[int]]], str | None]:
    """FAP -> frame -> values of the high-level FAPs to write, or why they cannot be."""
    high = track.metadata.get("high_level")
    if not isinstance(high, dict) or not high.get("frames"):
        return {}, None
    try:
        widths = {int(f): int(w) for f, w in high["widths"].items()}
        rows = {
            int(f): {int(r[0]): [int(v) for v in r[1:]] for r in frames}
            for f, frames in high["frames"].items()
        }
        same_timing = float(high["fps"]) == track.fps and int(high["n_frames"]) == track.n_frames
    except (KeyError, TypeError, ValueError, IndexError):
        return {}, "FAP 1 and 2 not written: their record in the track's metadata is damaged"
    names = " and ".join(f"FAP {f} ({FAPS[f].name})" for f in sorted(rows))
    if not same_timing:
        return (
            {},
            f"{names} not written: the track was resampled, trimmed or padded after they were read",
        )
    if any(widths.get(f) != dialect.width(f) for f in rows):
        return {}, (
            f"{names} not written: they came with {', '.join(str(widths[f]) for f in rows)} "
            f"value(s) a frame, the {dialect.name} takes "
            f"{', '.join(str(dialect.width(f)) for f in rows)}"
        )
    return rows, None


def _fill_gaps(values: np.ndarray) -> None:
    """Linear interpolation over NaN runs per column, in place; ends hold the nearest value."""
    frames = np.arange(values.shape[0])
    for j in range(values.shape[1]):
        col = values[:, j]
        missing = np.isnan(col)
        if missing.any():
            col[missing] = np.interp(frames[missing], frames[~missing], col[~missing])


def write_fap(
    track: MotionTrack, target: str | Path | IO[str], *, greta: bool = False
) -> str | None:
    """Write ``track`` as a .fap file; values are rounded to integers (the format's type).

    FAP 1 and 2 values read from a .fap file (``metadata["high_level"]``) are written back in
    their frames' masks when the dialect gives them the same number of values and the track
    has its frames; otherwise they are left out, and the returned line (also a comment in the
    file) says which and why. Returns ``None`` when nothing was left out.

    The default writes 68-value masks, what Xface (and MPEG-4) read. ``greta=True`` writes what
    Greta writes: 69-value masks, FAP i at position i and one trailing extra entry (left 0),
    one integer per masked FAP. Source and speaker go into comment lines, which
    :func:`read_fap` reads back. A track holding FAP 1 or 2 (high-level, not motion; the reader
    reads past them) or a value beyond the 32-bit range is refused with an :class:`InputError`.
    """
    high = [c for c in track.channels if c in HIGH_LEVEL_WIDTH]
    if high:
        raise InputError(
            f"FAP {high[0]} ({FAPS[high[0]].name}) is a high-level parameter, not motion: "
            "a .fap file written by facepair holds FAPs 3..68 only",
            field="channels",
        )
    ints = np.rint(track.values)
    if ints.size and not np.all(np.abs(ints) <= _INT32):
        raise InputError(
            "a value is outside the 32-bit integer range of .fap files", field="values"
        )
    ints = ints.astype(np.int64)
    out = io.StringIO()
    out.write(f"# {GRETA_WRITER_LINE if greta else WRITER_LINE}\n")
    for key in _META_KEYS:
        value = " ".join(str(getattr(track, key)).split())
        if value:
            out.write(f"# {key}: {value}\n")
    fps = int(track.fps) if float(track.fps).is_integer() else repr(track.fps)
    name = " ".join(track.name.split()) or "facepair"
    out.write(f"2.1 {name} {fps} {track.n_frames}\n")
    dialect = GRETA if greta else XFACE
    kept, left_out = _high_level_rows(track, dialect)
    if left_out:
        out.write(f"# {left_out}\n")
    bits = ["0"] * len(dialect.faps)
    for c in track.channels:
        bits[c - 1] = "1"
    mask = " ".join(bits) + "\n"
    for i in range(track.n_frames):
        extra = [kept[f][i] for f in sorted(kept) if i in kept[f]]
        if extra:
            frame_bits = list(bits)
            for f in sorted(kept):
                if i in kept[f]:
                    frame_bits[f - 1] = "1"
            out.write(" ".join(frame_bits) + "\n")
        else:
            out.write(mask)
        values = [str(v) for row in extra for v in row] + list(map(str, ints[i].tolist()))
        out.write(" ".join([str(i), *values]) + "\n")
    text = out.getvalue()
    if isinstance(target, (str, Path)):
        Path(target).write_text(text, encoding="utf-8")
    else:
        target.write(text)
    return left_out
