"""A study's life on the web: stimuli frozen once open or voted on, the pilot link, reopening
with a confirmation, copies with and without clips, deletion with its files, collaborators."""

import re
from urllib.parse import quote

import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.infra.storage import media_dir
from app.web.models import Job, Participant, Stimulus, Study, StudyList, Vote


def _page_token(client, study_id):
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    return re.search(r'name="csrf_token" (?:type="hidden" )?value="([^"]+)"', page).group(1)


def _post(client, study_id, path, **data):
    token = _page_token(client, study_id)
    return client.post(
        f"/experimenter/studies/{study_id}{path}", data={"csrf_token": token, **data}
    )


def _get(app, study_id, *attrs):
    with app.app_context():
        study = db.session.get(Study, study_id)
        return tuple(getattr(study, a) for a in attrs) if study else None


def _pilot(app, participant, study_id, choice="left"):
    """One pilot participant through the pilot link, voting ``choice`` on every trial."""
    (token,) = _get(app, study_id, "pilot_token")
    participant.client = app.test_client()
    participant.join_pilot(token)
    while (trial := participant.current_trial()) is not None:
        assert participant.vote(trial, choice).status_code == 201
    return participant.token


def test_stimuli_are_frozen_once_open(app, client, web):
    ready = web.study(status="ready")
    opened = web.study(status="open")
    web.login(client)
    assert 'id="stimuli-locked"' not in client.get(f"/experimenter/studies/{ready}").get_data(
        as_text=True
    )
    page = client.get(f"/experimenter/studies/{opened}").get_data(as_text=True)
    assert "Stimuli frozen: the study is open; duplicate the study" in page
    assert re.search(r"disabled>1\. Generate tracks", page)
    response = _post(client, opened, "/jobs/generate")
    assert response.status_code == 302
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Job.id))) == 0


def test_pilot_votes_freeze_the_stimuli_and_stay_out_of_the_export(app, client, web, participant):
    study_id = web.study(status="ready", design="all_ordered")
    web.login(client)
    _pilot(app, participant, study_id)
    with app.app_context():
        pilot = db.session.scalar(sa.select(Participant))
        assert pilot.pilot and pilot.finished_at is not None
    assert "participants have voted" in client.get(f"/experimenter/studies/{study_id}").get_data(
        as_text=True
    )
    _post(client, study_id, "/jobs/render")
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Job.id))) == 0
    export = client.get(f"/experimenter/studies/{study_id}/votes.csv").get_data(as_text=True)
    assert export.count("\n") == 1  # the header only
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert re.search(r'id="stat-joined">0<', monitor) and "no: pilot" in monitor
    pilots = client.get(f"/experimenter/studies/{study_id}/votes.csv?pilot=only").get_data(
        as_text=True
    )
    assert pilots.count("\n") == 5 and ",pilot," in pilots
    # Opening gives the pilot's list slot back: real participants are balanced alone.
    _post(client, study_id, "/status/open")
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.sum(StudyList.n_assigned))) == 0


def test_the_pilot_link_passes_through_the_consent_page(app, web, participant):
    study_id = web.study(status="ready", design="all_ordered")
    (token,) = _get(app, study_id, "pilot_token")
    participant.client = app.test_client()
    url = f"/experimenter/pilot/{token}"
    page = participant.client.get(url).get_data(as_text=True)
    assert "Before you start" in page and "You agree to take part." in page
    assert f'action="{url}"' in page
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 0  # not yet
    # Without the form's token nothing happens; agreeing enrols a pilot.
    assert participant.client.post(url).status_code == 400
    participant.join_pilot(token)
    with app.app_context():
        assert db.session.scalar(sa.select(Participant.pilot)) is True
    assert participant.current_trial() is not None


def test_the_pilot_link_needs_rendered_clips_and_its_secret(app, client, web):
    draft = web.study(video=False)
    (token,) = _get(app, draft, "pilot_token")
    assert client.get(f"/experimenter/pilot/{token}").status_code == 503
    assert client.get("/experimenter/pilot/not-the-token").status_code == 404
    (slug,) = _get(app, draft, "slug")
    assert client.get(f"/experimenter/pilot/{slug}").status_code == 404


def test_reopen_needs_the_tick(app, client, web):
    study_id = web.study(status="closed")
    web.login(client)
    _post(client, study_id, "/reopen")
    assert _get(app, study_id, "status") == ("closed",)
    assert _post(client, study_id, "/status/reopen").status_code == 400
    _post(client, study_id, "/reopen", confirm="y")
    assert _get(app, study_id, "status") == ("open",)


def test_duplicate_with_and_without_clips(app, client, web, participant):
    study_id = web.study(design="all_ordered")
    web.login(client)
    (slug,) = _get(app, study_id, "slug")
    participant.join(slug)
    bare = _post(client, study_id, "/duplicate")
    bare_id = int(bare.headers["Location"].rsplit("/", 1)[1])
    full = _post(client, study_id, "/duplicate", with_clips="y")
    full_id = int(full.headers["Location"].rsplit("/", 1)[1])
    with app.app_context():
        original, copy, rendered = (db.session.get(Study, i) for i in (study_id, bare_id, full_id))
        for other in (copy, rendered):
            assert other.title == "Test study (copy)"
            assert [p.label for p in other.pairs] == [p.label for p in original.pairs]
            assert (other.slug, other.pilot_token, other.pseudonym_key) != (
                original.slug,
                original.pilot_token,
                original.pseudonym_key,
            )
            assert (
                db.session.scalar(
                    sa.select(sa.func.count(Participant.id)).where(Participant.study_id == other.id)
                )
                == 0
            )
            assert (media_dir(other) / other.clips[0].audio_path).is_file()
        assert (copy.status, rendered.status) == ("draft", "ready")
        videos = db.session.scalars(
            sa.select(Stimulus.video_path).where(Stimulus.study_id == rendered.id)
        ).all()
        assert videos and all((media_dir(rendered) / v).is_file() for v in videos)
        assert set(
            db.session.scalars(sa.select(Stimulus.video_path).where(Stimulus.study_id == copy.id))
        ) == {None}


