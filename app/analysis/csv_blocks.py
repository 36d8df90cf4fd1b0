"""Reading a votes CSV in blocks: Arrow's CSV reader for plain files, the csv module for the rest.

A *plain* file has no quote character, no NUL byte and, on every line, exactly as many fields
as the header (an empty line aside, which carries no vote). In such a file every physical line
is one row, so a row's line number is its position plus the header's line. Arrow's streaming
CSV reader (:func:`arrow_blocks`) reads it a block of bytes at a time with quoting switched off,
each text column dictionary-encoded as it is parsed (codes and the block's distinct values: no
Python string per row), and refuses a row with the wrong number of fields itself. A quote or a
NUL is looked for in the distinct values only. The first block that is not plain raises
:class:`NotPlain`, and the caller reads the whole file again with :func:`exact_rows` (the csv
module, which counts lines itself and reports a row with the wrong number of fields).

Both return blocks of the same shape: per header column its values, the line number of each row
(negative for a row already known to have the wrong field count) and whether values may need
stripping. The csv module gives object arrays of ``str``; Arrow gives a column as its codes
and distinct values (a :class:`pyarrow.StringArray`), and a column named in ``unique`` (one
value per row, such as a time) as a :class:`pyarrow.StringArray` of every row.
"""

from __future__ import annotations

import csv
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from app.errors import InputError

#: Bytes Arrow reads per block: about 18,000 votes of the full export (it reads a few blocks
#: ahead, so larger blocks hold more of the file at once: 1.6 million votes peaked at 380 MB
#: reading with 1 MB blocks, 450 MB with 2 MB, 540-590 MB with 4 MB; the target is 3x the
#: CSV, 560 MB; the 2 MB blocks read faster than the 1 MB ones, 1.6-1.9 s against 2.0-2.9).
BLOCK_BYTES = 1 << 21


class NotPlain(Exception):
    """The file needs the exact reader (quotes, a wrong field count, a stray byte)."""


Block = tuple[dict[str, Any], np.ndarray, bool]


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


def _has(values: pa.Array, pattern: str) -> bool:
    return bool(pc.any(pc.match_substring_regex(values, pattern)).as_py())


def quoted_or_nul(values: pa.Array) -> bool:
    """Whether any value holds a quote (read with quoting off, a quoted field keeps its
    quotes) or a NUL: the file is not plain."""
    return _has(values, '["\\x00]')


#: A character that is not printable ASCII at either end: the value may need ``str.strip``.
_MAY_STRIP = "^[^!-~]|[^!-~]$"


def arrow_blocks(path: Path, header: list[str], unique: Collection[str] = ()) -> Iterator[Block]:
    """Blocks of a plain file after its header line: columns, line numbers, and whether any
    value may need stripping. Raises :class:`NotPlain` at the first block that is not plain
    (the caller starts again with :func:`exact_rows`). A column in ``unique`` is not checked
    for quotes here: its reader must refuse them (an ISO 8601 time has none)."""
    if len(set(header)) != len(header):
        raise NotPlain  # Arrow would need unique names; the exact path reports repeated ones
    keys = [f"c{k}" for k in range(len(header))]  # header names may be any text
    # every column parsed as text, the others dictionary-encoded here (a column left empty,
    # as most optional ones are, needs no hashing: 0.27 s against 0.37 s for 600,000 votes)
    types = dict.fromkeys(keys, pa.string())
    try:
        reader = pacsv.open_csv(
            path,
            # threads: Arrow parses the next blocks on another core while this one is typed
            read_options=pacsv.ReadOptions(
                skip_rows=1, column_names=keys, block_size=BLOCK_BYTES, use_threads=True
            ),
            parse_options=pacsv.ParseOptions(quote_char=False, ignore_empty_lines=False),
            convert_options=pacsv.ConvertOptions(
                column_types=types, strings_can_be_null=False, quoted_strings_can_be_null=False
            ),
            memory_pool=pa.system_memory_pool(),
        )
        line = 2
        for batch in reader:
            columns: dict[str, Any] = {}
            for key, name in zip(keys, header, strict=True):
                column = batch.column(key)
                columns[name] = column if name in unique else _codes(column)
            # every distinct value of the block at once: two scans, whatever the width
            distinct = pa.concat_arrays([c[1] for c in columns.values() if isinstance(c, tuple)])
            if quoted_or_nul(distinct):
                raise NotPlain
            may_strip = _has(distinct, _MAY_STRIP)
            rows = batch.num_rows
            yield columns, np.arange(line, line + rows, dtype=np.int64), may_strip
            line += rows
    except (pa.ArrowException, OSError, UnicodeDecodeError):
        raise NotPlain from None


def _codes(column: pa.StringArray) -> tuple[np.ndarray, pa.StringArray]:
    """A text column as its codes (int32) and distinct values, in order of first use."""
    offsets = np.frombuffer(
        column.buffers()[1], dtype=np.int32, count=len(column) + 1, offset=column.offset * 4
    )
    if len(column) == 0 or offsets[-1] == offsets[0]:  # every value empty
        return np.zeros(len(column), np.int32), pa.array([""] if len(column) else [], pa.string())
    encoded = column.dictionary_encode()
    return encoded.indices.to_numpy().astype(np.int32, copy=False), encoded.dictionary


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
