"""The study file's ``[prolific]`` table: what it accepts, one line for every mistake, the same
table back from ``to_toml``, and (property-based) nothing but a one-line ``InputError``
whatever the table holds."""

from __future__ import annotations

import tomllib
from decimal import Decimal
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.trials.fields import FieldReader
from app.trials.recruiting import (
    RECRUITING_KEYS,
    minimum_allowed_minutes,
    money,
    read_recruiting,
)
from app.trials.studyfile import loads_study

BASE = """
title = "T"
question = "Q"
completion_code = "C1"

[[conditions]]
name = "none"
model = "none"

[[conditions]]
name = "random"
model = "random"

[[clips]]
name = "s1"
audio = "s1.wav"
"""


def _read(table: dict) -> object:
    return read_recruiting(FieldReader("study.toml", Path(".")), table)


def test_a_full_table_and_its_defaults():
    spec = loads_study(
        BASE
        + """
[prolific]
name = "Faces"
reward = 150
places = 30
minutes = 8
max_minutes = 30
devices = ["desktop"]
peripherals = []
currency = "eur"
bonus_per_check = 0.1
filters = [
  {filter_id = "current-country-of-residence", selected_values = ["1"]},
  {filter_id = "age", selected_range = {lower = 18, upper = 65}},
]
""",
        check_files=False,
    ).prolific
    assert spec.reward == 150 and spec.places == 30 and spec.max_minutes == 30
    assert spec.devices == ("desktop",) and spec.peripherals == () and spec.currency == "EUR"
    assert spec.bonus_per_check == Decimal("0.10")
    assert spec.filters[1] == {"filter_id": "age", "selected_range": {"lower": 18, "upper": 65}}
    plain = _read({"reward": 1, "places": 1, "minutes": 1})
    assert plain.devices == ("desktop", "tablet", "mobile") and plain.peripherals == ("audio",)
    assert loads_study(BASE, check_files=False).prolific is None


def test_the_table_survives_to_toml():
    text = BASE + '\n[prolific]\nreward = 90\nplaces = 2\nminutes = 3\nbonus_per_check = "0.25"\n'
    spec = loads_study(text, check_files=False)
    again = loads_study(spec.to_toml(), check_files=False)
    assert again.prolific == spec.prolific
    assert tomllib.loads(spec.to_toml())["prolific"]["bonus_per_check"] == "0.25"


@pytest.mark.parametrize(
    ("table", "message"),
    [
        (
            {"places": 1, "minutes": 1},
            "prolific.reward: missing (required): the reward in minor units",
        ),
        (
            {"reward": 1.5, "places": 1, "minutes": 1},
            "prolific.reward: expected an integer, got 1.5",
        ),
        ({"reward": 150_000_000, "places": 1, "minutes": 1}, "prolific.reward: must be <= 100000"),
        ({"reward": 1, "places": 0, "minutes": 1}, "prolific.places: must be >= 1, got 0"),
        ({"reward": 1, "places": 1, "minutes": 9, "max_minutes": 20}, "no less than 26"),
        (
            {"reward": 1, "places": 1, "minutes": 1, "devices": ["phone"]},
            "prolific.devices: expected values",
        ),
        ({"reward": 1, "places": 1, "minutes": 1, "currency": "pounds"}, "prolific.currency"),
        (
            {"reward": 1, "places": 1, "minutes": 1, "bonus_per_check": "0.001"},
            "at most two decimals",
        ),
        (
            {"reward": 1, "places": 1, "minutes": 1, "filters": [{"filter_id": "a"}]},
            "either selected_values",
        ),
        ({"reward": 1, "places": 1, "minutes": 1, "workspace": "a b"}, "expected a Prolific id"),
        ({"reward": 1, "places": 1, "minutes": 1, "pay": 2}, "prolific.pay: unknown key"),
    ],
)
def test_every_mistake_is_one_line(table, message):
    with pytest.raises(InputError) as refused:
        _read(table)
    assert message in str(refused.value) and "\n" not in str(refused.value)
    assert str(refused.value).startswith("study.toml: prolific")


def test_helpers():
    assert minimum_allowed_minutes(1) == 6 and minimum_allowed_minutes(9) == 26
    assert money("2") == Decimal("2.00") and money("1e400") is None and money("0") is None


VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats() | st.text(max_size=12),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=12), inner, max_size=3)
    ),
    max_leaves=10,
)
KEYS = st.sampled_from([*RECRUITING_KEYS, "selected_values", "x"]) | st.text(max_size=6)


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(KEYS, VALUES, max_size=8) | VALUES)
def test_any_table_is_read_or_refused_in_one_line(table):
    try:
        _read(table)
    except InputError as exc:
        assert "\n" not in str(exc)


@settings(max_examples=200, deadline=None)
@given(
    reward=st.integers(-5, 10**6),
    places=st.integers(-5, 10**5),
    minutes=st.integers(-5, 3000),
    extra=st.dictionaries(st.sampled_from(RECRUITING_KEYS), VALUES, max_size=3),
)
def test_any_numbers_are_read_or_refused_in_one_line(reward, places, minutes, extra):
    try:
        spec = _read({"reward": reward, "places": places, "minutes": minutes, **extra})
    except InputError as exc:
        assert "\n" not in str(exc)
    else:
        assert spec.reward >= 1 and spec.places >= 1 and spec.minutes >= 1
