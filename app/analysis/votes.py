"""The votes table: the one definition of a paired-comparison vote (columns, types, values).

Every vote is one presentation of a side-by-side pair (thesis sec. 5.1-5.2: the same audio
under two conditions, left and right panel) and the participant's answer: ``left``, ``right``
or ``undecided`` (Le, Ma & Deng 2012, sec. 8.1: participants "were allowed to leave undecided
choices"). The web app exports through :func:`write_votes_csv`; the analysis reads through
:func:`read_votes`; both validate with the same rules, so a file one writes the other reads.

CSV layout: a header naming the columns (any order; all required ones present; columns the
format does not know are ignored on reading and refused on writing), then one row per vote.
Line numbers in messages count the header as line 1.

>>> [c.name for c in COLUMN_SPECS if c.required]
['participant', 'clip', 'left', 'right', 'choice']
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np
import pandas as pd

from app.errors import InputError
from app.trials.rules import CHOICES

#: How a true/false column may be spelt (case-insensitive); written as true/false.
FLAGS: dict[str, bool] = {
    "true": True,
    "1": True,
    "yes": True,
    "false": False,
    "0": False,
    "no": False,
}


@dataclass(frozen=True)
class VoteColumn:
    """One column of the votes table: its name, kind, whether required, and its meaning."""

    name: str
    kind: str  # "text", "choice", "count", "number", "flag" (true/false) or "time"
    required: bool
    description: str


COLUMN_SPECS: tuple[VoteColumn, ...] = (
    VoteColumn("participant", "text", True, "participant identifier (any non-empty text)"),
    VoteColumn("clip", "text", True, "clip (sentence / audio segment) the pair was rendered for"),
    VoteColumn("left", "text", True, "condition shown on the left panel"),
    VoteColumn("right", "text", True, "condition shown on the right panel"),
    VoteColumn("choice", "choice", True, "the answer: left, right or undecided"),
    VoteColumn("study", "text", False, "study identifier"),
    VoteColumn("trial", "count", False, "position of the pair in the participant's schedule"),
    VoteColumn("response_ms", "number", False, "milliseconds from presentation to vote"),
    VoteColumn("plays", "count", False, "how many times the pair was played"),
    VoteColumn("presented_at", "time", False, "ISO 8601 time the pair was shown"),
    VoteColumn("voted_at", "time", False, "ISO 8601 time of the vote"),
    # The participant's side (HEMVIP2's 5-level scale, reason tags, the media log):
    VoteColumn(
        "strength",
        "count",
        False,
        "on a 5-level scale: 2 clearly, 1 slightly, 0 cannot decide (empty: 3 levels)",
    ),
    VoteColumn("reasons", "text", False, "reason tags ticked after the choice, ';'-separated"),
    VoteColumn(
        "mismatched",
        "text",
        False,
        "appropriateness pair: the side showing another clip's motion (else empty)",
    ),
    VoteColumn("watched_ms", "number", False, "milliseconds of the clip actually played"),
    VoteColumn("played_to_end", "flag", False, "whether the clip played to its end"),
    VoteColumn("stalls", "count", False, "times playback waited for data"),
    VoteColumn("stall_ms", "number", False, "milliseconds playback waited for data"),
    VoteColumn("focus_lost", "count", False, "times the window lost focus during the trial"),
    VoteColumn(
        "kind",
        "text",
        False,
        "trial (a pair of the design), mismatch (an "
        "appropriateness pair) or catch (an attention check, left out of every "
        "statistic); empty means trial",
    ),
    VoteColumn(
        "status",
        "text",
        False,
        "the participant's status when exported: started, finished, dropped, excluded or returned",
    ),
    VoteColumn(
        "excluded",
        "text",
        False,
        "why the participant is left out of the analysis "
        "(pilot, excluded, a failed catch trial, unfinished); empty: included",
    ),
    VoteColumn("prolific_id", "text", False, "the participant's Prolific ID, pseudonymised"),
)
#: Values of ``kind`` whose rows are analysed (the others are attention checks); mismatch rows
#: go to the appropriateness test (``app.analysis.appropriateness``), not the pair statistics.
ANALYSED_KINDS: tuple[str, ...] = ("", "trial", "mismatch")
VOTE_COLUMNS: tuple[str, ...] = tuple(c.name for c in COLUMN_SPECS)
REQUIRED_COLUMNS: tuple[str, ...] = tuple(c.name for c in COLUMN_SPECS if c.required)
OPTIONAL_COLUMNS: tuple[str, ...] = tuple(c.name for c in COLUMN_SPECS if not c.required)
_SPEC = {c.name: c for c in COLUMN_SPECS}
_MAX_PROBLEMS_KEPT = 20


@dataclass
class VotesTable:
    """Validated votes plus an honest account of what was left out.

    ``frame`` has every column of :data:`VOTE_COLUMNS` (absent optional ones are empty),
    text columns as ``str``, ``choice`` restricted to :data:`CHOICES`, counts as ``Int64``,
    ``response_ms`` as ``Float64``, times as UTC ``datetime64``. ``skipped`` counts the bad rows
    dropped under ``skip_bad_rows``; ``problems`` keeps the first of their one-line messages.
    """

    frame: pd.DataFrame
    skipped: int = 0
    problems: list[str] = field(default_factory=list)
    source: str | None = None

    def __len__(self) -> int:
        return len(self.frame)


def _read_fast(path: Path) -> tuple[list[str], pd.DataFrame] | None:
    """The C parser's reading when the file is plain (one line per row, equal field counts)."""
    try:
        raw = path.read_bytes()
        frame = pd.read_csv(
            io.BytesIO(raw),
            dtype=str,
            keep_default_na=False,
            skip_blank_lines=False,
            encoding="utf-8-sig",
        )
    except (OSError, ValueError, pd.errors.ParserError, UnicodeDecodeError):
        return None
    lines = raw.count(b"\n") + (0 if raw.endswith(b"\n") else 1)
    first = raw.decode("utf-8-sig", errors="replace").split("\n", 1)[0]
    header = next(csv.reader([first]), [])
    if b'"' in raw or len(frame) != lines - 1 or list(frame.columns) != header:
        return None  # quoting, blank lines, repeated names: the exact path counts lines itself
    commas = {row.count(b",") for row in raw.rstrip(b"\r\n").split(b"\n")}
    if commas != {len(header) - 1}:
        return None  # a row with too few or too many fields
    blank = (frame.apply(lambda c: c.str.strip()) == "").all(axis=1).to_numpy()
    if blank.any():
        return None
    return [str(c).strip() for c in frame.columns], frame


