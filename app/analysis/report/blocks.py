"""The report's blocks - heading, paragraph, table, plot - and how their text prints numbers.

:func:`app.analysis.report.document.build_document` and the sections it places
(:mod:`~app.analysis.report.inference_document`, :mod:`~app.analysis.report.mixed_document`,
:mod:`~app.analysis.report.answer_document`, :mod:`~app.analysis.report.rating_document`) are
made of these blocks; :mod:`app.analysis.report.writer` writes them as HTML and as PDF, so both
say the same. Numbers are printed the way a paper's results section prints them (APA: p
without leading zero, "< .001").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from matplotlib.figure import Figure

ALPHA = 0.05
MAX_LISTED_PARTICIPANTS = 60


@dataclass
class Heading:
    text: str
    level: int = 2


@dataclass
class Paragraph:
    text: str


@dataclass
class Table:
    caption: str
    header: list[str]
    rows: list[list[str]]
    note: str = ""
    numeric: list[bool] = field(default_factory=list)


@dataclass
class Plot:
    caption: str
    figure: Figure


Block = Heading | Paragraph | Table | Plot


def counted(n: int, noun: str) -> str:
    """``n`` and the noun, singular for one (never "1 participants").

    >>> counted(1, "participant"), counted(3, "vote")
    ('1 participant', '3 votes')
    """
    return f"{n} {noun}{'' if n == 1 else 's'}"


def fmt(x: float | int | None, digits: int = 2) -> str:
    """A number for the reader; "-" for a statistic that could not be computed."""
    if x is None:
        return "-"
    if isinstance(x, int) or float(x).is_integer() and abs(x) >= 1000:
        return f"{int(x)}"
    return f"{x:.{digits}f}"


def fmt_p(p: float | None) -> str:
    """APA-style p: ".023", "< .001", "1"; "-" when undefined."""
    if p is None:
        return "-"
    if p < 0.001:
        return "< .001"
    return "1" if p >= 0.9995 else f"{p:.3f}".lstrip("0")


def judgements_per_pair(section: dict[str, Any], undecided: str, dash: str = "-") -> str:
    """How often each pair of different conditions was judged (``m`` of the agreement test):
    its votes in both side orders, the undecided ones where they are ``split`` and not where
    they are excluded; one number, or the range ``min-max``; "-" when no pair was shown.
    Pairs judged fewer than 3 times count here though the agreement test leaves them out.

    >>> pair = {"wins": 1, "losses": 1, "undecided": 1}  # A|B and B|A, and one undecided
    >>> judgements_per_pair({"sign_tests": [pair]}, "exclude")
    '2'
    """
    counts = [pair_judgements(s, undecided) for s in section["sign_tests"]]
    if not counts:
        return "-"
    low, high = min(counts), max(counts)
    return f"{low}" if low == high else f"{low}{dash}{high}"


def pair_judgements(sign_test: dict[str, Any], undecided: str) -> int:
    """One pair's judgements (:func:`judgements_per_pair`)."""
    split = sign_test["undecided"] if undecided == "split" else 0
    return int(sign_test["wins"] + sign_test["losses"] + split)
