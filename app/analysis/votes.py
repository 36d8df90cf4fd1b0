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

from app.analysis.csv_blocks import NotPlain, arrow_blocks, exact_rows, read_header
from app.analysis.vote_frame import give_back_freed_memory, join_columns
from app.analysis.vote_values import TypedBlock, VoteColumn, type_block, without_bad_rows
from app.errors import InputError
from app.trials.participation import PARTICIPANT_STATUSES
from app.trials.rules import CHOICES as CHOICES  # the choice column's values, part of the schema

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


def _frame(blocks: list[TypedBlock]) -> pd.DataFrame:
    """The kept rows of every block as the typed frame of :class:`VotesTable`."""
    return join_columns([b.values for b in blocks], [(c.name, c.kind) for c in COLUMN_SPECS])


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
) -> Iterator[TypedBlock]:
    """Typed blocks of the source; :data:`_RESTART` when the block reader gives up."""
    kw: dict[str, Any] = {"path": path, "conditions": conditions}
    if isinstance(source, pd.DataFrame):
        _check_header([str(c) for c in source.columns], None)
        columns = _frame_columns(source)
        lines = np.arange(2, len(source) + 2, dtype=np.int64)
        yield type_block(columns, lines, COLUMN_SPECS, strip=True, drop_blank=False, **kw)
        return
    file = Path(source)
    head = read_header(file)
    if head is not None:
        _check_header(head[0], path)
        try:
            for columns, lines, strip in arrow_blocks(file, head[0], _TIMES):
                yield type_block(columns, lines, COLUMN_SPECS, strip=strip, **kw)
            return
        except NotPlain:
            pass  # the caller drops what it has and reads again below
        yield _RESTART
    header, (columns, lines, _), count_errors = exact_rows(file)
    _check_header(header, path)
    known = np.flatnonzero(lines < 0)
    errors = dict(zip(known.tolist(), count_errors, strict=True))
    yield type_block(columns, lines, COLUMN_SPECS, strip=True, known=errors, **kw)


_RESTART = TypedBlock({}, np.zeros(0, np.int64), {}, np.zeros(0, bool))


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
    kept: list[TypedBlock] = []
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
            kept.append(without_bad_rows(block))
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
