"""Questionnaire pages of a study: questions before the trials and after them.

A study file's ``[[questions]]`` (docs/reference/studyfile.md) each give a name (the column of the
answers export), the text shown, the page (``before`` the trials or ``after`` them), a type and
whether an answer is required. Types: ``choice`` (one of ``choices``), ``number`` (between ``min``
and ``max``, both optional) and ``text`` (at most ``max_length`` characters). ``demographics =
true`` puts :data:`DEMOGRAPHICS` first on the ``before`` page: age band, gender, native
language, corrected vision and experience with animation, the sample description a methods
section needs. (The seeds' own experiments - thesis sec. 5.2, five subjects; Le, Ma & Deng 2012,
sec. 8 - report no demographics; a web study with strangers has to.)

:func:`check_answer` validates one submitted value; every problem is one line naming the
question, so the page can show it beside the field.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, Final

from app.errors import InputError
from app.trials.fields import FieldReader, describe

#: Automatic exclusion rules the report applies (``app.web.study.participants.AUTO_RULES``),
#: repeated so that reading a study file needs no database.
AUTO_EXCLUDE_RULES: Final = ("catch_failed", "unfinished")
PAGES: Final = ("before", "after")
QUESTION_TYPES: Final = ("choice", "number", "text")
DEFAULT_MAX_LENGTH: Final = 500
#: The longest free text any question may allow (a column, not a document).
MAX_TEXT_LENGTH: Final = 5000


@dataclass(frozen=True, slots=True)
class QuestionSpec:
    """One question of a questionnaire page."""

    name: str
    text: str
    page: str = "before"
    kind: str = "text"
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    maximum: float | None = None
    max_length: int = DEFAULT_MAX_LENGTH
    required: bool = True

    def to_dict(self) -> dict[str, Any]:
        """The question as a study file's ``[[questions]]`` table."""
        out: dict[str, Any] = {
            "name": self.name,
            "text": self.text,
            "page": self.page,
            "type": self.kind,
            "required": self.required,
        }
        if self.kind == "choice":
            out["choices"] = list(self.choices)
        elif self.kind == "number":
            out |= {
                k: v for k, v in (("min", self.minimum), ("max", self.maximum)) if v is not None
            }
        else:
            out["max_length"] = self.max_length
        return out


DEMOGRAPHICS: Final[tuple[QuestionSpec, ...]] = (
    QuestionSpec(
        "age_band",
        "Your age",
        kind="choice",
        choices=("18-24", "25-34", "35-44", "45-54", "55-64", "65 or over", "prefer not to say"),
    ),
    QuestionSpec(
        "gender",
        "Your gender",
        kind="choice",
        choices=("female", "male", "non-binary", "other", "prefer not to say"),
    ),
    QuestionSpec("native_language", "Your native language", kind="text", max_length=80),
    QuestionSpec(
        "vision_corrected",
        "Do you wear glasses or contact lenses to see a screen?",
        kind="choice",
        choices=("no", "yes, and I am wearing them now", "yes, but I am not wearing them now"),
    ),
    QuestionSpec(
        "animation_experience",
        "Your experience with computer animation",
        kind="choice",
        choices=(
            "none",
            "I watch animated films or play games",
            "I have made animations",
            "I work in animation",
        ),
    ),
)


class AnswerError(InputError):
    """A questionnaire answer refused: ``problem`` says which rule (``required``, ``choice``,
    ``number``, ``minimum``, ``maximum``, ``length``), ``limit`` its bound and ``got`` what
    was given, so a page can say it in the participant's language."""

    def __init__(
        self,
        message: str,
        *,
        field: str,
        problem: str,
        limit: float | None = None,
        got: str = "",
    ) -> None:
        super().__init__(message, field=field)
        self.problem = problem
        self.limit = limit
        self.got = got


