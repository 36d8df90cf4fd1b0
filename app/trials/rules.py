"""Vote rules: when a clip may be (re)played, when a vote may be cast, which choices exist.

Replay policies: ``unlimited`` follows Le, Ma & Deng 2012, sec. 8.1 ("they can view
the clips for unlimited times before made their decisions"); ``max_plays`` caps the number of
plays; ``play_to_end`` requires the clip to have played through once before a vote, so no vote
is cast on a half-seen animation (the thesis, sec. 5.1, played both animations "in synchrony"
to the end of the audio track).

The choices are those of the seeds: left or right panel, and "undecided" where the study allows
it (Le et al. 2012, sec. 8.1: "allowed to leave undecided choices if they cannot decide").
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Final

KNOWN_CHOICES: Final = ("left", "right", "undecided")
"""The choices of the votes schema; must equal ``app.analysis.votes.CHOICES`` (the tests check it
when that module is present), which is the one place for them."""


def _schema_choices() -> tuple[str, ...]:
    """The vote choices from the analysis package's votes schema, if installed."""
    try:
        from app.analysis.votes import CHOICES as schema
    except ImportError:
        return KNOWN_CHOICES
    return tuple(schema)


CHOICES: Final[tuple[str, ...]] = _schema_choices()
"""The answers a participant can give: left panel, right panel, undecided."""

REPLAY_KINDS: Final = ("unlimited", "max_plays", "play_to_end")
"""Kinds of replay policy."""


class VoteChoice(StrEnum):
    """A participant's answer; the values are :data:`CHOICES`, in the same order."""

    LEFT = "left"
    RIGHT = "right"
    UNDECIDED = "undecided"


@dataclass(frozen=True, slots=True)
class ReplayPolicy:
    """How often a pair's clip may be played and whether it must finish before the vote.

    ``max_plays`` is required (a positive integer) for ``kind="max_plays"`` and must be
    ``None`` for the other kinds.

    >>> ReplayPolicy("max_plays", max_plays=2)
    ReplayPolicy(kind='max_plays', max_plays=2)
    """

    kind: str = "unlimited"
    max_plays: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in REPLAY_KINDS:
            raise ValueError(f"expected one of {', '.join(REPLAY_KINDS)}, got {self.kind!r}")
        if self.kind == "max_plays":
            if (
                isinstance(self.max_plays, bool)
                or not isinstance(self.max_plays, int)
                or (self.max_plays < 1)
            ):
                raise ValueError(f"max_plays must be a positive integer, got {self.max_plays!r}")
        elif self.max_plays is not None:
            raise ValueError(f"max_plays only applies to kind 'max_plays', not {self.kind!r}")


def may_play(policy: ReplayPolicy, plays: int) -> bool:
    """Whether the clip may start again after ``plays`` plays already started.

    >>> may_play(ReplayPolicy("max_plays", max_plays=2), 1), may_play(ReplayPolicy(), 99)
    (True, True)
    >>> may_play(ReplayPolicy("max_plays", max_plays=2), 2)
    False
    """
    if plays < 0:
        raise ValueError(f"plays must be >= 0, got {plays}")
    if policy.kind == "max_plays":
        assert policy.max_plays is not None
        return plays < policy.max_plays
    return True


def may_vote(policy: ReplayPolicy, plays: int, finished: bool) -> bool:
    """Whether a vote may be cast after ``plays`` started plays (``finished``: one reached the end).

    Every policy needs the clip to have been played at least once; ``play_to_end`` also needs a
    play to have reached the end.

    >>> to_end = ReplayPolicy("play_to_end")
    >>> may_vote(to_end, 1, False), may_vote(to_end, 1, True), may_vote(ReplayPolicy(), 0, False)
    (False, True, False)
    """
    if plays < 0:
        raise ValueError(f"plays must be >= 0, got {plays}")
    if plays == 0:
        return False
    if policy.kind == "play_to_end":
        return finished
    if policy.kind == "max_plays":
        assert policy.max_plays is not None
        return plays <= policy.max_plays
    return True


def allowed_choices(*, undecided_allowed: bool) -> tuple[str, ...]:
    """The choices a study offers: left, right, and undecided if allowed.

    >>> allowed_choices(undecided_allowed=False)
    ('left', 'right')
    """
    return tuple(c for c in CHOICES if undecided_allowed or c != VoteChoice.UNDECIDED)


def check_choice(choice: str, *, undecided_allowed: bool) -> VoteChoice:
    """Validate a submitted choice; ``ValueError`` with one line if it is not allowed."""
    allowed = allowed_choices(undecided_allowed=undecided_allowed)
    if choice not in allowed:
        raise ValueError(f"expected one of {', '.join(allowed)}, got {choice!r}")
    return VoteChoice(choice)
