import csv
import io
import re
import sys
import types

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Job, Participant, Stimulus, Study, Track, User
from tests.conftest import PASSWORD
from tests.support.studies import study_slug


def _post(client, url, **data):
    """POST a state-changing button with the CSRF token of the page it sits on."""
    return client.post(url, data={"csrf_token": _page_token(client), **data})


def _page_token(client):
    page = client.get("/experimenter/").get_data(as_text=True)
    return re.search(r'name="csrf_token" value="([^"]+)"', page).group(1)


def test_login_logout_and_protection(app, client, web):
    web.user()
    assert client.get("/experimenter/").headers["Location"].startswith("/experimenter/login")
    bad = web.login(client, password="wrong password")
    assert bad.status_code == 200 and b"wrong password" in bad.data
    good = web.login(client)
    assert good.status_code == 302 and good.headers["Location"] == "/experimenter/"
    assert client.get("/experimenter/").status_code == 200
    assert client.get("/").headers["Location"] == "/experimenter/"
    # No CSRF token: refused.
    assert client.post("/experimenter/logout").status_code == 400
    assert _post(client, "/experimenter/logout").status_code == 302
    assert client.get("/experimenter/").status_code == 302


def test_login_never_redirects_off_site(app, client, web):
    web.user()
    token = web.csrf(client, "/experimenter/login")
    response = client.post(
        "/experimenter/login?next=//evil.example/x",
        data={"csrf_token": token, "email": "exp@example.org", "password": PASSWORD},
    )
    assert response.headers["Location"] == "/experimenter/"


def test_passwords_are_hashed(app, web):
    web.user()
    with app.app_context():
        user = db.session.scalar(sa.select(User))
        assert PASSWORD not in user.password_hash and user.check_password(PASSWORD)


def test_each_experimenter_sees_only_their_studies(app, client, web):
    mine = web.study(owner_email="exp@example.org")
    theirs = web.study(owner_email="other@example.org")
    web.login(client)
    listing = client.get("/experimenter/").get_data(as_text=True)
    assert f"/experimenter/studies/{mine}" in listing
    assert f"/experimenter/studies/{theirs}" not in listing
    for path in ("", "/monitor", "/votes.csv", "/report/"):
        assert client.get(f"/experimenter/studies/{theirs}{path}").status_code == 404
    assert _post(client, f"/experimenter/studies/{theirs}/status/close").status_code == 404


def _upload_study(client, web, text: str, media=()):
    """Log in and post ``text`` as an uploaded study file with ``media`` (paths) beside it."""
    web.user()
    web.login(client)
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    token = re.search(r'name="file-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    data = {
        "file-csrf_token": token,
        "file-submit": "1",
        "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
    }
    if media:
        data["file-media"] = [(path.open("rb"), path.name) for path in media]
    return client.post("/experimenter/studies/new", content_type="multipart/form-data", data=data)


def test_create_study_from_uploaded_file(app, client, web, tmp_path):
    wav = web.write_wav(tmp_path / "s1.wav")
    response = _upload_study(client, web, web.toml(design="all_ordered"), [wav])
    assert response.status_code == 302, response.get_data(as_text=True)
    study_id = int(response.headers["Location"].rsplit("/", 1)[1])
    with app.app_context():
        study = db.session.get(Study, study_id)
        assert (study.title, study.design, len(study.pairs), study.status) == (
            "Test study",
            "all_ordered",
            4,
            "draft",
        )
        assert "Test study" in study.source_toml
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    assert "0 of 4 clips rendered" in page and "/s/" in page


def test_bad_study_file_gives_one_clear_line(app, client, web, tmp_path):
    wav = web.write_wav(tmp_path / "s1.wav")
    response = _upload_study(client, web, web.toml(design="zigzag"), [wav])
    assert response.status_code == 400
    assert "study.toml: design: expected one of" in response.get_data(as_text=True)


def test_uploaded_study_file_cannot_reach_outside_its_upload(app, client, web, tmp_path):
    # A study file on the server names its own media; an uploaded one must not read the
    # server's files (here a WAV that exists, outside the upload folder).
    outside = web.write_wav(tmp_path / "outside.wav")
    text = web.toml().replace('audio = "s1.wav"', f'audio = "{outside}"')
    response = _upload_study(client, web, text)
    assert response.status_code == 400
    assert "study.toml" in response.get_data(as_text=True)
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count()).select_from(Study)) == 0


