"""The participant's side of a study file: answer scale, reason tags, attention screening,
viewing conditions, appropriateness pairs, the participants' language and the audio check.

These keys sit in one block of the study file (``docs/reference/studyfile.md``, "The participant's
side") and follow today's evaluation interfaces for generated motion: the GENEA challenge's
HEMVIP2 5-level scale (clearly / slightly left, cannot decide, slightly / clearly right) and
its appropriateness test (the same motion once with its own speech and once with another
clip's speech), and the crowdsourcing practice of ITU-T P.910 (attention checks with a stop
rule, a viewing check before the first trial).

>>> from app.trials.fields import FieldReader
>>> from pathlib import Path
>>> read_participation(FieldReader("study.toml", Path(".")), {"answer": {"scale": 5}}).scale
5
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

from app.trials.fields import FieldReader

SCALES: Final = (3, 5)
"""Answer scales: 3 = left / right (/ undecided), 5 = HEMVIP2's clearly / slightly levels."""

PORTRAIT_MODES: Final = ("fit", "rotate")
"""What a phone held upright shows: the side-by-side clip across the width (both faces in
view, each half the screen wide), or a hint to turn the phone. The faces are never stacked:
one side-by-side file is what keeps them frame-synchronous."""

STRENGTHS: Final = {"clearly": 2, "slightly": 1, "undecided": 0}
"""The ``strength`` stored with a 5-level vote; its direction is the vote's ``choice``."""

MAX_REASONS: Final = 8
PARTICIPATION_KEYS: Final = (
    "mismatched",
    "answer",
    "attention",
    "viewing",
    "language",
    "audio_check",
)

LANGUAGES: Final = ("ar", "de", "en", "es", "fr", "ja")
"""Languages with a catalogue of the participant pages (``app/web/translations``): a study's
``language`` must start with one of them (``fr-CA`` uses ``fr``)."""

#: A BCP 47 tag as people write one: a language subtag, then optional script, region or
#: variant subtags (RFC 5646, sec. 2.1), e.g. ``de``, ``pt-BR``, ``zh-Hant-TW``.
_BCP47 = re.compile(r"[A-Za-z]{2,3}(-[A-Za-z0-9]{1,8})*")

AUDIO_CHECK_KINDS: Final = ("none", "huggins", "antiphase")
"""Headphone screens before the first trial (:mod:`app.stimuli.headphones`): none, Huggins pitch
(Milne et al. 2021) or the antiphase loudness test (Woods et al. 2017)."""


@dataclass(frozen=True, slots=True)
class AudioCheckSpec:
    """The audio check: ``kind`` (:data:`AUDIO_CHECK_KINDS`), ``trials`` three-interval trials
    per attempt, passed with at least ``pass_mark`` correct, in at most ``attempts`` attempts.

    The defaults are both papers' protocol: 6 trials, passed with 5 or more correct, one
    attempt (Milne et al. 2021, "An online headphone screening test based on dichotic pitch";
    Woods et al. 2017, "Headphone screening to facilitate web-based auditory experiments").
    Guessing passes one attempt with probability 0.018 (3 alternatives:
    ``6 * (1/3)**5 * (2/3) + (1/3)**6``).
    """

    kind: str = "none"
    trials: int = 6
    pass_mark: int = 5
    attempts: int = 1

    @property
    def enabled(self) -> bool:
        """Whether participants take the check before the first trial."""
        return self.kind != "none"


@dataclass(frozen=True, slots=True)
class ParticipationSpec:
    """The participant-side settings of a study (defaults: the classic 3-level page).

    scale : 3 or 5 answer levels (:data:`SCALES`).
    reasons : short reason tags offered after each choice (multiple choice); empty = none.
    max_failed : attention checks a participant may fail before the session ends (0 = never).
    screened_out_code : the completion code shown to a participant the stop rule ended, so
        the recruiting platform can tell them from those who completed.
    min_face_px : the viewing check: each face must be shown at least this many CSS pixels
        wide before the first trial (0 = no check).
    portrait : a phone held upright: ``fit`` shows the pair across the width, ``rotate`` asks
        to turn the phone (:data:`PORTRAIT_MODES`).
    mismatched : add appropriateness pairs: per condition and clip, that condition's motion
        for this clip beside its motion for another clip, under this clip's speech.
    language : the participants' language, a BCP 47 tag whose language has a catalogue
        (:data:`LANGUAGES`).
    audio_check : the headphone screen before the first trial (:class:`AudioCheckSpec`).
    """

    scale: int = 3
    reasons: tuple[str, ...] = ()
    max_failed: int = 0
    screened_out_code: str = ""
    min_face_px: int = 0
    portrait: str = "fit"
    mismatched: bool = False
    language: str = "en"
    audio_check: AudioCheckSpec = AudioCheckSpec()

    def to_dict(self) -> dict[str, Any]:
        """The block as study-file keys (what :func:`read_participation` reads back)."""
        return {
            "mismatched": self.mismatched,
            "answer": {"scale": self.scale, "reasons": list(self.reasons)},
            "attention": {
                "max_failed": self.max_failed,
                "screened_out_code": self.screened_out_code,
            },
            "viewing": {"min_face_px": self.min_face_px, "portrait": self.portrait},
            "language": self.language,
            "audio_check": {
                "kind": self.audio_check.kind,
                "trials": self.audio_check.trials,
                "pass_mark": self.audio_check.pass_mark,
                "attempts": self.audio_check.attempts,
            },
        }

    @classmethod
    def from_settings(cls, stored: Mapping[str, Any] | None) -> ParticipationSpec:
        """From the mapping :meth:`to_dict` wrote (a study's stored settings); absent keys
        take their defaults, so studies created before these keys existed read as before."""
        stored = stored or {}
        answer = stored.get("answer", {})
        attention = stored.get("attention", {})
        viewing = stored.get("viewing", {})
        check = stored.get("audio_check", {})
        return cls(
            scale=int(answer.get("scale", 3)),
            reasons=tuple(answer.get("reasons", ())),
            max_failed=int(attention.get("max_failed", 0)),
            screened_out_code=str(attention.get("screened_out_code", "")),
            min_face_px=int(viewing.get("min_face_px", 0)),
            portrait=str(viewing.get("portrait", "fit")),
            mismatched=bool(stored.get("mismatched", False)),
            language=str(stored.get("language", "en")),
            audio_check=AudioCheckSpec(
                kind=str(check.get("kind", "none")),
                trials=int(check.get("trials", 6)),
                pass_mark=int(check.get("pass_mark", 5)),
                attempts=int(check.get("attempts", 1)),
            ),
        )


