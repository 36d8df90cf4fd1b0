"""The New-study form's settings beyond conditions, clips and files, as the study file's keys.

:func:`add_settings` writes them into the mapping ``app.web.experimenter.create`` builds, so
:func:`app.trials.studyfile.parse_study` validates the form as it validates a file: the form and
the equivalent study file make the same study, and a field left at its default gives the key a
file leaves out. A bad value is the study file's one-line error, shown beside the form's field
(:func:`form_field`); a value the form itself refuses is one line naming the field's label
(:func:`field_errors`).

What the form leaves out (a model's settings, conditions named apart from their model, more
than ``QUESTION_SLOTS`` questions, the finer ``[render]`` keys, ...) a study file says: the page
says so and links the reference (docs/reference/studyfile.md).
"""

from __future__ import annotations

import re
from typing import Any, Final

from wtforms import Field, Form


def _number(text: str) -> int | float | str:
    """``text`` as the number it spells, else as it is (the study file's reader names it).

    >>> _number("18"), _number("2.5"), _number("lots")
    (18, 2.5, 'lots')
    """
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def question_table(row: Form) -> dict[str, Any] | None:
    """One question row of the form as a ``[[questions]]`` table; None for a row left empty."""
    name, text = (row.name.data or "").strip(), (row.text.data or "").strip()
    if not name and not text:
        return None
    kind = row.kind.data
    out: dict[str, Any] = {
        "name": name,
        "text": text,
        "page": row.page.data,
        "type": kind,
        "required": bool(row.required.data),
    }
    if kind == "choice":
        out["choices"] = [c.strip() for c in (row.choices.data or "").splitlines() if c.strip()]
    elif kind == "number":
        for key, field in (("min", row.minimum), ("max", row.maximum)):
            if (field.data or "").strip():
                out[key] = _number(field.data.strip())
    elif row.max_length.data is not None:
        out["max_length"] = row.max_length.data
    return out


def add_settings(form: Form, data: dict[str, Any]) -> None:
    """The form's design, check, questionnaire, exclusion and rendering settings into ``data``
    (a study-file mapping), each under the study file's key."""
    data |= {
        "language": (form.language.data or "").strip() or "en",
        "block_by_clip": bool(form.block_by_clip.data),
        "posture": form.posture.data,
        "rejoin": form.rejoin.data,
        "auto_exclude": list(form.auto_exclude.data or []),
        "demographics": bool(form.demographics.data),
        "audio_check": {"kind": form.audio_check.data},
    }
    for key in ("trials", "pass_mark", "attempts"):
        value = getattr(form, f"audio_check_{key}").data
        if value is not None:  # empty: the study file's default
            data["audio_check"][key] = value
    if form.catch_kind.data:
        data.setdefault("catch", {})["kind"] = form.catch_kind.data
    if form.rating_scale.data:
        data["rating"] = {"scale": form.rating_scale.data}
    pair = [p.strip() for p in (form.practice_pair.data or "").split(",")]
    if not form.practice.data:
        data["practice"] = False
    elif pair != [""]:  # empty: the first and the last condition (none in the rating designs)
        data["practice"] = pair
    for key in ("practice_clip", "exclude"):
        value = (getattr(form, key).data or "").strip()
        if value:
            data[key] = value
    questions = [q for q in (question_table(row.form) for row in form.questions) if q]
    if questions:
        data["questions"] = questions
    render = {key: getattr(form, key).data for key in ("size", "mosaic_block")}
    render = {key: value for key, value in render.items() if value is not None}
    if form.look.data:
        render["look"] = form.look.data
    if render:
        data.setdefault("render", {}).update(render)


#: The form's field of each study-file key whose field has another name.
FORM_FIELDS: Final = {
    "rating": "rating_scale",
    "rating.scale": "rating_scale",
    "catch": "catch_trials",
    "catch.trials": "catch_trials",
    "catch.kind": "catch_kind",
    "undecided.allowed": "undecided_allowed",
    "undecided.label": "undecided_label",
    "replay.policy": "replay",
    "replay.max_plays": "max_plays",
    "answer.scale": "scale",
    "answer.reasons": "reasons",
    "attention.max_failed": "max_failed",
    "attention.screened_out_code": "screened_out_code",
    "viewing.min_face_px": "min_face_px",
    "viewing.portrait": "portrait",
    "audio_check.kind": "audio_check",
    "audio_check.trials": "audio_check_trials",
    "audio_check.pass_mark": "audio_check_pass_mark",
    "audio_check.attempts": "audio_check_attempts",
    "practice": "practice_pair",
    "render.face": "face",
    "render.size": "size",
    "render.mosaic_block": "mosaic_block",
    "render.look": "look",
    "clips": "audio",
    "conditions": "models",
}
#: A question's study-file keys whose field has another name.
_QUESTION_FIELDS: Final = {"type": "kind", "min": "minimum", "max": "maximum"}


def form_field(form: Form, key: str | None) -> Field | None:
    """The form's field the study file's ``key`` is about (``questions[1].choices``: the
    second question given, its choices), or None where the form has none."""
    if not key:
        return None
    found = re.fullmatch(r"questions\[(\d+)\]\.([a-z_]+)", key)
    if found:
        rows = [row.form for row in form.questions if question_table(row.form)]
        if int(found[1]) >= len(rows):
            return None
        name = _QUESTION_FIELDS.get(found[2], found[2])
        return rows[int(found[1])]._fields.get(name)
    name = FORM_FIELDS.get(key, key.split("[")[0].split(".")[0])
    return form._fields.get(name)


def mark_field(form: Form, key: str | None, message: str) -> None:
    """Show ``message`` beside the form's field for the study file's ``key``, if it has one."""
    field = form_field(form, key)
    if field is not None:
        field.errors = [*field.errors, message]


def field_errors(form: Form) -> list[str]:
    """Every error of the form's own validation, one line each naming the field's label (a
    question's as "Question 2, Name ...")."""
    lines = []
    for name, errors in form.errors.items():
        if name != "questions":
            lines += [f"{form[name].label.text}: {error}" for error in errors]
    for index, row in enumerate(getattr(form, "questions", [])):
        for name, errors in row.form.errors.items():
            label = row.form[name].label.text
            lines += [f"Question {index + 1}, {label}: {error}" for error in errors]
    return lines
