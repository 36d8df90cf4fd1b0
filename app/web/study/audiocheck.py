"""The audio check before the first trial (the study file's ``[audio_check]``): its state per
participant, the sounds of each question, the scoring, and its result in the exports and the
analysis's exclusions.

The server keeps the answer key: each attempt's target positions are drawn from a random key
stored with the participant (``Participant.audio_check``), never sent to the page, and the
sounds are made here for the question asked (:mod:`app.stimuli.headphones`). A participant
who fails every allowed attempt goes on with the study; the report leaves them out under the
``audio_check_failed`` rule (``app.web.study.participants``).

The state is ``{"key": int, "answers": [[...], ...], "scores": [...], "passed": bool|None}``:
one list of answers (0, 1 or 2) per attempt, the score of each finished attempt, and the
verdict once given.
"""

from __future__ import annotations

import secrets
from typing import Any, Final, Literal

import numpy as np

from app.stimuli.headphones import targets as draw_targets
from app.stimuli.headphones import three_intervals, wav_bytes
from app.trials.participation import AudioCheckSpec
from app.web.models import Participant
from app.web.study.studies import participation

CHOICES: Final = (0, 1, 2)
Phase = Literal["question", "retry", "done"]


class AudioCheckRefused(ValueError):
    """An answer that does not fit the question being asked (one line naming the field)."""


def audio_spec(participant: Participant) -> AudioCheckSpec:
    """The study's audio check (``kind = "none"`` when it has none)."""
    return participation(participant.study).audio_check


def state(participant: Participant) -> dict[str, Any]:
    """The participant's check so far (a fresh one, with its secret key, before the first
    question; the caller stores it with :func:`_store`)."""
    found = participant.audio_check
    if found and "key" in found:
        return {**found, "answers": [list(a) for a in found["answers"]]}
    return {"key": secrets.randbits(62), "answers": [[]], "scores": [], "passed": None}


def _store(participant: Participant, current: dict[str, Any]) -> None:
    # A new dict each time: the JSON column sees assignments, not changes in place.
    participant.audio_check = current


def pending(participant: Participant) -> bool:
    """Whether the participant still owes the audio check before the first trial."""
    if not audio_spec(participant).enabled:
        return False
    return (participant.audio_check or {}).get("passed") is None


def phase(spec: AudioCheckSpec, current: dict[str, Any]) -> Phase:
    """``question`` (an attempt is under way), ``retry`` (the last attempt failed and another
    is allowed) or ``done`` (passed, or failed with no attempt left)."""
    if current["passed"] is not None:
        return "done"
    if len(current["answers"][-1]) < spec.trials:
        return "question"
    return "retry"


def _targets(current: dict[str, Any], attempt: int, trials: int) -> list[int]:
    return draw_targets(int(current["key"]) + 7919 * attempt, trials)


def position(participant: Participant) -> tuple[int, int]:
    """The attempt (1-based) and the question number (1-based) being asked now."""
    current = state(participant)
    return len(current["answers"]), len(current["answers"][-1]) + 1


def begin(participant: Participant) -> dict[str, Any]:
    """The participant's state, stored (so its key is fixed before any sound is made)."""
    current = state(participant)
    if participant.audio_check != current:
        _store(participant, current)
    return current


def answer(participant: Participant, *, attempt: int, question: int, choice: object) -> bool:
    """Record ``choice`` (0, 1 or 2) for ``question`` of ``attempt``; True when stored, False
    when that question was already answered (a resent form changes nothing). The attempt is
    scored at its last answer: passed with ``pass_mark`` right, else another attempt if one is
    left, else failed."""
    spec = audio_spec(participant)
    current = begin(participant)
    if phase(spec, current) != "question":
        return False
    if (attempt, question) != position(participant):
        if attempt == len(current["answers"]) and 1 <= question < position(participant)[1]:
            return False
        raise AudioCheckRefused(
            f"question: expected {position(participant)}, got {attempt, question}"
        )
    if isinstance(choice, bool) or choice not in CHOICES:
        raise AudioCheckRefused(f"choice: expected 0, 1 or 2, got {str(choice)[:20]!r}")
    answers = current["answers"][-1] + [int(choice)]  # type: ignore[call-overload]
    current["answers"][-1] = answers
    if len(answers) == spec.trials:
        key = _targets(current, attempt, spec.trials)
        score = sum(a == t for a, t in zip(answers, key, strict=True))
        current["scores"] = current["scores"] + [score]
        if score >= spec.pass_mark:
            current["passed"] = True
        elif attempt >= spec.attempts:
            current["passed"] = False
    _store(participant, {**current})
    return True


def retry(participant: Participant) -> bool:
    """Start the next attempt after a failed one, if one is left; True if started."""
    spec = audio_spec(participant)
    current = begin(participant)
    if phase(spec, current) != "retry" or len(current["answers"]) >= spec.attempts:
        return False
    _store(participant, {**current, "answers": current["answers"] + [[]]})
    return True


def sound(participant: Participant, *, attempt: int, question: int) -> bytes | None:
    """The WAV of ``question`` in ``attempt``, or None unless it is the question being asked
    (no sound of a later question, or of another attempt, is ever made)."""
    spec = audio_spec(participant)
    current = state(participant)
    if participant.audio_check is None or phase(spec, current) != "question":
        return None
    if (attempt, question) != position(participant):
        return None
    target = _targets(current, attempt, spec.trials)[question - 1]
    rng = np.random.default_rng([int(current["key"]), attempt, question])
    return wav_bytes(three_intervals(spec.kind, target=target, rng=rng))


def result(participant: Participant) -> dict[str, Any]:
    """The export's columns: ``audio_check`` (passed, failed, or "" without a verdict),
    ``audio_check_attempts`` and ``audio_check_score`` (right answers of the last finished
    attempt)."""
    found = participant.audio_check or {}
    verdict = found.get("passed")
    scores = found.get("scores") or []
    return {
        "audio_check": "" if verdict is None else ("passed" if verdict else "failed"),
        "audio_check_attempts": len(scores) if found else "",
        "audio_check_score": scores[-1] if scores else "",
    }
