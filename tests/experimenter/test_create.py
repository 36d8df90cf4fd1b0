"""Creating a study on the web: the shipped example uploads as it is, form errors name files,
a failed attempt keeps its files, the models are ticked, hostile file names never give a 5xx."""

import io
import re
from pathlib import Path

import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.web.experimenter.create import form_error
from app.web.extensions import db
from app.web.models import Study


def _token(page: str, prefix: str) -> str:
    return re.search(rf'name="{prefix}-csrf_token" type="hidden" value="([^"]+)"', page).group(1)


def _kept(page: str, prefix: str) -> str:
    return re.search(rf'name="{prefix}-kept" type="hidden" value="([^"]*)"', page).group(1)


def _new_page(client) -> str:
    return client.get("/experimenter/studies/new").get_data(as_text=True)


def _post(client, data):
    return client.post("/experimenter/studies/new", content_type="multipart/form-data", data=data)


def _files(*paths):
    return [(io.BytesIO(p.read_bytes()), p.name) for p in paths]


def test_the_shipped_example_uploads_as_it_is(app, client, web, repo_root):
    web.user()
    web.login(client)
    text = (repo_root / "app" / "data" / "examples" / "study.toml").read_text()
    demo = repo_root / "app" / "data" / "demo"
    response = _post(
        client,
        {
            "file-csrf_token": _token(_new_page(client), "file"),
            "file-submit": "1",
            "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
            "file-media": _files(demo / "speech.wav", demo / "ground_truth.fap"),
        },
    )
    assert response.status_code == 302, response.get_data(as_text=True)
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        assert [c.name for c in study.conditions] == [
            "none",
            "random",
            "speech_driven",
            "ground_truth",
        ]
        assert [(c.name, c.ground_truth_path) for c in study.clips] == [
            ("speech", "clips/speech/ground_truth.fap")
        ]


def test_a_file_the_study_names_but_nobody_uploaded_is_named(app, client, web, repo_root):
    web.user()
    web.login(client)
    text = (repo_root / "app" / "data" / "examples" / "study.toml").read_text()
    response = _post(
        client,
        {
            "file-csrf_token": _token(_new_page(client), "file"),
            "file-submit": "1",
            "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
            "file-media": _files(repo_root / "app" / "data" / "demo" / "speech.wav"),
        },
    )
    assert response.status_code == 400
    assert (
        "study.toml: clips[0].ground_truth: no uploaded file named 'ground_truth.fap'; "
        "upload it with the study file"
    ) in response.get_data(as_text=True).replace("&#39;", "'")


def test_a_bad_speech_or_track_file_is_refused_at_upload_by_its_name(
    app, client, web, repo_root, tmp_path
):
    """An mp3 renamed .wav (an ID3 header and noise) and a truncated ground truth are refused
    before any study exists, naming the uploaded file, never a server path: they never become
    a failed generation job."""
    web.user()
    web.login(client)
    text = (repo_root / "app" / "data" / "examples" / "study.toml").read_text()
    demo = repo_root / "app" / "data" / "demo"
    fake = tmp_path / "speech.wav"
    fake.write_bytes(b"ID3\x03\x00\x00\x00\x00\x00\x21" + bytes(range(256)) * 20)
    cut = tmp_path / "ground_truth.fap"
    cut.write_text("\n".join((demo / "ground_truth.fap").read_text().splitlines()[:3]) + "\nxx\n")
    for media, name in (
        ((fake, demo / "ground_truth.fap"), "speech.wav"),
        ((demo / "speech.wav", cut), "ground_truth.fap"),
    ):
        response = _post(
            client,
            {
                "file-csrf_token": _token(_new_page(client), "file"),
                "file-submit": "1",
                "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
                "file-media": _files(*media),
            },
        )
        page = response.get_data(as_text=True).replace("&#39;", "'")
        assert response.status_code == 400, page
        error = re.search(r'class="error"[^>]*>([^<]+)<', page) or re.search(
            rf"({re.escape(name)}: [^<]+)", page
        )
        assert error and error.group(1).startswith(f"{name}: "), page[:2000]
        assert str(tmp_path) not in page and app.config["MEDIA_ROOT"] not in page
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Study.id))) == 0


def test_a_failed_upload_keeps_its_files_for_the_next_attempt(app, client, web, tmp_path):
    web.user()
    web.login(client)
    wav = web.write_wav(tmp_path / "s1.wav")
    broken = web.toml(design="zigzag")
    first = _post(
        client,
        {
            "file-csrf_token": _token(_new_page(client), "file"),
            "file-submit": "1",
            "file-study_file": (io.BytesIO(broken.encode()), "study.toml"),
            "file-media": _files(wav),
        },
    )
    page = first.get_data(as_text=True)
    assert first.status_code == 400 and "Kept from your last attempt" in page
    assert "s1.wav" in page
    # The fixed study file alone: the audio comes from the kept files.
    second = _post(
        client,
        {
            "file-csrf_token": _token(page, "file"),
            "file-submit": "1",
            "file-kept": _kept(page, "file"),
            "file-study_file": (io.BytesIO(web.toml().encode()), "study.toml"),
        },
    )
    assert second.status_code == 302, second.get_data(as_text=True)


