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


def test_the_parallel_monitor_counts_whom_the_post_screening_would_leave_out(
    app, client, participant, web
):
    """The hidden-reference post-screening as a report written now would apply it: over the
    participants it would otherwise include (an excluded one is not screened again)."""
    from app.web.models import Participant
    from app.web.study.monitor import rating_monitor
    from app.web.study.participants import remove
    from tests.support.rating import parallel_participants

    study_id = parallel_participants(app, client, participant, web, (95, 50, 40))
    with app.app_context():
        study = db.session.get(Study, study_id)
        third = db.session.scalar(sa.select(Participant).where(Participant.number == 2))
        remove(third, how="excluded", reason="asked to leave")
        db.session.commit()
        screening = rating_monitor(study)["screening"]
        rating = web.study(design="rating", catch_kind="instructed")
        assert rating_monitor(db.session.get(Study, rating))["screening"] is None
    assert screening["screened"] == 2 and list(screening["excluded"]) == ["P0001"]
    assert screening["excluded"]["P0001"].startswith("rated the hidden reference below 90 on 1")
    assert screening["rule"].startswith("Post-screening (ITU-R BS.1534-3, sec. 4.1.2")
