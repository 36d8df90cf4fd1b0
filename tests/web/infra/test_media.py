"""Media through Flask, the front proxy (X-Accel-Redirect) or a bucket (pre-signed URLs): the
same access check before each, and a participant never gets another participant's clip."""

import urllib.error
import urllib.request

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.web.extensions import db
from app.web.infra import media
from app.web.models import Participant, Stimulus, Study, Trial
from tests.support.s3 import BUCKET, s3_env, s3_server, use_backend  # noqa: F401 (fixtures)
from tests.support.served import free_port
from tests.support.studies import study_slug

LEAKS = ("X-Accel-Redirect", "Location")


def _trials_of(app, token: str) -> list[int]:
    with app.app_context():
        return list(
            db.session.scalars(
                sa.select(Trial.id)
                .join(Participant)
                .where(Participant.token == token, Trial.stimulus_id.is_not(None))
            )
        )


def _bytes_of(response) -> bytes:
    """What the browser ends up with: the body, or what the pre-signed URL gives."""
    if response.status_code == 302:
        with urllib.request.urlopen(response.headers["Location"], timeout=10) as answer:
            return answer.read()
    try:
        return response.get_data()
    finally:
        response.close()


@pytest.mark.parametrize("backend", ["local", "accel", "s3"])
def test_a_participant_gets_only_the_clips_of_their_own_schedule(
    app, client, web, participant, backend, request
):
    slug = study_slug(app, web.study())
    other = type(participant)(app.test_client(), app)
    other.join(slug)
    participant.join(slug)
    use_backend(app, backend, request)
    own, theirs = _trials_of(app, participant.token), _trials_of(app, other.token)
    assert own and theirs and not set(own) & set(theirs)

    mine = client.get(f"/p/{participant.token}/video/{own[0]}")
    expected = {"local": 200, "accel": 200, "s3": 302}[backend]
    assert mine.status_code == expected
    if backend == "accel":
        assert mine.get_data() == b"" and mine.mimetype == "video/mp4"
        assert mine.headers["X-Accel-Redirect"].startswith("/_protected/study-")
    else:
        assert _bytes_of(mine) == web.tiny_video.read_bytes()
    if backend == "s3":
        # signed with the deployment's secret (the store refuses an edited one), short-lived
        assert "X-Amz-Signature=" in mine.headers["Location"]
        assert f"X-Amz-Expires={app.config['MEDIA_URL_TTL']}" in mine.headers["Location"]
        assert mine.headers["Cache-Control"] == "no-store"

    for trial_id in theirs:
        stolen = client.get(f"/p/{participant.token}/video/{trial_id}")
        assert stolen.status_code in (403, 404)
        assert not any(header in stolen.headers for header in LEAKS)


@pytest.mark.parametrize("backend", ["local", "accel", "s3"])
@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(trial_id=st.integers(min_value=0, max_value=2**63), token=st.text(max_size=80))
def test_any_token_and_trial_answer_without_a_leak_or_a_5xx(
    app, client, web, backend, request, trial_id, token
):
    if not db_has_study(app):
        web.study()
        use_backend(app, backend, request)
    app.config["MEDIA_BACKEND"] = backend
    path = "/p/" + urllib.request.quote(token, safe="") + f"/video/{trial_id}"
    response = client.get(path)
    assert 300 <= response.status_code < 500  # no clip for a token nobody holds
    assert "X-Accel-Redirect" not in response.headers
    assert not any(leak in response.headers.get("Location", "") for leak in ("X-Amz", "/_p"))


def db_has_study(app) -> bool:
    with app.app_context():
        return db.session.scalar(sa.select(sa.func.count(Study.id))) > 0


def test_the_experimenter_report_and_preview_go_through_the_proxy(app, client, web):
    study_id = web.study()
    web.login(client)
    app.config["MEDIA_BACKEND"] = "accel"
    with app.app_context():
        stimulus = db.session.scalars(sa.select(Stimulus)).first()
        folder = media.media_dir(db.session.get(Study, study_id)) / "report"
    preview = client.get(f"/experimenter/studies/{study_id}/stimuli/{stimulus.id}.mp4")
    assert preview.status_code == 200 and preview.get_data() == b""
    assert preview.headers["X-Accel-Redirect"].endswith(stimulus.video_path)
    assert client.get(f"/experimenter/studies/{study_id}/report/").status_code == 404
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "report.html").write_text("<p>report</p>", encoding="utf-8")
    report = client.get(f"/experimenter/studies/{study_id}/report/")
    assert report.headers["X-Accel-Redirect"] == f"/_protected/study-{study_id}/report/report.html"
    assert report.mimetype == "text/html"
    assert client.get(f"/experimenter/studies/{study_id}/report/../../x").status_code == 404


@pytest.mark.parametrize(
    ("setting", "value"),
    [
        ("MEDIA_BACKEND", "ftp"),
        ("MEDIA_URL_TTL", "soon"),
        ("MEDIA_URL_TTL", 0),
        ("MEDIA_ACCEL_PREFIX", "_protected"),
    ],
)
def test_a_media_setting_that_cannot_work_is_refused_by_name(tmp_path, setting, value):
    from app.web import create_app

    config = {
        "TESTING": True,
        "MEDIA_ROOT": str(tmp_path),
        "MEDIA_BACKEND": "accel",
        "SQLALCHEMY_DATABASE_URI": f"sqlite:///{tmp_path / 'm.sqlite'}",
        setting: value,
    }
    with pytest.raises(InputError) as refused:
        create_app(config)
    assert setting in str(refused.value)