def _form(page: str, **fields):
    data = {
        "web-csrf_token": _token(page, "web"),
        "web-submit": "1",
        "web-title": "Form study",
        "web-question": "Which one?",
        "web-design": "all_ordered",
        "web-replay": "unlimited",
        "web-undecided_allowed": "y",
        "web-undecided_label": "Same",
        "web-catch_trials": "0",
        "web-target_participants": "4",
        "web-seed": "1",
    }
    return data | fields


def test_form_errors_name_the_file_and_keep_the_choices(app, client, web, tmp_path):
    web.user()
    web.login(client)
    a, b = web.write_wav(tmp_path / "clip_a.wav"), web.write_wav(tmp_path / "clip_b.wav")
    truth = tmp_path / "clip_a.fap"
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack

    write_fap(MotionTrack.zeros(30.0, 15, channels=(48,)), truth)
    response = _post(
        client,
        _form(
            _new_page(client),
            **{
                "web-models": ["none", "ground_truth"],
                "web-audio": _files(a, b),
                "web-ground_truth": _files(truth),
            },
        ),
    )
    page = response.get_data(as_text=True).replace("&#39;", "'")
    assert response.status_code == 400
    # clip_b.wav is the second clip: the message says so by name, not as clips[1].
    assert "clip_b.wav: ground truth: missing (required by condition 'ground_truth'" in page
    assert "clips[1]" not in page
    assert re.search(r'checked[^>]*value="ground_truth"|value="ground_truth"[^>]*checked', page)
    assert "clip_a.wav, clip_b.wav" in page and "clip_a.fap" in page
    # Choosing other models only (no files again) works from the kept files.
    again = _post(
        client, _form(page, **{"web-kept": _kept(page, "web"), "web-models": ["none", "random"]})
    )
    assert again.status_code == 302, again.get_data(as_text=True)
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        assert [c.name for c in study.clips] == ["clip_a", "clip_b"]


def test_kept_files_belong_to_their_experimenter(app, client, web, tmp_path):
    web.user()
    web.login(client)
    wav = web.write_wav(tmp_path / "s1.wav")
    first = _post(
        client,
        {
            "file-csrf_token": _token(_new_page(client), "file"),
            "file-submit": "1",
            "file-study_file": (io.BytesIO(web.toml(design="zigzag").encode()), "study.toml"),
            "file-media": _files(wav),
        },
    )
    kept = _kept(first.get_data(as_text=True), "file")
    other = app.test_client()
    web.user("other@example.org")
    web.login(other, "other@example.org")
    response = _post(
        other,
        {
            "file-csrf_token": _token(_new_page(other), "file"),
            "file-submit": "1",
            "file-kept": kept,
            "file-study_file": (io.BytesIO(web.toml().encode()), "study.toml"),
        },
    )
    assert response.status_code == 400
    assert "no uploaded file named 's1.wav'" in response.get_data(as_text=True).replace(
        "&#39;", "'"
    )


def test_models_are_ticked_not_ctrl_clicked(app, client, web):
    web.user()
    web.login(client)
    page = _new_page(client)
    assert re.search(r'<input[^>]*name="web-models"[^>]*type="checkbox"[^>]*value="none"', page)
    assert "<select multiple" not in page


def test_form_error_names_tracks_and_models():
    data = {
        "clips": [{"name": "a", "audio": "audio/a.wav"}],
        "conditions": [
            {"name": "up", "tracks": {"a": "tracks/up__a.fap"}},
            {"name": "none", "model": "none"},
        ],
    }
    assert (
        str(form_error(InputError("bad", path="form", field="conditions[0].tracks.a"), data))
        == "up__a.fap: track: bad"
    )
    assert (
        str(form_error(InputError("bad", path="form", field="conditions[1].settings"), data))
        == "model none: settings: bad"
    )
    assert str(form_error(InputError("bad", path="form", field="title"), data)) == (
        "form: title: bad"
    )