def read_participation(
    reader: FieldReader, top: Mapping[str, Any], *, n_clips: int = 2
) -> ParticipationSpec:
    """Validate the block's keys in ``top`` (a study file's top-level table).

    ``n_clips`` is the study's number of clips: appropriateness pairs need another clip's
    motion, so ``mismatched = true`` needs at least two. Every problem raises one
    :class:`~app.errors.InputError` naming the field.
    """
    mismatched = bool(reader.get(top, "mismatched", "mismatched", (bool,), "true or false", False))
    if mismatched and n_clips < 2:
        raise reader.error(
            "mismatched",
            "needs at least two clips (another clip's motion is shown under each clip's speech)",
        )
    answer = reader.table(top.get("answer", {}), "answer", ("scale", "reasons"))
    scale = reader.integer(answer, "scale", "answer.scale", 3, 3, 5)
    if scale not in SCALES:
        raise reader.error("answer.scale", f"expected 3 or 5, got {scale}")
    tags = reader.get(answer, "reasons", "answer.reasons", (list,), "an array of strings", [])
    if len(tags) > MAX_REASONS:
        raise reader.error("answer.reasons", f"at most {MAX_REASONS} tags, got {len(tags)}")
    for index, tag in enumerate(tags):
        if not isinstance(tag, str) or not 1 <= len(tag.strip()) <= 40:
            raise reader.error(f"answer.reasons[{index}]", "expected a tag of 1 to 40 characters")
    if len(set(tags)) != len(tags):
        raise reader.error("answer.reasons", "repeats a tag")
    attention = reader.table(
        top.get("attention", {}), "attention", ("max_failed", "screened_out_code")
    )
    max_failed = reader.integer(attention, "max_failed", "attention.max_failed", 0, 0, 1000)
    code = reader.text(attention, "screened_out_code", "attention.screened_out_code", "")
    if len(code) > 80:
        raise reader.error("attention.screened_out_code", "at most 80 characters")
    viewing = reader.table(top.get("viewing", {}), "viewing", ("min_face_px", "portrait"))
    min_face = reader.integer(viewing, "min_face_px", "viewing.min_face_px", 0, 0, 4096)
    portrait = reader.choice(viewing, "portrait", "viewing.portrait", PORTRAIT_MODES, "fit")
    return ParticipationSpec(
        scale=scale,
        reasons=tuple(t.strip() for t in tags),
        max_failed=max_failed,
        screened_out_code=code,
        min_face_px=min_face,
        portrait=portrait,
        mismatched=mismatched,
        language=read_language(reader, top),
        audio_check=read_audio_check(reader, top),
    )


def read_language(reader: FieldReader, top: Mapping[str, Any]) -> str:
    """The study's ``language``: a BCP 47 tag (RFC 5646) whose language subtag has a
    catalogue (:data:`LANGUAGES`), kept as written; ``"en"`` when absent.

    >>> from pathlib import Path
    >>> read_language(FieldReader("study.toml", Path(".")), {"language": "fr-CA"})
    'fr-CA'
    """
    tag = reader.text(top, "language", "language", "en")
    if not _BCP47.fullmatch(tag):
        raise reader.error(
            "language", f"expected a BCP 47 tag such as 'de' or 'fr-CA', got {tag!r}"
        )
    primary = tag.split("-")[0].lower()
    if primary not in LANGUAGES:
        raise reader.error(
            "language", f"no catalogue for {primary!r}; expected one of {', '.join(LANGUAGES)}"
        )
    return tag


def read_audio_check(reader: FieldReader, top: Mapping[str, Any]) -> AudioCheckSpec:
    """The ``[audio_check]`` table (:class:`AudioCheckSpec`); every problem one line naming
    the key."""
    table = reader.table(
        top.get("audio_check", {}), "audio_check", ("kind", "trials", "pass_mark", "attempts")
    )
    kind = reader.choice(table, "kind", "audio_check.kind", AUDIO_CHECK_KINDS, "none")
    trials = reader.integer(table, "trials", "audio_check.trials", 6, 1, 20)
    pass_mark = reader.integer(table, "pass_mark", "audio_check.pass_mark", min(5, trials), 1)
    if pass_mark > trials:
        raise reader.error(
            "audio_check.pass_mark", f"at most audio_check.trials ({trials}), got {pass_mark}"
        )
    attempts = reader.integer(table, "attempts", "audio_check.attempts", 1, 1, 3)
    return AudioCheckSpec(kind=kind, trials=trials, pass_mark=pass_mark, attempts=attempts)
