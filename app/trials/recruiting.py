"""The study file's ``[prolific]`` table: what a study asks of Prolific when facepair publishes
it (``facepair prolific publish``, ``docs/reference/prolific.md``).

The keys map onto Prolific's ``CreateStudy`` (API v1, ``POST /api/v1/studies/``): ``reward`` is
sent as it is, in the minor units of the researcher's currency (pence, cents: the API's own
unit); ``places`` is ``total_available_places``; ``minutes`` and ``max_minutes`` are
``estimated_completion_time`` and ``maximum_allowed_time``; ``devices``, ``peripherals`` and
``filters`` are ``device_compatibility``, ``peripheral_requirements`` and ``filters`` (select
filters by their values, range filters by a lower and upper bound). ``currency`` guards against
the wrong currency (peers paid bonuses in pounds meaning dollars): the workspace's currency must
be the one named. ``bonus_per_check`` is the bonus rule, in the study currency's major unit
(the bonus CSV's unit).

>>> from app.trials.fields import FieldReader
>>> from pathlib import Path
>>> spec = read_recruiting(FieldReader("study.toml", Path(".")),
...                        {"reward": 150, "places": 20, "minutes": 8})
>>> spec.reward, spec.places, spec.devices
(150, 20, ('desktop', 'tablet', 'mobile'))
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from typing import Any, Final

from app.trials.fields import FieldReader, describe

DEVICES: Final = ("desktop", "tablet", "mobile")
"""Prolific's ``device_compatibility`` values."""

PERIPHERALS: Final = ("audio", "camera", "download", "microphone")
"""Prolific's ``peripheral_requirements`` values."""

RECRUITING_KEYS: Final = (
    "name",
    "description",
    "reward",
    "places",
    "minutes",
    "max_minutes",
    "devices",
    "peripherals",
    "filters",
    "currency",
    "workspace",
    "project",
    "bonus_per_check",
)

#: Bounds that keep a typing slip (a reward of 150000 meaning 1.50) from reaching Prolific.
MAX_REWARD: Final = 100_000
MAX_PLACES: Final = 50_000
MAX_MINUTES: Final = 24 * 60
MAX_BONUS: Final = Decimal("100")
MAX_FILTERS: Final = 40


def minimum_allowed_minutes(minutes: int) -> int:
    """The shortest ``maximum_allowed_time`` Prolific accepts for an ``estimated_completion_time``
    of ``minutes``: two minutes plus twice the estimate plus twice its square root (Prolific's
    ``CreateStudy`` schema), rounded up.

    >>> minimum_allowed_minutes(9)
    26
    """
    return math.ceil(2 + 2 * minutes + 2 * math.sqrt(minutes))


def money(text: str) -> Decimal | None:
    """A positive amount with at most two decimals (``"1.50"``), or None when ``text`` is not
    one. Amounts stay decimal: a bonus of 0.10 is never 0.1000000000000000055.

    >>> money("1.5"), money("0.10"), money("1.234"), money("-1"), money("nan")
    (Decimal('1.50'), Decimal('0.10'), None, None, None)
    """
    try:
        value = Decimal(text.strip())
    except (InvalidOperation, ValueError, AttributeError):
        return None
    if not value.is_finite() or value <= 0 or value.adjusted() > 12:
        return None
    if value != value.quantize(Decimal("0.01")):
        return None
    return value.quantize(Decimal("0.01"))


