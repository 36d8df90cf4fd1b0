"""Spreadsheet formulas in exported CSV cells are neutralised (OWASP "CSV Injection"), numbers
stay numbers, and every export is sent uncached."""

import csv
import io
import re

import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant, Study
from app.web.study.csvcells import FORMULA_STARTS, csv_text, safe_cell, safe_csv

PID = "5f2a0c7e9b1d3e4f5a6b7c8d"
NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
QUESTIONS = """[[questions]]
name = "comments"
text = "Any comments?"
page = "after"
required = false
"""
# NUL is refused at input (app.web.infra.limits) and PostgreSQL cannot store it.
cell_text = st.text(
    st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=40
)


def _unsafe(cell: str) -> bool:
    return cell.startswith(FORMULA_STARTS) and not NUMBER.fullmatch(cell)


def _cells(text: str) -> list[str]:
    return [cell for row in csv.reader(io.StringIO(text, newline="")) for cell in row]


def test_known_cells():
    assert safe_cell('=HYPERLINK("http://x","y")') == '\'=HYPERLINK("http://x","y")'
    assert safe_cell("@SUM(A1)") == "'@SUM(A1)"
    assert safe_cell("\t=1") == "'\t=1" and safe_cell("\r+1") == "'\r+1"
    assert safe_cell("-1+2") == "'-1+2" and safe_cell("-inf") == "'-inf"
    for number in ("-1", "+2.5", "-.5", "1e-3", "-3E+4"):
        assert safe_cell(number) == number
    assert safe_cell(-1) == -1 and safe_cell(None) is None and safe_cell(PID) == PID


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(cell_text, min_size=2, max_size=2), max_size=5), cell_text)
def test_no_parsed_cell_is_a_formula(rows, name):
    text = csv_text([name, "b"], rows)
    assert not any(_unsafe(cell) for cell in _cells(text))
    assert safe_csv(text) == text  # neutralising twice changes nothing
    parsed = list(csv.reader(io.StringIO(text, newline="")))
    for row, back in zip(rows, parsed[1:], strict=True):
        assert [c[1:] if c != o else c for c, o in zip(back, row, strict=True)] == row


def _study_with_a_participant(app, web):
    from tests.conftest import ParticipantActions

    study_id = web.study(design="all_ordered", extra=QUESTIONS)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    person = ParticipantActions(app.test_client(), app)
    person.join(slug, f"PROLIFIC_PID={PID}&STUDY_ID=study-xyz&SESSION_ID=session-{PID}")
    while (trial := person.current_trial()) is not None:
        person.vote(trial, "left")
    return study_id


def _set_comment(app, text: str) -> None:
    with app.app_context():
        person = db.session.scalar(sa.select(Participant))
        person.answers = {"after": {"comments": text}}
        db.session.commit()


def test_a_formula_answer_is_text_and_the_ids_are_kept(app, client, web):
    study_id = _study_with_a_participant(app, web)
    _set_comment(app, '=HYPERLINK("http://x","y")')
    web.login(client)
    base = f"/experimenter/studies/{study_id}"
    answers = client.get(f"{base}/answers.csv")
    assert answers.headers["Cache-Control"] == "no-store"
    row = next(csv.DictReader(io.StringIO(answers.get_data(as_text=True))))
    assert row["comments"] == '\'=HYPERLINK("http://x","y")'
    raw = client.get(f"{base}/participants.csv?ids=raw")
    assert raw.headers["Cache-Control"] == "no-store"
    assert next(csv.DictReader(io.StringIO(raw.get_data(as_text=True))))["prolific_pid"] == PID
    votes = client.get(f"{base}/votes.csv")
    assert votes.headers["Cache-Control"] == "no-store"
    assert not any(_unsafe(cell) for cell in _cells(votes.get_data(as_text=True)))


def test_no_export_cell_is_a_formula(app, client, web):
    study_id = _study_with_a_participant(app, web)
    web.login(client)
    base = f"/experimenter/studies/{study_id}"

    @settings(
        max_examples=25,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(cell_text)
    def exported(text):
        _set_comment(app, text)
        for name in ("answers.csv", "participants.csv", "votes.csv"):
            body = client.get(f"{base}/{name}").get_data(as_text=True)
            assert not any(_unsafe(cell) for cell in _cells(body)), name

    exported()
