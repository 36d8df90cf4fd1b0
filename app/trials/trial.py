"""One page of a participant's study: :class:`ScheduledTrial` and the kinds of trial.

A schedule is a list of these in presentation order, built by :mod:`app.trials.schedule` for
the pair designs (the thesis' side-by-side pairs, sec. 5.2) and by :mod:`app.trials.rating`
for the rating designs (ITU-T P.910 ACR, one face per page). The web layer stores each as a
row and resumes at the lowest unanswered position; catch trials carry the answer an attentive
participant gives (:mod:`app.trials.catch`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from app.trials.design import ConditionPair

TRIAL_KINDS: Final = ("practice", "trial", "catch", "mismatch")
"""Kinds of trial: the practice pair after the instructions, a real trial, a catch trial, an
appropriateness pair (one condition's motion for this clip beside its motion for another
clip, under this clip's speech: the GENEA challenge's appropriateness test)."""


@dataclass(frozen=True, slots=True)
class ScheduledTrial:
    """One page of the study.

    Attributes
    ----------
    position:
        0-based place in the participant's schedule, consecutive over all kinds (the practice
        trial, if any, is position 0); the web layer resumes at the lowest unanswered position.
    clip:
        Name of the clip (the audio segment) both panels play.
    left, right:
        Condition names shown on the left and right panels.
    kind:
        One of :data:`TRIAL_KINDS`.
    expected:
        For a catch trial, the answer an attentive participant gives (a value of
        ``app.trials.rules.CHOICES``); for an appropriateness pair, the side whose motion
        belongs to the speech; ``None`` otherwise.
    instruction:
        For an ``onscreen`` catch trial, the side the clip tells the participant to press.
    foreign:
        For an appropriateness pair, the side showing another clip's motion
        (:func:`app.trials.schedule.foreign_clip`); ``""`` otherwise.
    """

    position: int
    clip: str
    left: str
    right: str
    kind: str = "trial"
    expected: str | None = None
    instruction: str = ""
    foreign: str = ""

    @property
    def pair(self) -> ConditionPair:
        """The displayed pair."""
        return ConditionPair(self.left, self.right)

    def catch_passed(self, choice: str) -> bool | None:
        """For a catch trial, whether ``choice`` is the expected answer; ``None`` otherwise.

        >>> ScheduledTrial(3, "s2", "a", "a", "catch", "undecided").catch_passed("left")
        False
        """
        if self.kind != "catch":
            return None
        return choice == self.expected
