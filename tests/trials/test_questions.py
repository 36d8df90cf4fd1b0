"""Questionnaire questions in study files, and checking a participant's answers."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.errors import InputError
from app.trials.questions import DEMOGRAPHICS, QuestionSpec, check_answer
from app.trials.studyfile import loads_study

BASE = """
title = "T"
question = "Q?"
{extra}
[[conditions]]
name = "none"
[[conditions]]
name = "random"
[[clips]]
name = "s1"
audio = "s1.wav"
{tables}
"""


def _load(extra="", tables=""):
    return loads_study(BASE.format(extra=extra, tables=tables), check_files=False)


def test_demographics_and_own_questions_in_file_order():
    spec = _load(
        "demographics = true",
        """
[[questions]]
name = "comments"
text = "Anything to tell us?"
page = "after"
required = false
max_length = 1000
[[questions]]
name = "hours"
text = "Hours of screen time a day"
type = "number"
min = 0
max = 24
""",
    )
    assert [q.name for q in spec.questions] == [q.name for q in DEMOGRAPHICS] + [
        "comments",
        "hours",
    ]
    assert spec.questions[-2] == QuestionSpec(
        "comments", "Anything to tell us?", page="after", max_length=1000, required=False
    )
    assert (spec.questions[-1].minimum, spec.questions[-1].maximum) == (0, 24)
    again = loads_study(spec.to_toml(), check_files=False)
    assert again.questions == spec.questions


@pytest.mark.parametrize(
    ("tables", "message"),
    [
        (
            '[[questions]]\nname = "a"\ntext = "A"\ntype = "choice"\nchoices = ["x"]',
            "questions[0].choices: expected two or more non-empty strings",
        ),
        (
            '[[questions]]\nname = "a"\ntext = "A"\ntype = "text"\nmin = 1',
            "questions[0].min: does not apply to type = 'text'",
        ),
        (
            '[[questions]]\nname = "a"\ntext = "A"\ntype = "number"\nmin = 5\nmax = 1',
            "questions[0].max: must be >= min (5), got 1",
        ),
        (
            '[[questions]]\nname = "a"\ntext = "A"\npage = "during"',
            "questions[0].page: expected one of before, after, got 'during'",
        ),
        (
            '[[questions]]\nname = "gender"\ntext = "G"',
            "questions[0].name: repeats question name 'gender' (a demographics question)",
        ),
        (
            '[[questions]]\nname = "a"\ntext = "A"\nmax_length = 100000',
            "questions[0].max_length: must be <= 5000, got 100000",
        ),
    ],
)
def test_bad_questions_are_one_line(tables, message):
    with pytest.raises(InputError) as caught:
        _load("demographics = true", tables)
    assert str(caught.value) == f"study.toml: {message}"


def test_answers_are_checked():
    age = QuestionSpec("age", "Age", kind="number", minimum=18, maximum=99)
    assert check_answer(age, "42") == 42.0
    for bad, message in (
        ("", "age: an answer is required"),
        ("x", "age: expected a number, got 'x'"),
        ("nan", "age: expected a number, got 'nan'"),
        ("100", "age: must be at most 99, got 100"),
    ):
        with pytest.raises(InputError) as caught:
            check_answer(age, bad)
        assert str(caught.value) == message
    band = DEMOGRAPHICS[0]
    assert check_answer(band, "25-34") == "25-34"
    with pytest.raises(InputError, match="choose one of the options"):
        check_answer(band, "26")
    note = QuestionSpec("note", "Note", required=False, max_length=5)
    assert check_answer(note, "  ") is None
    with pytest.raises(InputError, match="at most 5 characters, got 6"):
        check_answer(note, "abcdef")


@given(
    st.sampled_from(
        [
            *DEMOGRAPHICS,
            QuestionSpec("n", "N", kind="number", minimum=0),
            QuestionSpec("t", "T", max_length=10, required=False),
        ]
    ),
    st.one_of(st.none(), st.text(max_size=30)),
)
def test_any_answer_is_a_value_or_one_line(question, raw):
    try:
        value = check_answer(question, raw)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(question.name + ": ")
    else:
        assert value is None or value == value  # never NaN