@dataclass(frozen=True, slots=True)
class RecruitingSpec:
    """The validated ``[prolific]`` table (see the module docstring for each key)."""

    reward: int
    places: int
    minutes: int
    name: str | None = None
    description: str | None = None
    max_minutes: int | None = None
    devices: tuple[str, ...] = DEVICES
    peripherals: tuple[str, ...] = ("audio",)
    filters: tuple[Mapping[str, Any], ...] = field(default_factory=tuple)
    currency: str | None = None
    workspace: str | None = None
    project: str | None = None
    bonus_per_check: Decimal | None = None

    def to_dict(self) -> dict[str, Any]:
        """The table as a study file writes it (``read_recruiting`` reads it back equal)."""
        out: dict[str, Any] = {}
        for key in ("name", "description"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        out |= {"reward": self.reward, "places": self.places, "minutes": self.minutes}
        if self.max_minutes is not None:
            out["max_minutes"] = self.max_minutes
        out["devices"] = list(self.devices)
        out["peripherals"] = list(self.peripherals)
        if self.filters:
            out["filters"] = [dict(f) for f in self.filters]
        for key in ("currency", "workspace", "project"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        if self.bonus_per_check is not None:
            out["bonus_per_check"] = str(self.bonus_per_check)
        return out


def read_recruiting(reader: FieldReader, data: Any, name: str = "prolific") -> RecruitingSpec:
    """Validate a ``[prolific]`` table (``data``) with ``reader``; every mistake is one
    :class:`~app.errors.InputError` naming ``prolific.<key>``."""
    table = reader.table(data, name, RECRUITING_KEYS)
    text = {
        key: reader.text(table, key, f"{name}.{key}", None, nonempty=True)
        for key in ("name", "description")
    }
    for key, value in text.items():
        if value is not None and len(value) > 5000:
            raise reader.error(f"{name}.{key}", f"at most 5000 characters, got {len(value)}")
    required = {
        "reward": "the reward in minor units (150 = 1.50)",
        "places": "how many participants",
        "minutes": "the estimated duration in minutes",
    }
    for key, meaning in required.items():
        if key not in table:
            raise reader.error(f"{name}.{key}", f"missing (required): {meaning}")
    reward = reader.integer(table, "reward", f"{name}.reward", None, 1, MAX_REWARD)
    places = reader.integer(table, "places", f"{name}.places", None, 1, MAX_PLACES)
    minutes = reader.integer(table, "minutes", f"{name}.minutes", None, 1, MAX_MINUTES)
    max_minutes = None
    if "max_minutes" in table:
        max_minutes = reader.integer(
            table, "max_minutes", f"{name}.max_minutes", None, 1, 10 * MAX_MINUTES
        )
        if max_minutes < minimum_allowed_minutes(minutes):
            raise reader.error(
                f"{name}.max_minutes",
                f"Prolific allows no less than {minimum_allowed_minutes(minutes)} for "
                f"minutes = {minutes}, got {max_minutes}",
            )
    devices = _choices(reader, table, "devices", f"{name}.devices", DEVICES, DEVICES)
    if not devices:
        raise reader.error(f"{name}.devices", "name at least one device")
    peripherals = _choices(
        reader, table, "peripherals", f"{name}.peripherals", PERIPHERALS, ("audio",)
    )
    filters = _filters(reader, table.get("filters", []), f"{name}.filters")
    currency = reader.text(table, "currency", f"{name}.currency", None)
    if currency is not None and not (
        len(currency) == 3 and currency.isascii() and currency.isalpha()
    ):
        raise reader.error(
            f"{name}.currency", f"expected a currency code such as GBP, got {currency!r}"
        )
    ids = {
        key: reader.text(table, key, f"{name}.{key}", None, nonempty=True)
        for key in ("workspace", "project")
    }
    for key, value in ids.items():
        if value is not None and (len(value) > 64 or not value.isascii() or not value.isalnum()):
            raise reader.error(f"{name}.{key}", f"expected a Prolific id, got {value!r}")
    bonus = None
    if "bonus_per_check" in table:
        raw = table["bonus_per_check"]
        if isinstance(raw, bool) or not isinstance(raw, str | int | float):
            raise reader.error(
                f"{name}.bonus_per_check", f'expected an amount such as "0.10", got {describe(raw)}'
            )
        bonus = money(str(raw))
        if bonus is None or bonus > MAX_BONUS:
            raise reader.error(
                f"{name}.bonus_per_check",
                f"expected an amount above 0 and at most {MAX_BONUS} with at most two "
                f"decimals, got {describe(raw)}",
            )
    return RecruitingSpec(
        reward=reward,
        places=places,
        minutes=minutes,
        name=text["name"],
        description=text["description"],
        max_minutes=max_minutes,
        devices=devices,
        peripherals=peripherals,
        filters=filters,
        currency=currency.upper() if currency else None,
        workspace=ids["workspace"],
        project=ids["project"],
        bonus_per_check=bonus,
    )


def _choices(
    reader: FieldReader,
    table: Mapping[str, Any],
    key: str,
    name: str,
    options: tuple[str, ...],
    default: tuple[str, ...],
) -> tuple[str, ...]:
    values = reader.get(table, key, name, (list,), "an array of strings", list(default))
    out: list[str] = []
    for value in values:
        if not isinstance(value, str) or value not in options:
            raise reader.error(
                name, f"expected values among {', '.join(options)}, got {describe(value)}"
            )
        if value in out:
            raise reader.error(name, f"names {value!r} twice")
        out.append(value)
    return tuple(out)


def _filters(reader: FieldReader, items: Any, name: str) -> tuple[Mapping[str, Any], ...]:
    """Prolific's select and range filters: ``{filter_id, selected_values}`` or
    ``{filter_id, selected_range = {lower, upper}}``."""
    if not isinstance(items, list):
        raise reader.error(name, f"expected an array of tables, got {describe(items)}")
    if len(items) > MAX_FILTERS:
        raise reader.error(name, f"at most {MAX_FILTERS} filters, got {len(items)}")
    out: list[Mapping[str, Any]] = []
    for index, item in enumerate(items):
        where = f"{name}[{index}]"
        item = reader.table(item, where, ("filter_id", "selected_values", "selected_range"))
        filter_id = reader.text(item, "filter_id", f"{where}.filter_id", nonempty=True)
        if len(filter_id) > 100:
            raise reader.error(f"{where}.filter_id", "at most 100 characters")
        if ("selected_values" in item) == ("selected_range" in item):
            raise reader.error(where, "give either selected_values or selected_range")
        if "selected_values" in item:
            values = reader.get(
                item, "selected_values", f"{where}.selected_values", (list,), "an array"
            )
            if not values or not all(isinstance(v, str) and v for v in values):
                raise reader.error(
                    f"{where}.selected_values", "expected a non-empty array of strings"
                )
            out.append({"filter_id": filter_id, "selected_values": list(values)})
            continue
        bounds = reader.table(item["selected_range"], f"{where}.selected_range", ("lower", "upper"))
        if not bounds:
            raise reader.error(f"{where}.selected_range", "give lower, upper or both")
        for key, value in bounds.items():
            if isinstance(value, bool) or not isinstance(value, int | float | str):
                raise reader.error(
                    f"{where}.selected_range.{key}",
                    f"expected a number or a date, got {describe(value)}",
                )
            if isinstance(value, float) and not math.isfinite(value):
                raise reader.error(f"{where}.selected_range.{key}", "expected a finite number")
        out.append({"filter_id": filter_id, "selected_range": dict(bounds)})
    return tuple(out)