def test_the_web_form_takes_an_avatar_and_the_lips_and_padding(app, client, web, tmp_path):
    """An avatar made by another tool (Ready Player Me's structure), with a sidecar, uploaded
    on the form: kept beside the study's media and named by [render] face."""
    from app.web.infra.storage import media_dir
    from tests.renderer.avatar_fixtures import build_avatar

    web.user()
    web.login(client)
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    token = re.search(r'name="web-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    wav = web.write_wav(tmp_path / "clip_a.wav")
    avatar = build_avatar("rpm", tmp_path, name="Her Avatar.glb")
    sidecar = tmp_path / "Her Avatar.avatar.json"
    sidecar.write_text('{"bones": {"head": "Head"}}')
    from werkzeug.test import EnvironBuilder

    builder = EnvironBuilder(
        path="/experimenter/studies/new",
        method="POST",
        content_type="multipart/form-data",
        data={
            "web-csrf_token": token,
            "web-submit": "1",
            "web-title": "Avatar study",
            "web-question": "Which one?",
            "web-models": ["none", "random"],
            "web-audio": [(io.BytesIO(wav.read_bytes()), "clip_a.wav")],
            "web-face": [(io.BytesIO(p.read_bytes()), p.name) for p in (avatar, sidecar)],
            "web-lips": "own",
            "web-pad": "y",
            "web-design": "all_ordered",
            "web-undecided_allowed": "y",
            "web-undecided_label": "Same",
            "web-replay": "unlimited",
            "web-catch_trials": "0",
            "web-target_participants": "12",
            "web-seed": "5",
        },
    )
    environ = builder.get_environ()
    try:  # a body of megabytes is spooled to a file, which the test client leaves open
        response = client.open(environ)
    finally:
        environ["wsgi.input"].close()
        builder.close()
    assert response.status_code == 302, response.get_data(as_text=True)
    with app.app_context():
        study = db.session.scalar(sa.select(Study).where(Study.title == "Avatar study"))
        face = study.settings["render"]["face"]
        assert face == "render/Her_Avatar.glb"
        assert (media_dir(study) / "render" / "Her_Avatar.avatar.json").is_file()
        assert (study.settings["lips"], study.settings["pad"]) == ("own", True)
        assert 'face = "Her_Avatar.glb"' in study.source_toml or "Her Avatar.glb" in (
            study.source_toml
        )


def test_an_avatar_that_does_not_load_is_refused_at_upload(app, client, web, tmp_path):
    web.user()
    web.login(client)
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    token = re.search(r'name="file-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    wav = web.write_wav(tmp_path / "s1.wav")
    text = web.toml() + '\n[render]\nface = "broken.glb"\n'
    response = client.post(
        "/experimenter/studies/new",
        content_type="multipart/form-data",
        data={
            "file-csrf_token": token,
            "file-submit": "1",
            "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
            "file-media": [
                (io.BytesIO(wav.read_bytes()), "s1.wav"),
                (io.BytesIO(b"glTF junk"), "broken.glb"),
            ],
        },
    )
    assert response.status_code == 400
    page = response.get_data(as_text=True)
    assert "broken.glb: the face of [render]: not a readable glTF 2.0 / VRM file" in page
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count()).select_from(Study)) == 0


