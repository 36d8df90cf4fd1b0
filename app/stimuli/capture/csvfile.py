"""Reading a tracker's CSV: one header, one row of numbers per frame, errors naming row and column.

Both importers (:mod:`~app.stimuli.capture.openface`, :mod:`~app.stimuli.capture.arkit`) read
their files through :func:`read_numeric_csv`: the header's names stripped of spaces, blank
lines skipped, every other row as long as the header and every cell a number (except the
columns named in ``text_columns``, kept as strings). Anything else is one
:class:`~app.errors.InputError` naming the file, the line and the column.

Example
-------
>>> import tempfile, os
>>> path = os.path.join(tempfile.mkdtemp(), "t.csv")
>>> with open(path, "w") as out:
...     _ = out.write("time, x\\n0.0, 1\\n0.1, 2\\n")
>>> table = read_numeric_csv(path)
>>> table.header, table.values.tolist(), table.lines.tolist()
(['time', 'x'], [[0.0, 1.0], [0.1, 2.0]], [2, 3])
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.errors import InputError


@dataclass(eq=False)
class NumericTable:
    """Header names, numbers (rows x columns; NaN in text columns), text columns, file lines."""

    header: list[str]
    values: np.ndarray
    lines: np.ndarray
    text: dict[str, list[str]] = field(default_factory=dict)


def read_numeric_csv(
    path: str | Path,
    *,
    check_header: Callable[[list[str]], str | None] = lambda header: None,
    text_columns: dict[str, Callable[[str], str | None]] | None = None,
) -> NumericTable:
    """Read a tracker's CSV (see the module docstring).

    ``check_header(names)`` returns why the header is not the expected one, or ``None``;
    ``text_columns`` maps a column name (any case) to a check returning why a cell is bad, or
    ``None``; those cells are kept in :attr:`NumericTable.text` under the file's own name.
    """
    p = Path(path)
    checks = {k.lower(): v for k, v in (text_columns or {}).items()}
    try:
        with p.open(newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(f, skipinitialspace=True)
            header = [h.strip() for h in next(reader, [])]
            problem = check_header(header)
            if problem:
                raise InputError(problem, path=p, line=1)
            text_at = {i: checks[h.lower()] for i, h in enumerate(header) if h.lower() in checks}
            values: list[list[float]] = []
            text: dict[str, list[str]] = {header[i]: [] for i in text_at}
            lines: list[int] = []
            for record in reader:
                if not record or all(not v.strip() for v in record):
                    continue
                line = reader.line_num
                if len(record) != len(header):
                    raise InputError(
                        f"{len(record)} values for {len(header)} columns", path=p, line=line
                    )
                row = []
                for i, cell in enumerate(record):
                    if i in text_at:
                        why = text_at[i](cell.strip())
                        if why:
                            raise InputError(f"column {header[i]}: {why}", path=p, line=line)
                        text[header[i]].append(cell.strip())
                        row.append(np.nan)
                        continue
                    try:
                        row.append(float(cell))
                    except ValueError:
                        raise InputError(
                            f"column {header[i]}: not a number: {cell[:40]!r}", path=p, line=line
                        ) from None
                values.append(row)
                lines.append(line)
    except FileNotFoundError:
        raise InputError("no such file", path=p) from None
    except UnicodeDecodeError:
        raise InputError("not a text CSV file (not UTF-8)", path=p) from None
    except csv.Error as exc:
        raise InputError(f"not a readable CSV: {exc}", path=p) from None
    if not values:
        raise InputError("no data rows", path=p)
    return NumericTable(header, np.array(values, dtype=np.float64), np.array(lines), text)
