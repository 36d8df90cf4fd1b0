"""The vote vocabulary: which choices exist, when a clip may be (re)played, when a vote may be
cast, and what a participant reads when it may not. The one place for these facts: the votes
schema (:mod:`app.analysis.votes`), the web layer's checks and the participant page's buttons and
keys all read them from here.

Replay policies: ``unlimited`` follows Le, Ma & Deng 2012, sec. 8.1 ("they can view
the clips for unlimited times before made their decisions"); ``max_plays`` caps the number of
plays; ``play_to_end`` requires the clip to have played through once before a vote, so no vote
is cast on a half-seen animation (the thesis, sec. 5.1, played both animations "in synchrony"
to the end of the audio track).

The choices are those of the seeds: left or right panel, and "undecided" where the study allows
it (Le et al. 2012, sec. 8.1: "allowed to leave undecided choices if they cannot decide").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Final, NamedTuple


class VoteChoice(StrEnum):
    """A participant's answer: the left panel, the right panel, or undecided."""

    LEFT = "left"
    RIGHT = "right"
    UNDECIDED = "undecided"


CHOICES: Final[tuple[str, ...]] = tuple(c.value for c in VoteChoice)
"""The answers a participant can give, in the order the vote counts index them (0, 1, 2)."""

KEYS: Final[dict[str, str]] = {
    "ArrowLeft": CHOICES[0],
    "1": CHOICES[0],
    "ArrowRight": CHOICES[1],
    "2": CHOICES[1],
    "ArrowDown": CHOICES[2],
    "0": CHOICES[2],
}
"""Keyboard keys of the 3-level answer (the study file's convention: 1 = left, 2 = right,
0 = undecided; the arrows work too). The 5-level answer is keyed 1 to 5, left to right."""

REPLAY_KINDS: Final = ("unlimited", "max_plays", "play_to_end")
"""Kinds of replay policy."""


def key_map(scale: int) -> dict[str, str]:
    """Key -> choice for keys that cast a choice whatever its button's own key: :data:`KEYS`
    on the 3-level answer; none on the 5-level one (its buttons carry keys 1 to 5).

    >>> key_map(3)["ArrowDown"], key_map(5)
    ('undecided', {})
    """
    return dict(KEYS) if scale != 5 else {}


class Answer(NamedTuple):
    """One answer button: the choice it casts, its strength on the 5-level scale (None on the
    3-level one), its label and its key."""

    choice: str
    strength: int | None
    label: str
    key: str


DEFAULT_UNDECIDED_LABEL: Final = "Undecided"
"""The undecided button's label when the study file names none (``undecided.label``)."""


def answers(
    *, scale: int, undecided_allowed: bool, undecided_label: str = DEFAULT_UNDECIDED_LABEL
) -> tuple[Answer, ...]:
    """The answer buttons of a study, left to right (HEMVIP2's 5-level scale when ``scale`` is 5).

    >>> [a.key for a in answers(scale=3, undecided_allowed=True)]
    ['1', '0', '2']
    >>> [(a.choice, a.strength, a.key) for a in answers(scale=5, undecided_allowed=False)]
    [('left', 2, '1'), ('left', 1, '2'), ('right', 1, '4'), ('right', 2, '5')]
    """
    left, right, undecided = CHOICES
    if scale == 5:
        out = [
            Answer(left, 2, "Clearly left", "1"),
            Answer(left, 1, "Slightly left", "2"),
            Answer(undecided, 0, undecided_label, "3"),
            Answer(right, 1, "Slightly right", "4"),
            Answer(right, 2, "Clearly right", "5"),
        ]
    else:
        key = {choice: k for k, choice in KEYS.items() if k.isdigit()}
        out = [
            Answer(left, None, "Left", key[left]),
            Answer(undecided, None, undecided_label, key[undecided]),
            Answer(right, None, "Right", key[right]),
        ]
    return tuple(a for a in out if undecided_allowed or a.choice != undecided)


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

    @property
    def needs_end(self) -> bool:
        """Whether a vote waits for a play to reach the end."""
        return self.kind == "play_to_end"


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


def vote_refusal(policy: ReplayPolicy, plays: int, finished: bool) -> str | None:
    """Why a vote after ``plays`` started plays is refused (one line naming the field), or None
    when :func:`may_vote` allows it.

    >>> vote_refusal(ReplayPolicy("play_to_end"), 1, False)
    'watched_to_end: the clip must play to the end before voting'
    >>> vote_refusal(ReplayPolicy(), 1, False) is None
    True
    """
    if may_vote(policy, plays, finished):
        return None
    if plays == 0:
        return "plays: the clip must be played before voting"
    if policy.needs_end:
        return "watched_to_end: the clip must play to the end before voting"
    return play_refusal(policy)


def play_refusal(policy: ReplayPolicy) -> str:
    """What a participant reads when no play is left (``max_plays``)."""
    return f"plays: at most {policy.max_plays} plays are allowed"


def allowed_choices(*, undecided_allowed: bool) -> tuple[str, ...]:
    """The choices a study offers: left, right, and undecided if allowed.

    >>> allowed_choices(undecided_allowed=False)
    ('left', 'right')
    """
    return tuple(c for c in CHOICES if undecided_allowed or c != VoteChoice.UNDECIDED)


def check_choice(choice: object, *, undecided_allowed: bool) -> VoteChoice:
    """Validate a submitted choice; ``ValueError`` with one line if it is not allowed.

    >>> check_choice("left", undecided_allowed=False)
    <VoteChoice.LEFT: 'left'>
    """
    allowed = allowed_choices(undecided_allowed=undecided_allowed)
    if not isinstance(choice, str) or choice not in allowed:
        raise ValueError(f"expected one of {', '.join(allowed)}, got {repr(choice)[:40]}")
    return VoteChoice(choice)


def instructed_side(kind: str, expected: str | None, instruction: Callable[[], str]) -> str | None:
    """The side a pair's page asks for in words ("For this pair, please choose left."): that
    of an instructed attention check, a catch trial expecting left or right whose clip does
    not carry its own on-screen instruction (``instruction()``, read only for such a trial);
    None for every other pair. The one rule for the trial page and the vote's answer that
    carries the next pair."""
    if kind == "catch" and expected in (VoteChoice.LEFT, VoteChoice.RIGHT) and not instruction():
        return expected
    return None