def test_create_study_from_web_form(app, client, web, tmp_path):
    web.user()
    web.login(client)
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    token = re.search(r'name="web-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    wav = web.write_wav(tmp_path / "clip_a.wav")
    track = tmp_path / "uploaded__clip_a.fap"
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack

    write_fap(MotionTrack.zeros(30.0, 15, channels=(48,)), track)
    response = client.post(
        "/experimenter/studies/new",
        content_type="multipart/form-data",
        data={
            "web-csrf_token": token,
            "web-submit": "1",
            "web-title": "Form study",
            "web-question": "Which one?",
            "web-models": ["none"],
            "web-audio": [(wav.open("rb"), "clip_a.wav")],
            "web-tracks": [(track.open("rb"), "uploaded__clip_a.fap")],
            "web-design": "reference",
            "web-reference": "none",
            "web-undecided_allowed": "y",
            "web-undecided_label": "Same",
            "web-replay": "max_plays",
            "web-max_plays": "2",
            "web-catch_trials": "0",
            "web-target_participants": "12",
            "web-seed": "5",
            "web-completion_code": "XYZ",
            "web-redirect_url": "https://example.org/done",
        },
    )
    assert response.status_code == 302, response.get_data(as_text=True)
    with app.app_context():
        study = db.session.scalar(sa.select(Study).where(Study.title == "Form study"))
        assert [(c.name, c.model) for c in study.conditions] == [
            ("none", "none"),
            ("uploaded", "upload"),
        ]
        assert (study.replay, study.max_plays, study.reference, study.undecided_label) == (
            "max_plays",
            2,
            "none",
            "Same",
        )
        assert [p.label for p in study.pairs] == ["uploaded vs none", "none vs uploaded"]


def test_recruitment_states(app, client, web):
    draft = web.study(video=False)
    ready = web.study(status="ready")
    web.login(client)
    base = f"/experimenter/studies/{draft}/status"
    assert _post(client, f"{base}/open").status_code == 302
    with app.app_context():
        assert db.session.get(Study, draft).status == "draft"  # clips not rendered yet
    base = f"/experimenter/studies/{ready}/status"
    for action, state in (("open", "open"), ("pause", "paused"), ("open", "open")):
        _post(client, f"{base}/{action}")
        with app.app_context():
            assert db.session.get(Study, ready).status == state
    assert _post(client, f"{base}/bogus").status_code == 302
    assert client.post(f"{base}/close").status_code == 400  # no CSRF token
    _post(client, f"{base}/close")
    with app.app_context():
        study = db.session.get(Study, ready)
        assert study.status == "closed"
        # Closing queues the report after the commit; without votes it says so, not failing.
        job = db.session.scalar(sa.select(Job).where(Job.study_id == ready))
        assert (job.kind, job.status) == ("report", "done")
        assert job.message.startswith("no votes to analyse")


def _finish(app, participant, slug, choice):
    participant.client = app.test_client()
    participant.join(slug)
    while (trial := participant.current_trial()) is not None:
        assert participant.vote(trial, choice).status_code == 201


def test_monitor_export_and_report(app, client, participant, web):
    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    _finish(app, participant, slug, "left")
    _finish(app, participant, slug, "right")
    web.login(client)
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert re.search(r'id="stat-joined">2<', monitor)
    assert re.search(r'id="stat-finished">2<', monitor)
    assert "none vs random" in monitor
    response = client.get(f"/experimenter/studies/{study_id}/votes.csv")
    assert response.mimetype == "text/csv"
    rows = list(csv.DictReader(io.StringIO(response.get_data(as_text=True))))
    from app.analysis.votes import VOTE_COLUMNS, read_votes

    assert tuple(rows[0]) == VOTE_COLUMNS
    assert len(rows) == 8 and {r["choice"] for r in rows} == {"left", "right"}
    assert {(r["participant"], r["choice"]) for r in rows} == {
        ("P0000", "left"),
        ("P0001", "right"),
    }
    assert (
        len(
            read_votes(
                io.StringIO(response.get_data(as_text=True))
                if False
                else _tmp_csv(response.get_data(as_text=True))
            )
        )
        == 8
    )
    assert client.get(f"/experimenter/studies/{study_id}/report/").status_code == 404
    _post(client, f"/experimenter/studies/{study_id}/status/close")
    report = client.get(f"/experimenter/studies/{study_id}/report/")
    assert report.status_code == 200 and b"<html" in report.data.lower()
    report.close()


def test_report_applies_the_studys_exclusion_rules(app, participant, web):
    from app.web.study.exports import write_report_files

    study_id = web.study(design="all_ordered")
    slug = study_slug(app, study_id)
    _finish(app, participant, slug, "left")
    _finish(app, participant, slug, "right")
    with app.app_context():
        study = db.session.get(Study, study_id)
        study.settings = {**study.settings, "exclude": "side_left>0.9"}
        db.session.commit()
        text = write_report_files(study).read_text(encoding="utf-8")
    assert "Exclusion rules side_left&gt;0.9 were applied" in text
    assert "P0000: side_left&gt;0.9 (side_left = 1)" in text


def _tmp_csv(text):
    import tempfile
    from pathlib import Path

    folder = Path(tempfile.mkdtemp())
    (folder / "votes.csv").write_text(text)
    return folder / "votes.csv"


def test_dropped_participants_give_their_slot_back(app, client, participant, web):
    from app.web.models import StudyList

    study_id = web.study()
    token = participant.join(study_slug(app, study_id))
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        person.last_seen_at = person.last_seen_at.replace(year=2000)
        db.session.commit()
    web.login(client)
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert re.search(r'id="stat-dropped">1<', monitor)
    with app.app_context():
        assert sum(row.n_assigned for row in db.session.scalars(sa.select(StudyList))) == 0


def test_preview_clip(app, client, web):
    study_id = web.study()
    web.login(client)
    with app.app_context():
        stimulus = db.session.scalar(sa.select(Stimulus).where(Stimulus.study_id == study_id))
    response = client.get(f"/experimenter/studies/{study_id}/stimuli/{stimulus.id}.mp4")
    assert response.status_code == 200 and response.mimetype == "video/mp4"
    response.close()
    assert client.get(f"/experimenter/studies/{study_id}/stimuli/99999.mp4").status_code == 404


@pytest.fixture
def fake_renderer(monkeypatch, tiny_video, tiny_webm):
    """The render job with the renderer stubbed: it copies a tiny clip and its WebM rendition
    (the real renderer is tested on its own); records the calls."""
    import shutil

    calls = []
    module = types.ModuleType("renderer")

    class RenderSettings:
        def __init__(self, **kwargs):
            self.kwargs = kwargs

    def render_pair(
        left, right, audio, out, *, settings=None, cache_dir=None, progress=None, webm_path=None
    ):
        calls.append((left.n_frames, right.n_frames, str(audio)))
        shutil.copyfile(tiny_video, out)
        if webm_path is not None:
            shutil.copyfile(tiny_webm, webm_path)
        return out

    module.RenderSettings, module.render_pair = RenderSettings, render_pair
    monkeypatch.setitem(sys.modules, "renderer", module)
    return calls


def _generated_tracks(study: Study) -> None:
    """A zero track of every condition on the study's first clip, as 'generate' leaves them."""
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack
    from app.web.infra.storage import media_dir

    for condition in study.conditions:
        rel = f"tracks/s1/{condition.name}.fap"
        (media_dir(study) / "tracks/s1").mkdir(parents=True, exist_ok=True)
        write_fap(MotionTrack.zeros(30.0, 15, channels=(48,)), media_dir(study) / rel)
        db.session.add(Track(condition_id=condition.id, clip_id=study.clips[0].id, path=rel))


def test_render_job_fills_every_stimulus(app, client, web, fake_renderer):
    study_id = web.study(video=False)
    web.login(client)
    with app.app_context():
        _generated_tracks(db.session.get(Study, study_id))
        db.session.commit()
    response = _post(client, f"/experimenter/studies/{study_id}/jobs/render")
    assert response.status_code == 302
    with app.app_context():
        job = db.session.scalar(sa.select(Job).where(Job.study_id == study_id))
        assert (job.status, job.done, job.total) == ("done", 2, 2), job.message
        assert all(
            s.video_path
            for s in db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study_id))
        )
        assert db.session.get(Study, study_id).status == "ready"
    assert len(fake_renderer) == 2
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    assert "2 of 2 clips rendered" in page and "job-done" in page


