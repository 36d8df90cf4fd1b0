"""How every export names and times a participant: the label ``P0007``, the pseudonym of a
Prolific ID, and one time format.

One place for each, so that votes.csv, participants.csv, answers.csv, the monitor and the
report agree on who is who and when.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import hmac


def participant_label(number: int) -> str:
    """How exports name a participant (``P0007``): the arrival number, nothing personal."""
    return f"P{number:04d}"


def pseudonym(key: str, identifier: str | None) -> str:
    """The pseudonym of ``identifier`` under ``key`` (empty for no identifier).

    >>> pseudonym("k", "5f2a0c") == pseudonym("k", "5f2a0c") != pseudonym("other", "5f2a0c")
    True
    >>> pseudonym("k", "5f2a0c").startswith("anon-"), pseudonym("k", None)
    (True, '')
    """
    if not identifier:
        return ""
    digest = hmac.new(key.encode(), identifier.encode("utf-8", "surrogatepass"), hashlib.sha256)
    return "anon-" + digest.hexdigest()[:16]


def iso_time(value: dt.datetime | None) -> str:
    """A stored (naive UTC) time as every export writes it, to the millisecond; empty for none.

    >>> iso_time(dt.datetime(2026, 1, 2, 3, 4, 5, 678900)), iso_time(None)
    ('2026-01-02T03:04:05.678Z', '')
    """
    return value.isoformat(timespec="milliseconds") + "Z" if value is not None else ""
