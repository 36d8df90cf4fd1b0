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
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc

from app.analysis.csv_blocks import NotPlain, arrow_blocks, exact_rows, quoted_or_nul, read_header
from app.analysis.vote_frame import give_back_freed_memory, join_columns
from app.errors import InputError
from app.trials.participation import PARTICIPANT_STATUSES
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
        "the participant's status when exported: " + ", ".join(PARTICIPANT_STATUSES),
    ),
    VoteColumn(
        "excluded",
        "text",
        False,
        "why the participant is left out of the analysis "
        "(pilot, excluded, returned, failed attention checks, a failed catch trial, "
        "unfinished); empty: included",
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
#: One value per row: read as text, never hashed into distinct values.
_TIMES = frozenset(c.name for c in COLUMN_SPECS if c.kind == "time")
_MAX_PROBLEMS_KEPT = 20


@dataclass
class VotesTable:
    """Validated votes plus an honest account of what was left out.

    ``frame`` has every column of :data:`VOTE_COLUMNS` (absent optional ones are empty),
    text columns as categoricals of stripped ``str`` (categories sorted, only those used),
    ``choice`` a categorical of :data:`CHOICES`, counts as ``Int64``, numbers as ``Float64``,
    flags as ``boolean``, times as UTC ``datetime64[us]``. ``skipped`` counts the bad rows
    dropped under ``skip_bad_rows``; ``problems`` keeps the first of their one-line messages.
    """

    frame: pd.DataFrame
    skipped: int = 0
    problems: list[str] = field(default_factory=list)
    source: str | None = None

    def __len__(self) -> int:
        return len(self.frame)


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


@dataclass
class _Block:
    """One block of rows, typed and checked: per column its values (text: codes and distinct
    values; choice: codes into CHOICES; the others: a float or datetime64 array), the line of
    each row, the one-line message of each bad row and which rows are blank."""

    values: dict[str, Any]
    lines: np.ndarray
    problems: dict[int, InputError]
    blank: np.ndarray


def _distinct(
    values: np.ndarray | tuple[np.ndarray, pa.Array] | pa.Array, strip: bool, kind: str
) -> tuple[np.ndarray, Any]:
    """Codes and distinct (stripped) values of one column of a ``kind`` (``""`` for a column
    the format does not know): every rule below runs once per distinct value, not once per row.

    ``values`` is an object array of ``str``, or Arrow's codes and distinct values, or an Arrow
    string array of every row. Times are not hashed (each row is its own value); those that
    Arrow gives stay Arrow arrays, as do Arrow's distinct numbers: their rules try Arrow's
    parsers first and strip only what those cannot read. Every other column becomes an object
    array of ``str``.
    """
    if isinstance(values, pa.Array):
        return np.arange(len(values), dtype=np.int32), values
    if isinstance(values, tuple):
        codes, uniques = values
        if not strip and kind in ("count", "number"):
            return codes, uniques
        uniques = uniques.to_numpy(zero_copy_only=False).astype(object, copy=False)
    else:
        n = len(values)
        if n and (values == "").all():  # an optional column the export leaves empty
            return np.zeros(n, dtype=np.int32), np.array([""], dtype=object)
        if kind == "time":
            codes, uniques = np.arange(n, dtype=np.int32), values
        else:
            found, uniques = pd.factorize(values)
            codes, uniques = found.astype(np.int32), np.asarray(uniques, dtype=object)
    if strip and uniques.size:
        stripped = np.empty(uniques.size, dtype=object)
        stripped[:] = [u.strip() for u in uniques]
        if kind == "time":
            return codes, stripped
        merged, uniques = pd.factorize(stripped)
        codes, uniques = merged[codes].astype(np.int32), np.asarray(uniques, dtype=object)
    return codes, uniques


def _empty(distinct: np.ndarray | pa.Array) -> np.ndarray:
    """Which distinct values are empty."""
    if isinstance(distinct, pa.Array):
        return pc.equal(distinct, "").to_numpy(zero_copy_only=False)
    return distinct == ""


def _without_empty(text: pa.Array) -> pa.Array:
    return pc.if_else(pc.equal(text, ""), pa.scalar(None, pa.string()), text)


def _arrow_times(text: pa.Array) -> np.ndarray | None:
    """ISO 8601 times read by Arrow's parser as UTC ``datetime64[us]`` (empty: NaT), or None
    when any value needs the full rule (space around it, no offset, a bad value)."""
    try:
        when = pc.cast(_without_empty(text), pa.timestamp("us", tz="UTC"))
    except pa.ArrowException:
        return None
    return when.cast(pa.int64()).to_numpy(zero_copy_only=False).astype("datetime64[us]")


def _arrow_numbers(text: pa.Array, kind: str) -> np.ndarray | None:
    """Distinct numbers read by Arrow's parser (empty: NaN), or None when any value needs the
    full rule, which names it (not a number, negative, not whole for a count, space around)."""
    try:
        value = pc.cast(_without_empty(text), pa.float64()).to_numpy(zero_copy_only=False)
    except pa.ArrowException:
        return None
    given = value[~_empty(text)]
    good = np.isfinite(given) & (given >= 0)
    if kind == "count":
        good &= (given == np.floor(given)) & (given < 2.0**53)
    return value if good.all() else None


def _typed(spec: VoteColumn, distinct: np.ndarray | pa.Array) -> tuple[Any, dict[int, str]]:
    """Typed value of each distinct value of one column, and the problem of the bad ones."""
    if not spec.required and _empty(distinct).all():  # a column no row fills: no rule to run
        if spec.kind == "text":
            return distinct, {}
        return np.full(len(distinct), np.nan if spec.kind != "time" else np.datetime64("NaT")), {}
    if isinstance(distinct, pa.Array):  # times or distinct numbers as Arrow read them
        fast = (
            _arrow_times(distinct) if spec.kind == "time" else _arrow_numbers(distinct, spec.kind)
        )
        if fast is not None:
            return fast, {}
        if spec.kind == "time" and quoted_or_nul(distinct):
            raise NotPlain  # Arrow read it with quoting off; the exact reader unquotes it
        distinct = np.array([v.strip() for v in distinct.to_pylist()], dtype=object)
    empty = distinct == ""
    bad: np.ndarray = np.zeros(distinct.size, dtype=bool)
    if spec.kind == "choice":
        low = [d.lower() for d in distinct]
        value: Any = np.array([CHOICES.index(x) if x in CHOICES else -1 for x in low], np.int8)
        bad = (value < 0) & ~empty
        what = "unknown choice {!r} (expected left, right or undecided)"
    elif spec.kind == "text":
        value, what = distinct, ""
    elif spec.kind == "flag":
        low = [d.lower() for d in distinct]
        value = np.array([float(FLAGS[x]) if x in FLAGS else np.nan for x in low])
        bad, what = np.isnan(value) & ~empty, "expected true or false, got {!r}"
    elif spec.kind in ("count", "number"):
        value = pd.to_numeric(
            pd.Series(distinct, dtype=object).where(~empty), errors="coerce"
        ).to_numpy(dtype=float, copy=True)
        with np.errstate(invalid="ignore"):
            wrong = ~np.isfinite(value) | (value < 0)
            if spec.kind == "count":  # and exact in the Int64 it becomes
                wrong |= (value != np.floor(value)) | (value >= 2.0**53)
        bad = wrong & ~empty
        value[bad] = np.nan
        what = "expected " + ("a whole number >= 0" if spec.kind == "count" else "a number >= 0")
        what += ", got {!r}"
    else:  # time
        text = pd.Series(distinct, dtype=object).where(~empty)
        when = pd.to_datetime(text, errors="coerce", utc=True, format="ISO8601")
        value = when.dt.tz_localize(None).to_numpy().astype("datetime64[us]")
        bad, what = np.isnat(value) & ~empty, "expected an ISO 8601 time, got {!r}"
    flagged = np.flatnonzero(bad | (empty & spec.required))
    problems = {
        int(k): "missing value" if spec.required and empty[k] else what.format(distinct[k])
        for k in flagged
    }
    return value, problems


def _type_block(
    columns: Mapping[str, np.ndarray],
    lines: np.ndarray,
    *,
    strip: bool,
    path: str | None,
    conditions: Sequence[str] | None,
    drop_blank: bool = True,
    known: Mapping[int, InputError] | None = None,
) -> _Block:
    """Type and check one block of raw columns (object arrays of ``str``, one per header name).

    A row's problem is that of its first bad column in :data:`COLUMN_SPECS` order, else a
    condition outside ``conditions`` (left before right); ``known`` (row -> error, e.g. a wrong
    field count) wins over both. Blank rows (every field empty) are no votes when
    ``drop_blank`` (files); in a frame they are rows like any other.
    """
    n, lines = len(lines), np.abs(lines)
    distinct = {
        name: _distinct(raw, strip, _SPEC[name].kind if name in _SPEC else "")
        for name, raw in columns.items()
    }
    blank = np.ones(n, dtype=bool)
    for codes, values_of in distinct.values():
        blank &= _empty(values_of)[codes]
    problems: dict[int, InputError] = {}
    outside: dict[int, InputError] = {}
    values: dict[str, Any] = {}
    for spec in COLUMN_SPECS:
        if spec.name not in distinct:
            values[spec.name] = _absent(spec, n)
            continue
        codes, values_of = distinct[spec.name]
        value, messages = _typed(spec, values_of)
        bad = np.zeros(len(values_of), dtype=bool)
        bad[list(messages)] = True
        for pos in np.flatnonzero(bad[codes]).tolist() if messages else []:
            if pos not in problems:
                message = messages[int(codes[pos])]
                problems[pos] = InputError(
                    message, path=path, line=int(lines[pos]), field=spec.name
                )
        # kept as codes and one value per code (times: one per row) until the frame is built
        small = codes.astype(np.min_scalar_type(max(len(values_of) - 1, 0)))
        values[spec.name] = value[codes] if spec.kind == "time" else (small, value)
        if spec.kind != "text":
            continue
        if conditions is not None and spec.name in ("left", "right"):
            unknown = ~np.isin(values_of, list(conditions)) & (values_of != "")
            expected = ", ".join(conditions)
            for pos in np.flatnonzero(unknown[codes]).tolist():
                outside.setdefault(
                    pos,
                    InputError(
                        f"unknown condition {values_of[codes[pos]]!r} (expected one of {expected})",
                        path=path,
                        line=int(lines[pos]),
                        field=spec.name,
                    ),
                )
    for pos, error in outside.items():
        problems.setdefault(pos, error)
    problems.update(known or {})
    if drop_blank:  # a blank line carries no vote, so nothing is wrong with it
        problems = {pos: e for pos, e in problems.items() if not blank[pos]}
    else:
        blank[:] = False
    return _Block(values, lines, problems, blank)


def _absent(spec: VoteColumn, n: int) -> Any:
    """An optional column the file does not have: every value empty."""
    if spec.kind == "time":
        return np.full(n, np.datetime64("NaT"), dtype="datetime64[us]")
    empty = np.array([""], dtype=object) if spec.kind == "text" else np.array([np.nan])
    return np.zeros(n, dtype=np.uint8), empty


def _frame(blocks: list[_Block]) -> pd.DataFrame:
    """The kept rows of every block as the typed frame of :class:`VotesTable`."""
    return join_columns([b.values for b in blocks], [(c.name, c.kind) for c in COLUMN_SPECS])


def _keep(block: _Block) -> _Block:
    """The block's values without its bad and blank rows (all the frame needs of it)."""
    keep = ~block.blank
    keep[list(block.problems)] = False
    values = block.values
    if not keep.all():
        values = {
            k: (v[0][keep], v[1]) if isinstance(v, tuple) else v[keep] for k, v in values.items()
        }
    return _Block(values, _NONE.lines, {}, _NONE.blank)


def _frame_columns(source: pd.DataFrame) -> dict[str, np.ndarray]:
    """An in-memory frame's columns as object arrays of ``str`` (missing values empty)."""
    out = {}
    for name in source.columns:
        if name in out:
            continue
        col = source[name]
        col = col.iloc[:, 0] if isinstance(col, pd.DataFrame) else col
        values = np.empty(len(col), dtype=object)
        values[:] = [
            v if isinstance(v, str) else "" if v is None or v is pd.NA or v != v else str(v)
            for v in col.to_numpy(dtype=object)
        ]
        out[str(name)] = values
    return out


def _blocks(
    source: str | Path | pd.DataFrame, path: str | None, conditions: Sequence[str] | None
) -> Iterator[_Block]:
    """Typed blocks of the source; :data:`_RESTART` when the block reader gives up."""
    kw: dict[str, Any] = {"path": path, "conditions": conditions}
    if isinstance(source, pd.DataFrame):
        _check_header([str(c) for c in source.columns], None)
        columns = _frame_columns(source)
        lines = np.arange(2, len(source) + 2, dtype=np.int64)
        yield _type_block(columns, lines, strip=True, drop_blank=False, **kw)
        return
    file = Path(source)
    head = read_header(file)
    if head is not None:
        _check_header(head[0], path)
        try:
            for columns, lines, strip in arrow_blocks(file, head[0], _TIMES):
                yield _type_block(columns, lines, strip=strip, **kw)
            return
        except NotPlain:
            pass  # the caller drops what it has and reads again below
        yield _RESTART
    header, (columns, lines, _), count_errors = exact_rows(file)
    _check_header(header, path)
    known = np.flatnonzero(lines < 0)
    errors = dict(zip(known.tolist(), count_errors, strict=True))
    yield _type_block(columns, lines, strip=True, known=errors, **kw)


_RESTART = _Block({}, np.zeros(0, np.int64), {}, np.zeros(0, bool))
_NONE = _Block({}, np.zeros(0, np.int64), {}, np.zeros(0, bool))


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

    A plain file (no quotes, every line with the header's number of fields) is read a block at
    a time by Arrow's CSV reader (:mod:`app.analysis.csv_blocks`), text columns dictionary-encoded
    as they are parsed, and each block typed at once: every rule runs on the distinct values of
    a column, times go through Arrow's ISO 8601 parser (the values it cannot read through the
    full rule), text columns become categoricals, so no Python string per row is ever made.
    Any other file is read whole by the csv module with the same rules and messages.

    >>> t = read_votes(pd.DataFrame({"participant": ["p1"], "clip": ["s2"], "left": ["a"],
    ...                              "right": ["b"], "choice": ["Left"]}))
    >>> t.frame.loc[0, "choice"], t.skipped
    ('left', 0)
    """
    path = None if isinstance(source, pd.DataFrame) else str(source)
    kept: list[_Block] = []
    first: InputError | None = None
    skipped, problems = 0, list[str]()
    for block in _blocks(source, path, conditions):
        if block is _RESTART:
            kept, first, skipped, problems = [], None, 0, []
            continue
        if block.problems:
            ordered = [block.problems[k] for k in sorted(block.problems)]
            first = ordered[0] if first is None else first
            skipped += len(ordered)
            problems.extend(str(e) for e in ordered[: _MAX_PROBLEMS_KEPT - len(problems)])
        if skip_bad_rows or first is None:
            kept.append(_keep(block))
    if first is not None and not skip_bad_rows:
        more = (
            f" (and {skipped - 1} more bad rows; --skip-bad-rows drops them)" if skipped > 1 else ""
        )
        raise InputError(first.message + more, path=first.path, line=first.line, field=first.field)
    give_back_freed_memory()
    frame = _frame(kept)
    del kept
    give_back_freed_memory()
    return VotesTable(frame, skipped=skipped, problems=problems, source=path)


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