def _read_rows(path: Path) -> tuple[list[str], list[list[str]], list[int], list[InputError]]:
    """Header, rows padded to the header's width, their line numbers, and field-count errors."""
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
    return [h.strip() for h in header], rows, lines, count_errors


def _check_header(columns: Sequence[str], path: str | None, *, writing: bool = False) -> None:
    """Required columns present, none repeated; unknown ones are an error when writing only
    (a reader ignores them, so exports from other tools and newer versions still read)."""
    seen = [str(c) for c in columns]
    dup = sorted({c for c in seen if seen.count(c) > 1 and (writing or c in _SPEC)})
    missing = [c for c in REQUIRED_COLUMNS if c not in seen]
    unknown = [c for c in seen if c not in _SPEC] if writing else []
    if dup or missing or unknown:
        parts = []
        if missing:
            parts.append("missing " + ", ".join(missing))
        if unknown:
            parts.append("unknown " + ", ".join(repr(c) for c in unknown))
        if dup:
            parts.append("repeated " + ", ".join(dup))
        raise InputError(
            "header does not match the votes format: "
            + "; ".join(parts)
            + f" (columns: {', '.join(VOTE_COLUMNS)})",
            path=path,
            line=1,
        )


def _validate(raw: pd.DataFrame) -> tuple[pd.DataFrame, list[tuple[int, str, str]]]:
    """Typed frame and, per bad row, (row position, field, message); vectorised per column."""
    n = len(raw)
    bad: dict[int, tuple[str, str]] = {}
    out: dict[str, Any] = {}

    def flag(mask: np.ndarray, name: str, message_of) -> None:
        for pos in np.flatnonzero(mask):
            if pos not in bad:
                bad[int(pos)] = (name, message_of(int(pos)))

    for spec in COLUMN_SPECS:
        col = (
            raw[spec.name].astype(str).str.strip()
            if spec.name in raw
            else pd.Series([""] * n, index=raw.index, dtype=str)
        )
        empty = (col == "").to_numpy()
        if spec.required:
            flag(empty, spec.name, lambda _p: "missing value")
        if spec.kind == "choice":
            low = col.str.lower()
            wrong = ~low.isin(CHOICES).to_numpy() & ~empty
            flag(
                wrong,
                spec.name,
                lambda p, c=col: (
                    f"unknown choice {c.iloc[p]!r} (expected left, right or undecided)"
                ),
            )
            out[spec.name] = low.to_numpy(dtype=object)
        elif spec.kind == "text":
            out[spec.name] = col.to_numpy(dtype=object)
        elif spec.kind == "flag":
            low = col.str.lower()
            truth = low.map(FLAGS)
            wrong = (truth.isna().to_numpy()) & ~empty
            flag(wrong, spec.name, lambda p, c=col: f"expected true or false, got {c.iloc[p]!r}")
            out[spec.name] = truth.astype("boolean")
        elif spec.kind in ("count", "number"):
            num = pd.to_numeric(col.where(~empty), errors="coerce")
            fraction = (num != np.floor(num)).fillna(False) if spec.kind == "count" else False
            wrong = (~empty) & (num.isna() | (num < 0) | fraction).to_numpy()
            what = "a whole number >= 0" if spec.kind == "count" else "a number >= 0"
            flag(wrong, spec.name, lambda p, c=col, w=what: f"expected {w}, got {c.iloc[p]!r}")
            num = num.where(~wrong)  # the row is reported; keep the column typed
            out[spec.name] = num.astype("Int64" if spec.kind == "count" else "Float64")
        else:  # time
            when = pd.to_datetime(col.where(~empty), errors="coerce", utc=True, format="ISO8601")
            wrong = (~empty) & when.isna().to_numpy()
            flag(wrong, spec.name, lambda p, c=col: f"expected an ISO 8601 time, got {c.iloc[p]!r}")
            out[spec.name] = when
    frame = pd.DataFrame(
        {
            k: (v if isinstance(v, pd.Series) else pd.Series(v, index=raw.index))
            for k, v in out.items()
        }
    )
    problems = [(pos, f, m) for pos, (f, m) in sorted(bad.items())]
    return frame, problems


