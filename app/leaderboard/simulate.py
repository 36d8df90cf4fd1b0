"""Simulated participants with known preferences, for the demo season and its tests.

A simulated participant answers each trial as the model the board fits says a population with
these preferences would: a pair of two systems by the Bradley-Terry-Davidson model (worths
``exp(strength)``, tie parameter ``nu``; Davidson 1970), on HEMVIP2's five levels (a decided
answer is "clearly" with probability ``1 - exp(-|difference|)``, else "slightly"); a
mismatched-speech pair for the matched face with the system's coherence probability (a tenth
of them undecided); an identical catch pair undecided, an instructed one as instructed. Each
participant carries a small shift of every strength (sd ``spread``), so votes are not
independent across a participant's trials: the bootstrap over participants has something to do.

>>> prefs = Preferences({"a": 2.0, "b": -2.0}, {"a": 0.9, "b": 0.5})
>>> rng = np.random.default_rng(0)
>>> answers = [answer_pair(prefs, "a", "b", rng)[0] for _ in range(200)]
>>> answers.count("left") > 150
True
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Preferences:
    """Strengths (log worths) and coherence probabilities by system (condition) name."""

    strengths: Mapping[str, float]
    coherence: Mapping[str, float]
    nu: float = 0.25
    spread: float = 0.2
    shift: Mapping[str, float] = field(default_factory=dict)

    def for_participant(self, rng: np.random.Generator) -> Preferences:
        """This population's preferences as one participant holds them."""
        shift = {k: float(rng.normal(0.0, self.spread)) for k in self.strengths}
        return Preferences(self.strengths, self.coherence, self.nu, self.spread, shift)

    def strength(self, system: str) -> float:
        return float(self.strengths.get(system, 0.0)) + self.shift.get(system, 0.0)


def answer_pair(
    prefs: Preferences, left: str, right: str, rng: np.random.Generator
) -> tuple[str, int]:
    """(choice, strength) for ``left`` against ``right`` (Davidson's ties)."""
    a, b = np.exp(prefs.strength(left)), np.exp(prefs.strength(right))
    tie = prefs.nu * np.sqrt(a * b)
    total = a + b + tie
    draw = rng.random() * total
    if draw >= a + b:
        return "undecided", 0
    choice = "left" if draw < a else "right"
    gap = abs(prefs.strength(left) - prefs.strength(right))
    return choice, 2 if rng.random() < 1.0 - np.exp(-gap) else 1


def answer_mismatch(
    prefs: Preferences, system: str, mismatched: str, rng: np.random.Generator
) -> tuple[str, int]:
    """(choice, strength) of a mismatched-speech pair whose ``mismatched`` side moves to
    another segment."""
    if rng.random() < 0.1:
        return "undecided", 0
    matched = "right" if mismatched == "left" else "left"
    hit = rng.random() < float(prefs.coherence.get(system, 0.5))
    return (matched if hit else mismatched), 1


def answer_catch(expected: str | None) -> tuple[str, int]:
    """The attentive answer to an attention check."""
    choice = expected or "undecided"
    return choice, 0 if choice == "undecided" else 2
