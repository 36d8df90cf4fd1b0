"""The ``facepair prolific`` commands the whole-flow test does not take: subscribing the webhook
(``hooks``), answering no before publishing, the pilot's test study, a ``[prolific]`` table of
its own file, the bonus rule and the top-up proposal, each against the fake Prolific."""

from __future__ import annotations

import sqlalchemy as sa

from app.web.extensions import db
from app.web.prolific.models import ProlificStudy
from tests.web.prolific.conftest import cli, take_part

HOOK = "https://facepair.example.org/api/v1/prolific/webhook"


def test_hooks_subscribe_once_and_show_the_new_secret_once(prolific_env):
    fake = prolific_env
    refused = cli("hooks", "http://facepair.example.org/api/v1/prolific/webhook")
    assert refused.exit_code == 2 and "https://" in refused.output
    assert not fake.subscriptions

    made = cli("hooks", HOOK, "--new-secret")
    assert made.exit_code == 0, made.output
    assert fake.secret.startswith("whsec-") and made.output.count(fake.secret) == 1
    for event_type in ("submission.status.change", "study.status.change"):
        assert f"{event_type}: subscribed" in made.output
    assert len(fake.subscriptions) == 2
    assert all(s["is_enabled"] and s["target_url"] == HOOK for s in fake.subscriptions.values())

    again = cli("hooks", HOOK)
    assert again.exit_code == 0 and again.output.count("already subscribed") == 2
    assert fake.secret not in again.output and len(fake.subscriptions) == 2


def _live(app, *, pilot: bool = False) -> ProlificStudy:
    with app.app_context():
        row = db.session.scalars(sa.select(ProlificStudy).where(ProlificStudy.pilot == pilot)).one()
        db.session.expunge(row)
        return row


def test_no_at_the_prompt_leaves_the_draft_and_the_pilot_gets_a_test_study(
    app, prolific_env, recruiting_study
):
    fake = prolific_env
    declined = cli("publish", str(recruiting_study), input="n\n")
    assert declined.exit_code == 0 and "not published: the draft waits" in declined.output
    draft = _live(app)
    assert fake.studies[draft.prolific_id]["status"] == "UNPUBLISHED"
    assert fake.count("publish") == 0

    published = cli("publish", str(recruiting_study), input="y\n")
    assert published.exit_code == 0, published.output
    assert fake.count("create") == 1 and fake.count("publish") == 1  # the same draft

    piloted = cli("publish", str(recruiting_study), "--pilot", "--yes")
    assert piloted.exit_code == 0, piloted.output
    pilot = _live(app, pilot=True)
    assert "/pilot/" in fake.studies[pilot.prolific_id]["external_study_url"]
    assert fake.count("test_study") == 1 and pilot.test_study_id in fake.studies
    assert cli("publish", str(recruiting_study), "--pilot", "--yes").exit_code == 0
    assert fake.count("test_study") == 1 and fake.count("create") == 2


def test_a_prolific_table_of_its_own_file(app, web, prolific_env, tmp_path):
    fake = prolific_env
    study_id = web.study()
    with app.app_context():
        from app.web.models import Study

        db.session.get_one(Study, study_id).redirect_url = ""
        db.session.commit()
    missing = cli("publish", str(study_id), "--yes")
    assert missing.exit_code == 2 and "prolific" in missing.output
    table = tmp_path / "prolific.toml"
    table.write_text("[prolific]\nreward = 200\nplaces = 3\nminutes = 4\n", encoding="utf-8")
    made = cli("publish", str(study_id), "--yes", "--prolific-file", str(table))
    assert made.exit_code == 0, made.output
    (study,) = fake.studies.values()
    assert (study["reward"], study["total_available_places"]) == (200, 3)
    assert "3 places x 2.00 GBP = 6.00 GBP" in made.output


def test_the_bonus_rule_and_the_topup_proposal(app, prolific_env, recruiting_study):
    fake = prolific_env
    assert cli("publish", str(recruiting_study), "--yes").exit_code == 0
    prolific_id = _live(app).prolific_id
    (s1, p1), (s2, p2) = fake.start(prolific_id), fake.start(prolific_id)
    take_part(app, recruiting_study, prolific_id, s1, p1)  # the catch trial answered well
    take_part(app, recruiting_study, prolific_id, s2, p2, catch="left")
    fake.submit(s1, "DONE-123")
    fake.submit(s2, "DONE-123")
    assert cli("sync", str(recruiting_study)).exit_code == 0

    ruled = cli("bonus", str(recruiting_study), "--rule", "--yes")
    assert ruled.exit_code == 0, ruled.output
    assert fake.submissions[s1]["bonus_payments"] == [10]  # bonus_per_check = "0.10"
    assert fake.submissions[s2]["bonus_payments"] == []
    again = cli("bonus", str(recruiting_study), "--rule", "--yes")
    assert "nothing paid now" in again.output and fake.count("pay") == 1

    # 4 places, 2 submitted: 1 counted (the other failed its check), none under way, 2 free;
    # a target of 6 needs 6 - 1 - 2 = 3 more places
    asked = cli("topup", str(recruiting_study), "--target", "6", input="n\n")
    assert asked.exit_code == 0 and "1 counted of 6 needed" in asked.output
    assert "Raise the places from 4 to 7?" in asked.output
    assert fake.studies[prolific_id]["total_available_places"] == 4
    raised = cli("topup", str(recruiting_study), "--target", "6", "--yes")
    assert raised.exit_code == 0 and fake.studies[prolific_id]["total_available_places"] == 7
    enough = cli("topup", str(recruiting_study), "--target", "2", "--yes")
    assert "no more places needed" in enough.output and fake.count("top_up") == 1
