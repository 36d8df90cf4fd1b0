"""Recording a vote (``app.web.study.votes``): the choice and replay checks come from
``app.trials.rules``, and the database refuses a choice the rules do not know."""

import secrets

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy.exc import IntegrityError

from app.trials.rules import CHOICES, ReplayPolicy
from app.web.extensions import db
from app.web.models import Participant, Study, Vote
from app.web.study.votes import AnswerRejected, VoteRejected, may_vote, record_vote, replay_policy


def _person(app, participant, web, **toml) -> tuple[str, int]:
    study_id = web.study(**toml)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    token = participant.join(slug)
    return token, participant.current_trial()


def _payload(trial_id: int, choice: object = "left", **extra) -> dict:
    return {
        "trial_id": trial_id,
        "choice": choice,
        "plays": 1,
        "watched_to_end": True,
        "idempotency_key": "vote-key-0001",
        **extra,
    }


def _record(app, token: str, payload: dict):
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        try:
            outcome = record_vote(person, payload)
            db.session.commit()
            return outcome.vote.choice
        except AnswerRejected as exc:
            db.session.rollback()
            return exc


def test_the_database_refuses_a_choice_the_rules_do_not_know(app, participant, web):
    token, trial = _person(app, participant, web)
    assert _record(app, token, _payload(trial)) == "left"
    with app.app_context():
        with pytest.raises(IntegrityError):
            db.session.execute(sa.update(Vote).values(choice="sideways"))
            db.session.flush()
        db.session.rollback()
        assert db.session.scalars(sa.select(Vote.choice)).all() == ["left"]


def test_a_refused_choice_names_the_field_and_the_allowed_choices(app, participant, web):
    token, trial = _person(app, participant, web, undecided=False)
    refused = _record(app, token, _payload(trial, "undecided"))
    assert isinstance(refused, VoteRejected) and refused.status == 400
    assert refused.message == "choice: expected one of left, right, got 'undecided'"
    assert _record(app, token, _payload(trial, "right")) == "right"


def test_the_replay_refusals_come_from_the_rules(app, participant, web):
    token, trial = _person(app, participant, web, replay="max_plays", max_plays=2)
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        assert replay_policy(study) == ReplayPolicy("max_plays", max_plays=2)
        assert may_vote(study, plays=0, watched_to_end=True) == (
            "plays: the clip must be played before voting"
        )
        assert may_vote(study, plays=3, watched_to_end=True) == (
            "plays: at most 2 plays are allowed"
        )
        assert may_vote(study, plays=2, watched_to_end=False) is None
        study.replay, study.max_plays = "play_to_end", None
        assert may_vote(study, plays=1, watched_to_end=False).startswith("watched_to_end:")


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    choice=st.one_of(
        st.sampled_from(CHOICES),
        st.text(max_size=60),
        st.integers(),
        st.none(),
        st.lists(st.sampled_from(CHOICES), max_size=2),
    )
)
def test_any_choice_is_stored_or_refused_with_one_line(app, participant, web, choice):
    if participant.token is None:
        _person(app, participant, web)
    trial = participant.current_trial()
    if trial is None:
        return
    result = _record(
        app, participant.token, _payload(trial, choice, idempotency_key=secrets.token_hex(8))
    )
    if isinstance(result, VoteRejected):
        assert result.status < 500 and "\n" not in result.message
        assert result.message.startswith("choice: ")
    else:
        assert result in CHOICES and result == choice