def read_votes(
    source: str | Path | pd.DataFrame,
    *,
    skip_bad_rows: bool = False,
    conditions: Sequence[str] | None = None,
) -> VotesTable:
    """Read and validate a votes CSV file (or an in-memory frame with the same columns).

    A bad row (unknown choice, missing participant, wrong field count, a value of the wrong
    type, a condition outside ``conditions`` when that list is given) raises one
    :class:`~app.errors.InputError` naming the file, line and field - or, with
    ``skip_bad_rows``, is dropped and counted in :attr:`VotesTable.skipped`. A header that does
    not match the format always raises.

    >>> t = read_votes(pd.DataFrame({"participant": ["p1"], "clip": ["s2"], "left": ["a"],
    ...                              "right": ["b"], "choice": ["Left"]}))
    >>> t.frame.loc[0, "choice"], t.skipped
    ('left', 0)
    """
    if isinstance(source, pd.DataFrame):
        path = None
        _check_header(list(source.columns), None)
        raw = source.astype(object).where(source.notna(), "")
        lines = list(range(2, len(raw) + 2))
        count_errors: list[InputError] = []
    else:
        path = str(source)
        fast = _read_fast(Path(source))
        if fast is not None:
            header, raw = fast
            raw.columns = header
            _check_header(header, path)
            lines, count_errors = list(range(2, len(raw) + 2)), []
        else:
            header, rows, lines, count_errors = _read_rows(Path(source))
            _check_header(header, path)
            raw = (
                pd.DataFrame(rows, columns=header, dtype=object)
                if rows
                else pd.DataFrame({h: pd.Series([], dtype=object) for h in header})
            )
    raw = raw.loc[:, [c for c in raw.columns if c in _SPEC]]  # extra columns are ignored
    frame, problems = _validate(raw.reset_index(drop=True))
    line_arr = np.abs(np.asarray(lines, dtype=np.int64))
    messages = {
        int(pos): InputError(m, path=path, line=int(line_arr[pos]), field=f)
        for pos, f, m in problems
    }
    known_bad = [i for i, ln in enumerate(lines) if ln < 0]
    for i, msg in zip(known_bad, count_errors, strict=True):
        messages[i] = msg
    if conditions is not None:
        allowed = set(conditions)
        for name in ("left", "right"):
            outside = ~frame[name].isin(allowed).to_numpy()
            for pos in np.flatnonzero(outside):
                messages.setdefault(
                    int(pos),
                    InputError(
                        f"unknown condition {frame[name].iloc[pos]!r} (expected one of "
                        f"{', '.join(conditions)})",
                        path=path,
                        line=int(line_arr[pos]),
                        field=name,
                    ),
                )
    if messages and not skip_bad_rows:
        first = messages[min(messages)]
        more = (
            f" (and {len(messages) - 1} more bad rows; --skip-bad-rows drops them)"
            if len(messages) > 1
            else ""
        )
        raise InputError(first.message + more, path=first.path, line=first.line, field=first.field)
    keep = np.ones(len(frame), dtype=bool)
    keep[list(messages)] = False
    ordered = [str(messages[k]) for k in sorted(messages)]
    return VotesTable(
        frame[keep].reset_index(drop=True),
        skipped=len(messages),
        problems=ordered[:_MAX_PROBLEMS_KEPT],
        source=path,
    )


