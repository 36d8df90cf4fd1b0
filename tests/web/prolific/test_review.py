"""Review: a proposal per submission from facepair's verdicts, and decisions refused in one line
when Prolific would refuse them (a rejection's category and 100-character message)."""

from __future__ import annotations

import pytest

from app.errors import InputError
from app.web.extensions import db
from app.web.models import Study
from app.web.prolific.models import ProlificStudy, ProlificSubmission
from app.web.prolific.review import MIN_MESSAGE, NO_DATA, Decision, check, proposals
from tests.web.prolific.conftest import take_part


def test_proposals_follow_facepairs_verdicts(app, prolific_env, recruiting_study):
    take_part(app, recruiting_study, "P1", "s-fine", "fine1")
    take_part(app, recruiting_study, "P1", "s-catch", "catch1", catch="left")
    take_part(app, recruiting_study, "P1", "s-half", "half1", finish=False)
    with app.app_context():
        db.session.add(ProlificStudy(study_id=recruiting_study, prolific_id="P1"))
        for sid, pid in (
            ("s-fine", "fine1"),
            ("s-catch", "catch1"),
            ("s-half", "half1"),
            ("s-none", "none1"),
        ):
            db.session.add(
                ProlificSubmission(
                    study_id=recruiting_study,
                    submission_id=sid,
                    prolific_pid=pid,
                    status="AWAITING REVIEW",
                )
            )
        db.session.add(
            ProlificSubmission(
                study_id=recruiting_study,
                submission_id="s-late",
                prolific_pid="late1",
                status="ACTIVE",
            )
        )
        db.session.commit()
        found = {p.submission_id: p for p in proposals(db.session.get(Study, recruiting_study))}
    assert found["s-fine"].action == "approve" and found["s-fine"].open
    assert (found["s-catch"].action, found["s-catch"].category) == ("reject", "FAILED_CHECK")
    assert len(found["s-catch"].message) >= MIN_MESSAGE
    assert (found["s-half"].action, found["s-half"].return_reason) == (
        "return",
        "Didn't finish the study",
    )
    assert (found["s-none"].action, found["s-none"].message) == ("reject", NO_DATA)
    assert len(NO_DATA) >= MIN_MESSAGE
    assert found["s-late"].action == "none"


def test_decisions_prolific_would_refuse():
    with pytest.raises(InputError, match="category: expected one of TOO_QUICKLY"):
        check(Decision("s", "reject", "RUDE", "x" * 120))
    with pytest.raises(InputError, match="at least 100 characters for a rejection, got 5"):
        check(Decision("s", "reject", "LOW_EFFORT", "short"))
    with pytest.raises(InputError, match="give at least one reason"):
        check(Decision("s", "return", reasons=(" ",)))
    check(Decision("s", "reject", "LOW_EFFORT", "y" * 100))
