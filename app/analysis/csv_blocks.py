"""Reading a votes CSV in blocks: the C parser for plain files, the csv module for the rest.

A *plain* file has no quote character, no NUL byte, no lone carriage return and, on every
non-empty line, exactly as many commas as the header. In such a file every physical line is one
row, so a row's line number is its position plus the header's line; pandas' C tokenizer reads it
a block of lines at a time (:func:`plain_blocks`) and nothing but the current block's text is ever
held as Python strings. Whether a block is plain is checked on its bytes with numpy (one pass,
vectorised) before it is parsed; the first block that is not raises :class:`NotPlain`, and the
caller reads the whole file again with :func:`exact_rows` (the csv module, which counts lines
itself and reports a row with the wrong number of fields).

Both return the same thing: per block, every header column as an object array of ``str`` and
the line number of each row (negative for a row already known to have the wrong field count).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd

from app.errors import InputError

#: Bytes read per block: about 35,000 votes of the full export, some 25 MB of Python strings.
BLOCK_BYTES = 4 << 20
_QUOTE, _NUL, _CR, _LF, _COMMA = ord('"'), 0, ord("\r"), ord("\n"), ord(",")


class NotPlain(Exception):
    """The file needs the exact reader (quotes, a wrong field count, a stray byte)."""


Block = tuple[dict[str, np.ndarray], np.ndarray, bool]


def read_header(path: Path) -> tuple[list[str], int] | None:
    """The header's names (stripped) and its length in bytes with the line break, or None when
    the header is not plain (quoted, empty, not UTF-8, unreadable): the exact reader then
    reports what is wrong."""
    try:
        with path.open("rb") as handle:
            first = handle.readline()
        text = first.decode("utf-8-sig")
    except (OSError, UnicodeDecodeError):
        return None
    if not first.strip() or any(b in first for b in (b'"', b"\0")) or "\r" in text.rstrip("\r\n"):
        return None
    return [h.strip() for h in next(csv.reader([text]), [])], len(first)


def _check_block(data: bytes, width: int) -> tuple[int, bool]:
    """Rows in a block of whole lines (``data`` ends with a line break unless it is the file's
    end) and whether any field might need stripping; :class:`NotPlain` if the block is not plain.
    """
    a = np.frombuffer(data, dtype=np.uint8)
    if np.count_nonzero(a == _QUOTE) or np.count_nonzero(a == _NUL):
        raise NotPlain
    n_cr = np.count_nonzero(a == _CR)
    ends = np.flatnonzero(a == _LF)
    if ends.size == 0 or ends[-1] != a.size - 1:
        ends = np.append(ends, a.size)  # the last line has no line break
    cr = np.flatnonzero(a == _CR) if n_cr else np.zeros(0, dtype=np.int64)
    if cr.size and not np.isin(cr + 1, ends).all():
        raise NotPlain  # a carriage return that is not part of CRLF
    commas = np.diff(np.searchsorted(np.flatnonzero(a == _COMMA), ends), prepend=0)
    starts = np.concatenate(([0], ends[:-1] + 1))
    length = ends - starts - (np.isin(ends - 1, cr) if cr.size else 0)  # without CRLF's CR
    if np.any((commas != width - 1) & (length > 0)):
        raise NotPlain  # a row with too few or too many fields (an empty line is no vote)
    # As int8, bytes >= 128 are negative: one comparison finds every byte below "!" or beyond
    # ASCII; line breaks aside, such a byte may be whitespace str.strip removes.
    low = np.count_nonzero(a.view(np.int8) < 33) - np.count_nonzero(a == _LF) - n_cr
    return int(ends.size), bool(low > 0)


def _parse(data: bytes, header: list[str], rows: int) -> dict[str, np.ndarray]:
    try:
        frame = pd.read_csv(
            io.BytesIO(data),
            header=None,
            names=list(range(len(header))),
            dtype=object,
            keep_default_na=False,
            skip_blank_lines=False,
            index_col=False,
            encoding="utf-8",
        )
    except (ValueError, pd.errors.ParserError, UnicodeDecodeError):
        raise NotPlain from None
    if len(frame) != rows:
        raise NotPlain
    return {name: frame[k].to_numpy(dtype=object) for k, name in enumerate(header)}


def plain_blocks(path: Path, header: list[str], skip: int) -> Iterator[Block]:
    """Blocks of a plain file after its header (``skip`` bytes): columns, line numbers, and
    whether any field might need stripping. Raises :class:`NotPlain` at the first block that is
    not plain (the caller starts again with :func:`exact_rows`)."""
    if len(set(header)) != len(header):
        raise NotPlain  # the C parser would rename repeated names; the exact path reports them
    width, line = len(header), 2
    try:
        handle = path.open("rb")
    except OSError:
        raise NotPlain from None
    with handle:
        handle.seek(skip)
        rest = b""
        while True:
            chunk = handle.read(BLOCK_BYTES)
            data = rest + chunk
            if not data:
                return
            cut = data.rfind(b"\n") + 1 if chunk else len(data)
            if cut == 0:
                rest = data
                continue
            data, rest = data[:cut], data[cut:]
            rows, may_strip = _check_block(data, width)
            columns = _parse(data, header, rows)
            yield columns, np.arange(line, line + rows, dtype=np.int64), may_strip
            line += rows


def exact_rows(path: Path) -> tuple[list[str], Block, list[InputError]]:
    """The whole file read by the csv module: header, one block, and field-count errors.

    A row with the wrong number of fields is padded (or cut) to the header's width, its line
    number made negative and its error returned; blank lines carry no vote and are skipped.
    """
    try:
        handle = path.open(newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"cannot read votes file ({exc.strerror})", path=path) from None
    with handle:
        reader = csv.reader(handle)
        try:
            header = next(reader)
        except StopIteration:
            raise InputError("empty file; expected a header line", path=path, line=1) from None
        except (csv.Error, UnicodeDecodeError) as exc:
            raise InputError(f"not a CSV file ({exc})", path=path, line=1) from None
        width = len(header)
        rows: list[list[str]] = []
        lines: list[int] = []
        count_errors: list[InputError] = []
        try:
            for row in reader:
                if not row or all(not cell.strip() for cell in row):
                    continue  # blank lines carry no vote
                if len(row) != width:
                    count_errors.append(
                        InputError(
                            f"expected {width} fields like the header, got {len(row)}",
                            path=path,
                            line=reader.line_num,
                        )
                    )
                    row = (row + [""] * width)[:width]
                    lines.append(-reader.line_num)  # negative: already known bad
                else:
                    lines.append(reader.line_num)
                rows.append(row)
        except (csv.Error, UnicodeDecodeError) as exc:
            raise InputError(f"unreadable CSV ({exc})", path=path, line=reader.line_num) from None
    names = [h.strip() for h in header]
    table = np.empty((len(rows), width), dtype=object)
    if rows:
        table[:] = rows
    columns = {}
    for k, name in enumerate(names):
        if name not in columns:  # a repeated name: the header check reports it
            columns[name] = table[:, k]
    return names, (columns, np.asarray(lines, dtype=np.int64), True), count_errors