def test_hostile_upload_names_never_give_a_5xx(app, client, web):
    web.user()
    web.login(client)
    token = _token(_new_page(client), "file")
    names = st.text(st.characters(blacklist_categories=("Cs",)), max_size=60)

    @settings(
        max_examples=60,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(study_name=names, media_name=names, kept=names, body=st.binary(max_size=200))
    def hostile(study_name, media_name, kept, body):
        response = _post(
            client,
            {
                "file-csrf_token": token,
                "file-submit": "1",
                "file-kept": kept,
                "file-study_file": (io.BytesIO(body), study_name or "x.toml"),
                "file-media": [(io.BytesIO(b"RIFF"), media_name or "m.wav")],
            },
        )
        assert response.status_code in (302, 400), response.get_data(as_text=True)[-500:]

    hostile()


def test_the_form_sets_the_stimulus_and_participant_page_options(app, client, web, tmp_path):
    web.user()
    web.login(client)
    a, b = web.write_wav(tmp_path / "clip_a.wav"), web.write_wav(tmp_path / "clip_b.wav")
    response = _post(
        client,
        _form(
            _new_page(client),
            **{
                "web-models": ["none", "random"],
                "web-audio": _files(a, b),
                "web-eyes": "generated",
                "web-mismatched": "y",
                "web-catch_trials": "1",
                "web-catch_kind": "onscreen",
                "web-scale": "5",
                "web-reasons": "head motion, eyebrows ,timing",
                "web-max_failed": "2",
                "web-screened_out_code": "SCREENED",
                "web-min_face_px": "150",
                "web-portrait": "rotate",
            },
        ),
    )
    assert response.status_code == 302, response.get_data(as_text=True)
    with app.app_context():
        study = db.session.scalar(sa.select(Study))
        settings = study.settings
    assert settings["eyes"] == "generated" and settings["normalize"] is False
    # kept as the study file it amounts to, files by name alone (the package's study.toml)
    assert 'audio = "clip_a.wav"' in study.source_toml and str(tmp_path) not in study.source_toml
    from app.trials.studyfile import loads_study

    again = loads_study(study.source_toml, base_dir=tmp_path)
    assert [c.name for c in again.clips] == ["clip_a", "clip_b"]
    assert study.catch_kind == "onscreen"
    from app.trials.participation import ParticipationSpec

    part = ParticipationSpec.from_settings(settings["participation"])
    assert part.scale == 5 and part.reasons == ("head motion", "eyebrows", "timing")
    assert (part.max_failed, part.screened_out_code) == (2, "SCREENED")
    assert part.min_face_px == 150 and part.mismatched is True and part.portrait == "rotate"
    # the study page's design card says all of it
    page = client.get(response.headers["Location"]).get_data(as_text=True)
    card = {
        key: re.search(rf'id="design-{key}">(.*?)</dd>', page, re.S).group(1)
        for key in ("scale", "reasons", "mismatched", "attention", "viewing", "questions")
    }
    assert card["scale"].startswith("5 levels")
    assert card["reasons"] == "head motion, eyebrows, timing"
    assert card["mismatched"].startswith("yes")
    assert card["attention"] == "stop after 2 failed checks, code <code>SCREENED</code>"
    assert card["viewing"] == "each face at least 150 px wide; upright phone: asked to turn it"
    assert card["questions"] == "before: none · after: none"
    # an option that does not fit is named, as a study file's would be
    bad = _post(
        client,
        _form(
            _new_page(client),
            **{
                "web-models": ["none", "random"],
                "web-audio": _files(a, b),
                "web-eyes": "ground_truth",
            },
        ),
    )
    assert bad.status_code == 400
    assert "eyes: needs a ground_truth for every clip" in bad.get_data(as_text=True)


def test_hostile_portrait_values_are_refused_by_name(app, client, web, tmp_path):
    web.user()
    web.login(client)
    a = web.write_wav(tmp_path / "clip_a.wav")
    names = st.text(st.characters(blacklist_categories=("Cs",)), max_size=30)

    @settings(
        max_examples=25,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(portrait=names)
    def hostile(portrait):
        fields = {"web-models": ["none", "random"], "web-audio": _files(a)}
        response = _post(client, _form(_new_page(client), **fields, **{"web-portrait": portrait}))
        assert response.status_code < 500
        if portrait not in ("fit", "rotate"):
            assert response.status_code == 400
            assert "Not a valid choice" in response.get_data(as_text=True)

    hostile()


def test_only_the_newest_failed_attempts_are_kept(app, tmp_path):
    from app.web.experimenter import uploads

    attempt = tmp_path / "attempt" / "media"
    attempt.mkdir(parents=True)
    (attempt / "s1.wav").write_bytes(b"RIFF")
    with app.test_request_context():
        tokens = [uploads.keep(attempt.parent, user_id=7) for _ in range(uploads.KEEP_ATTEMPTS + 3)]
        root = Path(app.config["MEDIA_ROOT"]) / "staged" / "7"
        assert sorted(p.name for p in root.iterdir()) == sorted(tokens[-uploads.KEEP_ATTEMPTS :])
        back = tmp_path / "back"
        assert uploads.restore(tokens[-1], 7, back) and (back / "media" / "s1.wav").is_file()
        assert not uploads.restore(tokens[0], 7, tmp_path / "lost")