def test_render_before_generate_fails_visibly(app, client, web, fake_renderer):
    study_id = web.study(video=False)
    web.login(client)
    _post(client, f"/experimenter/studies/{study_id}/jobs/render")
    with app.app_context():
        job = db.session.scalar(sa.select(Job).where(Job.study_id == study_id))
        assert job.status == "failed" and "generate the tracks first" in job.message
    assert _post(client, f"/experimenter/studies/{study_id}/jobs/bogus").status_code == 400


def test_disk_full_on_upload_is_507_and_leaves_nothing(app, client, web, tmp_path, monkeypatch):
    import errno
    import shutil

    from app.web.study import studies

    copied = []
    copyfile = shutil.copyfile

    def copy_until_full(source, target):
        if copied:
            raise OSError(errno.ENOSPC, "No space left on device", str(target))
        copied.append(copyfile(source, target))

    monkeypatch.setattr(studies.shutil, "copyfile", copy_until_full)
    wav = web.write_wav(tmp_path / "s1.wav")
    track = tmp_path / "t.fap"
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack

    write_fap(MotionTrack.zeros(30.0, 15, channels=(48,)), track)
    text = web.toml().replace(
        "[[clips]]", '[[conditions]]\nname = "up"\ntracks = { s1 = "t.fap" }\n\n[[clips]]'
    )
    web.user()
    web.login(client)
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    token = re.search(r'name="file-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    response = client.post(
        "/experimenter/studies/new",
        content_type="multipart/form-data",
        data={
            "file-csrf_token": token,
            "file-submit": "1",
            "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
            "file-media": [(io.BytesIO(p.read_bytes()), p.name) for p in (wav, track)],
        },
    )
    assert response.status_code == 507
    assert "disk is full writing t.fap" in response.get_data(as_text=True)
    assert copied  # the first file was written, then the disk filled up
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count()).select_from(Study)) == 0
    from pathlib import Path

    assert not list(Path(app.config["MEDIA_ROOT"]).glob("study-*"))