def _column_text(values: pd.Series, kind: str) -> list[str]:
    """One column as CSV text, vectorised; missing values become empty fields."""
    missing = values.isna().to_numpy()
    if kind == "time":
        naive = values.dt.tz_convert("UTC").dt.tz_localize(None).to_numpy()
        micro = pd.Series(np.datetime_as_string(naive.astype("datetime64[us]"), unit="us"))
        # whole seconds always shown; the fraction only as long as it needs to be
        text = micro.str.replace(r"\.?0+$", "", regex=True) + "Z"
    elif kind == "count":
        text = values.astype("string").fillna("")
    elif kind == "flag":
        text = values.map({True: "true", False: "false"}).astype(object)
    elif kind == "number":
        num = values.astype(float).to_numpy()
        whole = np.isfinite(num) & (num == np.round(num)) & (np.abs(num) < 2**53)
        text = pd.Series(
            np.where(
                whole, np.round(np.nan_to_num(num)).astype(np.int64).astype(str), num.astype(str)
            ),
            dtype=object,
        )
    else:
        text = values.astype(str)
    return np.where(missing, "", text.to_numpy(dtype=object)).tolist()


def write_votes_csv(
    rows: Iterable[Mapping[str, Any]] | pd.DataFrame | VotesTable,
    path_or_file: str | Path | IO[str],
) -> int:
    """Write votes in the one CSV format :func:`read_votes` reads; returns the number written.

    ``rows`` are mappings with at least the required columns (extra keys are an error, absent
    optional ones are written empty), a frame, or a :class:`VotesTable`. The rows are validated
    first with the reader's rules, so an invalid vote is never exported.
    """
    if isinstance(rows, VotesTable):
        frame = rows.frame
    else:
        frame = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(list(rows))
        if frame.empty and not len(frame.columns):
            frame = pd.DataFrame(columns=list(REQUIRED_COLUMNS))
        _check_header(list(frame.columns), None, writing=True)
        frame = read_votes(frame).frame
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(VOTE_COLUMNS)
    columns = [_column_text(frame[name], _SPEC[name].kind) for name in VOTE_COLUMNS]
    writer.writerows(zip(*columns, strict=True))
    if isinstance(path_or_file, str | Path):
        Path(path_or_file).write_text(buffer.getvalue(), encoding="utf-8")
    else:
        path_or_file.write(buffer.getvalue())
    return len(frame)