@given(url=st.text(max_size=40))
def test_a_bucket_url_is_read_or_refused_by_name(url):
    try:
        bucket, prefix = media.bucket_and_prefix(url)
    except InputError as exc:
        assert "MEDIA_URL" in str(exc)
    else:
        assert url.startswith("s3://") and bucket and "/" not in bucket
        assert prefix == "" or prefix.endswith("/")


def test_a_worker_without_the_files_reads_and_writes_through_the_bucket(app, web, request):
    """``s3``: the study's audio went to the bucket when the study was made; a worker on
    another machine (no local copy) fetches it, and what it writes is in the bucket."""
    import shutil

    from app.web.jobs.bodies import generate_tracks

    use_backend(app, "s3", request)
    study_id = web.study(video=False)
    with app.app_context():
        study = db.session.get(Study, study_id)
        folder = media.media_dir(study)
        shutil.rmtree(folder)  # this machine never saw the upload
        assert generate_tracks(study, lambda done, total: None) == "2 tracks generated"
        keys = {
            o["Key"]
            for o in media.s3_client().list_objects_v2(
                Bucket=BUCKET, Prefix=f"media/study-{study_id}/"
            )["Contents"]
        }
    assert f"media/study-{study_id}/clips/s1/audio.wav" in keys
    assert {f"media/study-{study_id}/tracks/s1/{c}.fap" for c in ("none", "random")} <= keys
    assert (folder / "clips" / "s1" / "audio.wav").is_file()  # fetched for the job


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(name=st.text(max_size=60))
def test_a_report_name_never_sends_a_file_outside_the_studys_report(app, client, web, name):
    """``accel``: whatever the name, the proxy is pointed only inside the report folder."""
    if not db_has_study(app):
        web.study()
        web.login(client)
    app.config["MEDIA_BACKEND"] = "accel"
    with app.app_context():
        study = db.session.scalars(sa.select(Study)).first()
        (media.media_dir(study) / "report").mkdir(exist_ok=True)
        (media.media_dir(study) / "report" / "votes.csv").write_text("a,b\n", encoding="utf-8")
    response = client.get(
        f"/experimenter/studies/{study.id}/report/" + urllib.request.quote(name, safe="/")
    )
    assert response.status_code < 500
    accel = response.headers.get("X-Accel-Redirect")
    assert accel is None or accel.startswith(f"/_protected/study-{study.id}/report/")


def test_deleted_participants_and_studies_leave_nothing_in_the_bucket(
    app, web, participant, request
):
    from app.web.study.privacy import delete_participants
    from app.web.study.studies import delete_study

    use_backend(app, "s3", request)
    study_id = web.study()
    participant.join(study_slug(app, study_id))
    with app.app_context():
        study = db.session.get(Study, study_id)
        media.publish_folder(study, "videos")
        report = media.media_dir(study) / "report"
        report.mkdir()
        (report / "votes.csv").write_text("participant\nsomeone\n", encoding="utf-8")
        media.publish_folder(study, "report")
        client, prefix = media.s3_client(), f"media/study-{study_id}/"

        def keys() -> set[str]:
            listed = client.list_objects_v2(Bucket=BUCKET, Prefix=prefix).get("Contents", [])
            return {found["Key"] for found in listed}

        assert f"{prefix}report/votes.csv" in keys()
        from app.web.study.labels import participant_label

        number = db.session.scalar(
            sa.select(Participant.number).where(Participant.token == participant.token)
        )
        label = participant_label(number)
        assert delete_participants(study, label).labels == (label,)
        db.session.commit()
        assert keys() and not any(key.startswith(f"{prefix}report/") for key in keys())
        delete_study(study)
        db.session.commit()
        assert keys() == set()


def test_a_store_that_is_away_fails_the_job_and_the_request_with_one_line(
    app, client, web, request
):
    """``s3`` with the bucket unreachable: a job fails naming MEDIA_URL (no minutes of
    retries), and a page that writes to the bucket answers 503 with that line, not a 500."""
    from app.web.jobs.bodies import run_job
    from app.web.models import Job
    from tests.conftest import csrf_token

    study_id = web.study()
    web.login(client)
    request.getfixturevalue("s3_env")
    app.config.update(
        MEDIA_BACKEND="s3",
        MEDIA_URL=f"s3://{BUCKET}",
        MEDIA_S3_ENDPOINT=f"http://127.0.0.1:{free_port()}",
    )  # nobody listens
    with app.app_context():
        job = Job(study_id=study_id, kind="generate")
        db.session.add(job)
        db.session.commit()
        assert run_job(job.id) == "failed"
        message = db.session.get(Job, job.id).message
    # The reason in one line, without the exception's class (app.web.jobs.rows.failure_message).
    assert message.startswith("the media store (MEDIA_URL, http://127.0.0.1:"), message
    assert "could not take tracks/s1/" in message and "\n" not in message
    token = csrf_token(client, f"/experimenter/studies/{study_id}")
    copied = client.post(
        f"/experimenter/studies/{study_id}/duplicate", data={"csrf_token": token, "with_clips": "y"}
    )
    assert copied.status_code == 503
    assert "the media store (MEDIA_URL" in copied.get_data(as_text=True)
