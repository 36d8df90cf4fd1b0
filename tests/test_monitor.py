"""The live monitor (``app.web.study.monitor``): tallies per pair, by choice and by condition."""

import datetime as dt

import sqlalchemy as sa

from app.trials.rules import CHOICES
from app.web.extensions import db
from app.web.models import Study
from app.web.study.monitor import study_monitor


def test_votes_are_tallied_per_choice_and_per_condition(app, participant, web):
    study_id = web.study(design="all_ordered")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    answers = ["left", "right", "undecided", "left"]
    for choice in answers:
        trial = participant.current_trial()
        assert participant.vote(trial, choice).status_code == 201
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        seen = study_monitor(study, dropped_after=dt.timedelta(hours=1))
    assert seen["joined"] == 1 and sum(seen["statuses"].values()) == 1
    assert seen["votes"] == len(answers)
    assert all(set(p.choices) == set(CHOICES) for p in seen["pairs"])
    totals = {c: sum(p.choices[c] for p in seen["pairs"]) for c in CHOICES}
    assert totals == {"left": 2, "right": 1, "undecided": 1}
    assert sum(p.first + p.second for p in seen["pairs"]) == 3  # the undecided vote is neither
