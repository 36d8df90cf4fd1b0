"""The rules of the votes table's values (:mod:`app.analysis.votes`), per kind of column: a
block of raw columns typed and checked, each row's problem named.

Every rule runs once per distinct value of a column, not once per row: text columns stay
codes into their distinct values, choices codes into :data:`~app.trials.rules.CHOICES`;
counts, numbers and times that Arrow's parsers read (:mod:`app.analysis.csv_blocks`) skip the
full rule, which names what is wrong with a value it refuses. The typed blocks are joined into
the frame by :mod:`app.analysis.vote_frame`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc

from app.analysis.csv_blocks import NotPlain, quoted_or_nul
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


@dataclass
class TypedBlock:
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


def type_block(
    columns: Mapping[str, np.ndarray],
    lines: np.ndarray,
    specs: Sequence[VoteColumn],
    *,
    strip: bool,
    path: str | None,
    conditions: Sequence[str] | None,
    drop_blank: bool = True,
    known: Mapping[int, InputError] | None = None,
) -> TypedBlock:
    """Type and check one block of raw columns (object arrays of ``str``, one per header name)
    as the columns ``specs`` (:data:`app.analysis.votes.COLUMN_SPECS`) describe them; a
    column the specs do not name is ignored, one they name but the block lacks is empty.

    A row's problem is that of its first bad column in ``specs`` order, else a
    condition outside ``conditions`` (left before right); ``known`` (row -> error, e.g. a wrong
    field count) wins over both. Blank rows (every field empty) are no votes when
    ``drop_blank`` (files); in a frame they are rows like any other.
    """
    n, lines = len(lines), np.abs(lines)
    kinds = {spec.name: spec.kind for spec in specs}
    distinct = {name: _distinct(raw, strip, kinds.get(name, "")) for name, raw in columns.items()}
    blank = np.ones(n, dtype=bool)
    for codes, values_of in distinct.values():
        blank &= _empty(values_of)[codes]
    problems: dict[int, InputError] = {}
    outside: dict[int, InputError] = {}
    values: dict[str, Any] = {}
    for spec in specs:
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
    return TypedBlock(values, lines, problems, blank)


def _absent(spec: VoteColumn, n: int) -> Any:
    """An optional column the file does not have: every value empty."""
    if spec.kind == "time":
        return np.full(n, np.datetime64("NaT"), dtype="datetime64[us]")
    empty = np.array([""], dtype=object) if spec.kind == "text" else np.array([np.nan])
    return np.zeros(n, dtype=np.uint8), empty


def without_bad_rows(block: TypedBlock) -> TypedBlock:
    """The block's values without its bad and blank rows (all the frame needs of it)."""
    keep = ~block.blank
    keep[list(block.problems)] = False
    values = block.values
    if not keep.all():
        values = {
            k: (v[0][keep], v[1]) if isinstance(v, tuple) else v[keep] for k, v in values.items()
        }
    return TypedBlock(values, _NONE.lines, {}, _NONE.blank)


#: A block with no rows: what a kept block carries for the lines and blank rows it no longer needs.
_NONE = TypedBlock({}, np.zeros(0, np.int64), {}, np.zeros(0, bool))
