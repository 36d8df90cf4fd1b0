"""Numbers as the JSON output holds them: Python int or float, never NaN or infinity (null)."""

from __future__ import annotations

from typing import Any

import numpy as np


def json_number(x: Any) -> Any:
    """A JSON-ready number: Python int/float, NaN and infinities as None.

    >>> json_number(np.int64(3)), json_number(np.float64("nan")), json_number(0.5)
    (3, None, 0.5)
    """
    if x is None:
        return None
    if isinstance(x, np.integer | int) and not isinstance(x, bool):
        return int(x)
    x = float(x)
    return x if np.isfinite(x) else None


def json_row(row: dict[str, Any]) -> dict[str, Any]:
    """A table row with its floats (alone or in lists) made JSON-ready by :func:`json_number`;
    other values as they are.

    >>> json_row({"name": "a", "p": float("nan"), "ci": [0.1, float("inf")], "df": 3})
    {'name': 'a', 'p': None, 'ci': [0.1, None], 'df': 3}
    """
    return {
        key: [json_number(v) for v in value]
        if isinstance(value, list)
        else json_number(value)
        if isinstance(value, float)
        else value
        for key, value in row.items()
    }