def test_disk_full_in_a_job_is_its_error(app, web, monkeypatch):
    import errno

    from app.web.jobs import bodies
    from app.web.jobs.bodies import run_job

    def full(study, progress):
        raise OSError(errno.ENOSPC, "No space left on device", "/srv/media/videos/a.mp4")

    monkeypatch.setitem(bodies.TASKS, "render", full)
    study_id = web.study(video=False)
    with app.app_context():
        job = Job(study_id=study_id, kind="render")
        db.session.add(job)
        db.session.commit()
        assert run_job(job.id) == "failed"
        db.session.refresh(job)
        assert job.message == (
            "the server's disk is full writing a.mp4; free some space and try again"
        )


def test_retry_resumes_from_the_clips_already_rendered(
    app, client, web, fake_renderer, tiny_video, tiny_webm
):
    import shutil

    from app.web.infra.storage import media_dir

    study_id = web.study(video=False, design="all_ordered")
    web.login(client)
    with app.app_context():
        study = db.session.get(Study, study_id)
        _generated_tracks(study)
        # A render killed half way: two clips in place with their WebM, a third killed
        # between its MP4 and its WebM; the row failed.
        stimuli = db.session.scalars(
            sa.select(Stimulus).where(Stimulus.study_id == study_id).order_by(Stimulus.id)
        ).all()
        (media_dir(study) / "videos").mkdir(exist_ok=True)
        for stimulus in stimuli[:3]:
            stimulus.video_path = f"videos/kept-{stimulus.id}.mp4"
            shutil.copyfile(tiny_video, media_dir(study) / stimulus.video_path)
        for stimulus in stimuli[:2]:
            stimulus.webm_path = f"videos/kept-{stimulus.id}.webm"
            shutil.copyfile(tiny_webm, media_dir(study) / stimulus.webm_path)
        half = stimuli[2].id
        failed = Job(
            study_id=study_id,
            kind="render",
            status="failed",
            done=2,
            total=4,
            message="the process running it stopped",
        )
        db.session.add(failed)
        db.session.commit()
        failed_id, n_stimuli = failed.id, len(stimuli)
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    assert f"/jobs/{failed_id}/retry" in page
    assert (
        _post(client, f"/experimenter/studies/{study_id}/jobs/{failed_id}/retry").status_code == 302
    )
    # only the missing clips were rendered; the half-made one got its WebM from its MP4
    assert len(fake_renderer) == n_stimuli - 3
    with app.app_context():
        retried = db.session.scalar(sa.select(Job).where(Job.id != failed_id))
        assert (retried.kind, retried.status) == ("render", "done")
        assert retried.message == f"{n_stimuli} clips rendered (2 kept from before)"
        remade = db.session.get(Stimulus, half)
        assert remade.video_path == f"videos/kept-{half}.mp4"
        assert remade.webm_path == f"videos/kept-{half}.webm"
        webm = media_dir(db.session.get(Study, study_id)) / remade.webm_path
        assert webm.read_bytes()[:4] == b"\x1a\x45\xdf\xa3"  # an EBML (WebM) header
    # Only a failed job can be retried.
    _post(client, f"/experimenter/studies/{study_id}/jobs/{retried.id}/retry")
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Job.id))) == 2


def test_enqueue_error_leaves_no_orphan_row(app, client, web):
    study_id = web.study(video=False)
    app.config.update(REDIS_URL="redis://127.0.0.1:9/0", JOB_RUNNER="process")
    web.login(client)
    response = _post(client, f"/experimenter/studies/{study_id}/jobs/generate")
    assert response.status_code == 302
    page = client.get(response.headers["Location"]).get_data(as_text=True)
    assert "The generate job could not be started" in page and "unreachable" in page
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Job.id))) == 0
