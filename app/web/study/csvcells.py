"""Spreadsheet-safe CSV cells for every export (votes.csv, participants.csv, answers.csv).

A spreadsheet opening a CSV file runs a cell that starts with ``=``, ``+``, ``-`` or ``@`` as a
formula, and a leading tab or carriage return hides such a start; a participant's free-text answer
``=HYPERLINK("http://x","y")`` would become a live link in the experimenter's spreadsheet. Per
OWASP's "CSV Injection" page (https://owasp.org/www-community/attacks/CSV_Injection), such a cell
is written with a leading apostrophe, which spreadsheets show as text. A cell that is a plain
number (``-1``, ``+2.5``, ``1e-3``) is left alone, so numeric columns stay numeric.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterable, Sequence
from typing import Any

#: The characters that make a spreadsheet read a cell as a formula (or hide one).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")


def safe_cell(value: Any) -> Any:
    """``value`` with a leading apostrophe if it is text a spreadsheet would run as a formula;
    anything else (numbers, ``None``, plain text, text that is a plain number) unchanged."""
    if not isinstance(value, str) or not value.startswith(FORMULA_STARTS):
        return value
    if _NUMBER.fullmatch(value):
        return value
    return "'" + value


def csv_text(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """A header and rows as CSV text, every cell passed through :func:`safe_cell`. Lines end
    with CRLF as RFC 4180 has it, which also makes the writer quote a cell holding a lone CR
    (with a bare LF ending, Python 3.11's writer leaves it unquoted and a reader splits the row)."""
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer, lineterminator="\r\n")
    writer.writerow([safe_cell(name) for name in header])
    writer.writerows([safe_cell(cell) for cell in row] for row in rows)
    return buffer.getvalue()


def safe_csv(text: str) -> str:
    """CSV text (a header row first) rewritten with every cell passed through :func:`safe_cell`."""
    reader = csv.reader(io.StringIO(text, newline=""))
    header = next(reader, None)
    return "" if header is None else csv_text(header, reader)