def test_delete_needs_the_title_and_removes_files(app, client, web, participant):
    study_id = web.study(design="all_ordered")
    (slug,) = _get(app, study_id, "slug")
    participant.join(slug)
    participant.vote(participant.current_trial())
    web.login(client)
    with app.app_context():
        folder = media_dir(db.session.get(Study, study_id))
    assert folder.is_dir()
    _post(client, study_id, "/delete", title="Test stud")
    assert _get(app, study_id, "status") == ("open",)
    response = _post(client, study_id, "/delete", title="Test study")
    assert response.headers["Location"] == "/experimenter/"
    assert _get(app, study_id, "status") is None
    assert not folder.exists()
    with app.app_context():
        for model in (Participant, Vote, Stimulus, StudyList):
            assert db.session.scalar(sa.select(sa.func.count(model.id))) == 0


def test_collaborators_read_only_or_full(app, client, web):
    study_id = web.study(status="ready")
    web.user("reader@example.org")
    web.user("runner@example.org")
    web.login(client)
    _post(client, study_id, "/shares", email="Reader@example.org", access="read")
    _post(client, study_id, "/shares", email="runner@example.org", access="full")
    _post(client, study_id, "/shares", email="nobody@example.org", access="full")
    reader, runner = app.test_client(), app.test_client()
    web.login(reader, "reader@example.org")
    web.login(runner, "runner@example.org")
    listing = reader.get("/experimenter/").get_data(as_text=True)
    assert f"/experimenter/studies/{study_id}" in listing
    assert "(shared by exp@example.org)" in listing
    for path in ("", "/monitor", "/votes.csv", "/participants.csv"):
        assert reader.get(f"/experimenter/studies/{study_id}{path}").status_code == 200
    assert (
        reader.get(f"/experimenter/studies/{study_id}/participants.csv?ids=raw").status_code == 403
    )
    token = web.csrf(reader, "/experimenter/")
    assert (
        reader.post(
            f"/experimenter/studies/{study_id}/status/open", data={"csrf_token": token}
        ).status_code
        == 403
    )
    _post(runner, study_id, "/status/open")
    assert _get(app, study_id, "status") == ("open",)
    # Only the owner deletes or shares.
    assert _post(runner, study_id, "/delete", title="Test study").status_code == 403
    assert _post(runner, study_id, "/shares", email="reader@example.org").status_code == 403
    # A stranger learns nothing.
    stranger = app.test_client()
    web.user("stranger@example.org")
    web.login(stranger, "stranger@example.org")
    assert stranger.get(f"/experimenter/studies/{study_id}").status_code == 404
    # The progress of the study's jobs, as the study page polls it.
    _post(client, study_id, "/jobs/report")
    with app.app_context():
        job_id = db.session.scalar(sa.select(Job.id))
    assert reader.get(f"/api/v1/jobs/{job_id}").status_code == 200
    assert stranger.get(f"/api/v1/jobs/{job_id}").status_code == 404


def test_lifecycle_forms_never_answer_5xx(app, client, web):
    study_id = web.study(status="closed")
    web.login(client)
    token = _page_token(client, study_id)
    text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=80)

    @settings(
        max_examples=60,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(title=text, email=text, access=text, confirm=text, who=text, how=text)
    def hostile(title, email, access, confirm, who, how):
        base = f"/experimenter/studies/{study_id}"
        for path, data in (
            ("/delete", {"title": title}),
            ("/shares", {"email": email, "access": access}),
            ("/participants/exclude", {"participant": who, "how": how, "reason": title}),
            ("/participants/restore", {"participant": who}),
        ):
            response = client.post(base + path, data={"csrf_token": token, **data})
            assert response.status_code == 302, response.get_data(as_text=True)[-300:]
        assert client.get(f"/experimenter/pilot/{quote(who, safe='')}").status_code < 500
        pilot = client.post(f"/experimenter/pilot/{quote(who, safe='')}", data={"agree": how})
        assert pilot.status_code < 500

    hostile()
    assert _get(app, study_id, "status") == ("closed",)


def test_a_pilot_still_voting_after_opening_takes_no_slot(app, client, web, participant):
    study_id = web.study(status="ready", design="all_ordered")
    (token,) = _get(app, study_id, "pilot_token")
    participant.client = app.test_client()
    participant.join_pilot(token)
    assert participant.vote(participant.current_trial()).status_code == 201
    web.login(client)
    _post(client, study_id, "/status/open")
    assert participant.vote(participant.current_trial()).status_code == 201
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.sum(StudyList.n_assigned))) == 0


def test_a_study_with_onscreen_checks_duplicates_with_its_stimulus_variants(app, client, web):
    study_id = web.study(catch=1, catch_kind="onscreen")
    web.login(client)
    copies = [
        int(_post(client, study_id, "/duplicate", **extra).headers["Location"].rsplit("/", 1)[1])
        for extra in ({}, {"with_clips": "y"})
    ]

    def variants(sid):
        with app.app_context():
            rows = db.session.execute(
                sa.select(Stimulus.instruction, Stimulus.foreign_side).where(
                    Stimulus.study_id == sid
                )
            ).all()
        return sorted(rows, key=repr)

    original = variants(study_id)
    assert any(instruction for instruction, _ in original)  # the check's on-screen instruction
    for copy in copies:
        assert variants(copy) == original