def check_answer(question: QuestionSpec, raw: str | None) -> str | float | None:
    """The answer to ``question`` from the submitted text ``raw``: the chosen option, a number,
    the text, or None when left empty (allowed only if not required).

    >>> q = QuestionSpec("age", "Age", kind="number", minimum=18, maximum=99)
    >>> check_answer(q, " 42 ")
    42.0
    >>> check_answer(q, "17")
    Traceback (most recent call last):
    app.trials.questions.AnswerError: age: must be at least 18, got 17
    """
    value = (raw or "").strip()
    name = question.name
    if not value:
        if question.required:
            raise AnswerError("an answer is required", field=name, problem="required")
        return None
    if question.kind == "choice":
        if value not in question.choices:
            raise AnswerError(
                f"choose one of the options, got {value[:40]!r}",
                field=name,
                problem="choice",
                got=repr(value[:40]),
            )
        return value
    if question.kind == "number":
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not math.isfinite(number):
            raise AnswerError(
                f"expected a number, got {value[:40]!r}",
                field=name,
                problem="number",
                got=repr(value[:40]),
            )
        if question.minimum is not None and number < question.minimum:
            raise AnswerError(
                f"must be at least {question.minimum:g}, got {number:g}",
                field=name,
                problem="minimum",
                limit=question.minimum,
                got=f"{number:g}",
            )
        if question.maximum is not None and number > question.maximum:
            raise AnswerError(
                f"must be at most {question.maximum:g}, got {number:g}",
                field=name,
                problem="maximum",
                limit=question.maximum,
                got=f"{number:g}",
            )
        return number
    if len(value) > question.max_length:
        raise AnswerError(
            f"at most {question.max_length} characters, got {len(value)}",
            field=name,
            problem="length",
            limit=question.max_length,
            got=str(len(value)),
        )
    return value


class ExperimenterSideReader(FieldReader):
    """The study file's experimenter-side keys (``auto_exclude``, ``demographics``,
    ``[[questions]]``), kept apart from the design's keys in ``app.trials.studyfile``."""

    def experimenter_side(
        self, top: Mapping[str, Any]
    ) -> tuple[tuple[str, ...], tuple[QuestionSpec, ...]]:
        """``auto_exclude`` (the automatic exclusion rules; default: all of them) and the
        questionnaire: ``demographics`` and ``[[questions]]`` (:mod:`app.trials.questions`)."""
        rules = self.get(
            top,
            "auto_exclude",
            "auto_exclude",
            (list,),
            "an array of rule names",
            list(AUTO_EXCLUDE_RULES),
        )
        for rule in rules:
            if rule not in AUTO_EXCLUDE_RULES:
                raise self.error(
                    "auto_exclude",
                    f"expected rules from {', '.join(AUTO_EXCLUDE_RULES)}, got {describe(rule)}",
                )
        demographics = self.get(
            top, "demographics", "demographics", (bool,), "true or false", False
        )
        questions = list(DEMOGRAPHICS) if demographics else []
        items = self.get(
            top, "questions", "questions", (list,), "an array of tables ([[questions]])", []
        )
        for index, item in enumerate(items):
            question = self.question(item, f"questions[{index}]")
            if question.name in [q.name for q in questions]:
                raise self.error(
                    f"questions[{index}].name",
                    f"repeats question name {question.name!r}"
                    + (" (a demographics question)" if demographics else ""),
                )
            questions.append(question)
        return tuple(dict.fromkeys(rules)), tuple(questions)

    def question(self, item: Any, name: str) -> QuestionSpec:
        keys = ("name", "text", "page", "type", "required", "choices", "min", "max", "max_length")
        item = self.table(item, name, keys)
        kind = self.choice(item, "type", f"{name}.type", QUESTION_TYPES, "text")
        allowed = {"choice": ("choices",), "number": ("min", "max"), "text": ("max_length",)}
        for key in ("choices", "min", "max", "max_length"):
            if key in item and key not in allowed[kind]:
                raise self.error(f"{name}.{key}", f"does not apply to type = {kind!r}")
        question = QuestionSpec(
            name=self.identifier(item, "name", f"{name}.name"),
            text=self.text(item, "text", f"{name}.text", nonempty=True),
            page=self.choice(item, "page", f"{name}.page", PAGES, "before"),
            kind=kind,
            required=bool(
                self.get(item, "required", f"{name}.required", (bool,), "true or false", True)
            ),
        )
        if kind == "choice":
            choices = self.get(item, "choices", f"{name}.choices", (list,), "an array of strings")
            if len(choices) < 2 or not all(isinstance(c, str) and c.strip() for c in choices):
                raise self.error(f"{name}.choices", "expected two or more non-empty strings")
            if len(set(choices)) != len(choices):
                raise self.error(f"{name}.choices", "repeats an option")
            return replace(question, choices=tuple(choices))
        if kind == "number":
            low, high = (
                self.get(item, k, f"{name}.{k}", (int, float), "a number", None)
                for k in ("min", "max")
            )
            for key, bound in (("min", low), ("max", high)):
                if bound is not None and not math.isfinite(bound):
                    raise self.error(f"{name}.{key}", f"expected a finite number, got {bound}")
            if low is not None and high is not None and low > high:
                raise self.error(f"{name}.max", f"must be >= min ({low}), got {high}")
            return replace(question, minimum=low, maximum=high)
        length = self.integer(
            item, "max_length", f"{name}.max_length", DEFAULT_MAX_LENGTH, 1, MAX_TEXT_LENGTH
        )
        return replace(question, max_length=length)
