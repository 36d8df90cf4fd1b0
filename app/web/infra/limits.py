"""What a value must be to fit its column: the one place input limits come from.

The limits are read from the column definitions in :mod:`app.web.models` (a ``String(64)`` holds
64 characters, an ``Integer`` 32 bits, a ``BigInteger`` 64 bits; no text column holds a NUL or a
lone surrogate, which PostgreSQL refuses) instead of being written by hand in each view. Two
uses:

* :func:`check` and :func:`fits` for a value about to be looked up or stored (a vote's fields,
  a token in a URL);
* :func:`guard_flush`, a ``before_flush`` hook that checks every row written through the
  session, so a value that cannot be stored is a clear :class:`~app.errors.InputError` naming
  the field, never a database error answered with 500.
"""

from __future__ import annotations

import json
import math
from typing import Any

import sqlalchemy as sa
from sqlalchemy import orm as so

from app.errors import InputError

INT32 = (-(2**31), 2**31 - 1)
INT64 = (-(2**63), 2**63 - 1)
#: Unbounded text columns (instructions, consent, study files) still hold at most this much.
MAX_TEXT = 1_000_000
#: Nesting of JSON columns (render settings, model settings).
MAX_JSON_DEPTH = 32


def field_name(column: sa.Column[Any]) -> str:
    """How errors name a column: its ``info["field"]`` (the study file's key) or its name."""
    return str(column.info.get("field", column.key))


def integer_range(column: sa.Column[Any]) -> tuple[int, int] | None:
    kind = column.type
    if isinstance(kind, sa.BigInteger):
        return INT64
    if isinstance(kind, sa.SmallInteger):
        return (-(2**15), 2**15 - 1)
    if isinstance(kind, sa.Integer):
        return INT32
    return None


def text_problem(value: str, max_length: int | None) -> str | None:
    """Why ``value`` cannot be stored as text of at most ``max_length`` characters, or None."""
    if max_length is not None and len(value) > max_length:
        return f"at most {max_length} characters, got {len(value)}"
    if "\x00" in value:
        return "must not contain a NUL character"
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return "must be valid Unicode text (no lone surrogates)"
    return None


def printable(value: str) -> str:
    """``value`` without control characters (for text the client sends without meaning it,
    such as its User-Agent header)."""
    return "".join(ch for ch in value if ch.isprintable())


def _json_problem(value: Any, depth: int = 0) -> str | None:
    if depth > MAX_JSON_DEPTH:
        return f"nested more than {MAX_JSON_DEPTH} levels"
    if isinstance(value, str):
        return text_problem(value, MAX_TEXT)
    if isinstance(value, float) and not math.isfinite(value):
        return "must not hold NaN or infinity"
    if (
        isinstance(value, int)
        and not isinstance(value, bool)
        and not (INT64[0] <= value <= INT64[1])
    ):
        return "holds an integer beyond 64 bits"
    if isinstance(value, dict):
        items = list(value.keys()) + list(value.values())
    elif isinstance(value, list | tuple):
        items = list(value)
    else:
        return None
    for item in items:
        problem = _json_problem(item, depth + 1)
        if problem:
            return problem
    return None


def problem(column: sa.Column[Any], value: Any) -> str | None:
    """Why ``value`` does not fit ``column``, or None (None always fits: NOT NULL is the
    schema's business, and the models' defaults fill it)."""
    if value is None:
        return None
    kind = column.type
    bounds = integer_range(column)
    if bounds is not None:
        if isinstance(value, bool) or not isinstance(value, int):
            return "expected a whole number"
        if not bounds[0] <= value <= bounds[1]:
            return f"expected a whole number from {bounds[0]} to {bounds[1]}, got {value}"
        return None
    if isinstance(kind, sa.JSON):
        found = _json_problem(value)
        if found is None:
            try:
                json.dumps(value, allow_nan=False)
            except (TypeError, ValueError) as exc:
                return f"cannot be stored as JSON: {exc}"
        return found
    if isinstance(kind, sa.String):  # Text is a String without a length
        if not isinstance(value, str):
            return "expected text"
        return text_problem(value, kind.length or MAX_TEXT)
    return None


def column_of(attribute: Any) -> sa.Column[Any]:
    """The column behind a mapped attribute (``Vote.plays``) or the column itself."""
    return attribute.property.columns[0] if hasattr(attribute, "property") else attribute


def check(column: Any, value: Any, field: str | None = None) -> Any:
    """``value`` if it fits ``column``; else :class:`InputError` naming the field."""
    column = column_of(column)
    found = problem(column, value)
    if found:
        raise InputError(found, field=field or field_name(column))
    return value


def fits(column: Any, value: Any) -> bool:
    """Whether ``value`` could be stored in (so looked up by) ``column``."""
    return problem(column_of(column), value) is None


def guard_flush(session: so.Session, _context: Any, _instances: Any) -> None:
    """``before_flush``: refuse any new or changed row holding a value its column cannot."""
    for obj in list(session.new) + list(session.dirty):
        state = sa.inspect(obj)
        for attr in state.mapper.column_attrs:
            if not (state.pending or attr.key in state.committed_state):
                continue  # unchanged since it was loaded
            value = state.dict.get(attr.key)
            for column in attr.columns:
                found = problem(column, value)
                if found:
                    raise InputError(found, field=field_name(column))


def install(session_factory: Any) -> None:
    """Attach :func:`guard_flush` to the application's sessions (once)."""
    if not sa.event.contains(session_factory, "before_flush", guard_flush):
        sa.event.listen(session_factory, "before_flush", guard_flush)
