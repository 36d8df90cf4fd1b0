"""Creating a study on the web: the shipped example uploads as it is, form errors name files,
a failed attempt keeps its files, the models are ticked, hostile file names never give a 5xx."""

import html
import io
import re
import textwrap
from html.parser import HTMLParser
from pathlib import Path

import pytest
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
    """The web form as a browser sends it (:func:`_as_sent`) with a title and ``fields``."""
    settings = {
        "web-title": "Form study",
        "web-question": "Which one?",
        "web-undecided_label": "Same",
        "web-target_participants": "4",
        "web-seed": "1",
    }
    return _as_sent(page, **settings, **fields)


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


class _BrowserForm(HTMLParser):
    """What a browser sends for one form of a page left as it is: every field's value, the
    ticked boxes, each select's chosen option; files and buttons left out."""

    def __init__(self, form_id: str) -> None:
        super().__init__()
        self.form_id, self.inside, self.data = form_id, False, {}
        self.select: str | None = None
        self.options: list[tuple[str, bool]] = []
        self.textarea: str | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "form":
            self.inside = a.get("id") == self.form_id
        if not self.inside or "name" not in a and tag not in ("option",):
            return
        if tag == "input" and a.get("type") not in ("file", "submit"):
            if a.get("type") not in ("checkbox", "radio") or "checked" in a:
                self.data.setdefault(a["name"], []).append(a.get("value", "on"))
        elif tag == "select":
            self.select, self.options = a["name"], []
        elif tag == "option" and self.select:
            self.options.append((a.get("value", ""), "selected" in a))
        elif tag == "textarea":
            self.textarea = a["name"]
            self.data[self.textarea] = [""]

    def handle_data(self, data):
        if self.textarea:
            self.data[self.textarea][0] += data

    def handle_endtag(self, tag):
        if tag == "form":
            self.inside = False
        elif tag == "select" and self.select:
            chosen = [v for v, s in self.options if s] or [self.options[0][0]]
            self.data[self.select] = chosen[:1]
            self.select = None
        elif tag == "textarea" and self.textarea:
            # a browser drops the newline that opens a text area
            text = self.data[self.textarea][0].replace("\r\n", "\n")
            self.data[self.textarea][0] = text.removeprefix("\n")
            self.textarea = None


def _as_sent(page: str, **fields):
    """The web form as a browser sends it after ``fields`` are set (None unticks a box)."""
    parser = _BrowserForm("web-form")
    parser.feed(page)
    data = {k: v if len(v) > 1 else html.unescape(v[0]) for k, v in parser.data.items()}
    data["web-submit"] = "Create study"
    for key, value in fields.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    return data


def _fap(path: Path) -> Path:
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack

    write_fap(MotionTrack.zeros(30.0, 15, channels=(48,)), path)
    return path


def _study_summary(study) -> dict:
    """Everything a study is, less what names this copy of it (id, links, secrets, dates) and
    the text it was made from (compared as the study it amounts to)."""
    from app.trials.studyfile import loads_study
    from app.web.models import Stimulus

    own = {"id", "slug", "source_toml", "created_at", "pseudonym_key", "pilot_token"}
    columns = {
        c.key: getattr(study, c.key) for c in sa.inspect(Study).column_attrs if c.key not in own
    }
    stimuli = db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id))
    return {
        **columns,
        "conditions": [(c.name, c.model, c.params, c.uploads) for c in study.conditions],
        "clips": [(c.name, c.audio_path, c.ground_truth_path) for c in study.clips],
        "pairs": [(p.first.name, p.second.name) for p in study.pairs],
        "lists": len(study.lists),
        "stimuli": sorted(
            (s.clip.name, s.left.name, s.right.name, s.instruction or "", s.foreign_side or "")
            for s in stimuli
        ),
        "study file": loads_study(study.source_toml, check_files=False).to_portable_toml(),
    }


#: For each design: the form's fields (besides title, question and files) and the study file
#: that says the same; between them they set every field of the form.
EQUIVALENT = {
    "all_ordered": (
        {
            "web-models": ["none", "random"],
            "web-language": "de",
            "web-catch_trials": "1",
            "web-catch_kind": "identical",
            "web-practice_pair": "random, none",
            "web-practice_clip": "clip_b",
            "web-block_by_clip": None,
            "web-audio_check": "huggins",
            "web-audio_check_attempts": "2",
            "web-demographics": "y",
            "web-questions-0-name": "comments",
            "web-questions-0-text": "Anything you noticed?",
            "web-questions-0-page": "after",
            "web-questions-0-required": None,
            "web-questions-0-max_length": "1000",
            "web-questions-1-name": "hours",
            "web-questions-1-text": "Hours a day at a screen",
            "web-questions-1-kind": "number",
            "web-questions-1-minimum": "0",
            "web-questions-1-maximum": "24",
            "web-questions-2-name": "device",
            "web-questions-2-text": "Your device",
            "web-questions-2-kind": "choice",
            "web-questions-2-choices": "phone\r\ntablet\r\ncomputer",
            "web-auto_exclude": ["catch_failed", "unfinished"],
            "web-exclude": "side_p<0.001",
            "web-rejoin": "refuse",
            "web-posture": "per_condition",
            "web-look": "plain",
            "web-size": "256",
            "web-mosaic_block": "0",
            "web-lips": "own",
            "web-brows": "none",
            "web-completion_code": "DONE-1",
            "web-redirect_url": "https://example.org/done?cc=DONE-1",
            "web-seed": "7",
            "web-target_participants": "8",
        },
        """
        language = "de"
        design = "all_ordered"
        seed = 7
        target_participants = 8
        completion_code = "DONE-1"
        redirect_url = "https://example.org/done?cc=DONE-1"
        practice = ["random", "none"]
        practice_clip = "clip_b"
        block_by_clip = false
        posture = "per_condition"
        lips = "own"
        brows = "none"
        rejoin = "refuse"
        exclude = "side_p<0.001"
        auto_exclude = ["catch_failed", "unfinished"]
        demographics = true
        [render]
        look = "plain"
        size = 256
        mosaic_block = 0
        [catch]
        trials = 1
        [audio_check]
        kind = "huggins"
        attempts = 2
        [[questions]]
        name = "comments"
        text = "Anything you noticed?"
        page = "after"
        required = false
        max_length = 1000
        [[questions]]
        name = "hours"
        text = "Hours a day at a screen"
        type = "number"
        min = 0
        max = 24
        [[questions]]
        name = "device"
        text = "Your device"
        type = "choice"
        choices = ["phone", "tablet", "computer"]
        """,
    ),
    "reference": (
        {
            "web-models": ["none", "random", "speech_driven"],
            "web-design": "reference",
            "web-reference": "none",
            "web-scale": "5",
            "web-reasons": "head, eyes",
            "web-undecided_label": "Same",
            "web-max_failed": "2",
            "web-screened_out_code": "OUT",
            "web-min_face_px": "120",
            "web-portrait": "rotate",
            "web-mismatched": "y",
            "web-practice": None,
        },
        """
        design = "reference"
        reference = "none"
        practice = false
        mismatched = true
        [undecided]
        label = "Same"
        [answer]
        scale = 5
        reasons = ["head", "eyes"]
        [attention]
        max_failed = 2
        screened_out_code = "OUT"
        [viewing]
        min_face_px = 120
        portrait = "rotate"
        """,
    ),
    "unordered_counterbalanced": (
        {
            "web-models": ["none", "random"],
            "web-design": "unordered_counterbalanced",
            "web-replay": "max_plays",
            "web-max_plays": "3",
            "web-catch_trials": "1",
            "web-catch_kind": "instructed",
            "web-undecided_allowed": None,
            "web-audio_check": "antiphase",
            "web-audio_check_trials": "4",
            "web-audio_check_pass_mark": "3",
            "web-eyes": "still",
        },
        """
        design = "unordered_counterbalanced"
        eyes = "still"
        [undecided]
        allowed = false
        [replay]
        policy = "max_plays"
        max_plays = 3
        [catch]
        trials = 1
        kind = "instructed"
        [audio_check]
        kind = "antiphase"
        trials = 4
        pass_mark = 3
        """,
    ),
    "adaptive": (
        {"web-models": ["none", "random", "speech_driven"], "web-design": "adaptive"},
        'design = "adaptive"\n',
    ),
    "rating": (
        {
            "web-models": ["none", "random"],
            "web-design": "rating",
            "web-rating_scale": "slider",
            "web-catch_trials": "1",
            "web-replay": "play_to_end",
        },
        """
        design = "rating"
        [rating]
        scale = "slider"
        [replay]
        policy = "play_to_end"
        [catch]
        trials = 1
        """,
    ),
    "parallel": (
        {
            "web-models": ["none", "random", "speech_driven"],
            "web-design": "parallel",
            "web-reference": "speech_driven",
            "web-language": "fr-CA",
        },
        """
        design = "parallel"
        reference = "speech_driven"
        language = "fr-CA"
        """,
    ),
}
#: The adaptive design's five more conditions (it needs eight): uploaded tracks.
ADAPTIVE_TRACKS = ("up1", "up2", "up3", "up4", "up5")


@pytest.mark.parametrize("design", list(EQUIVALENT))
def test_the_form_makes_the_same_study_as_the_equivalent_study_file(
    app, client, web, tmp_path, design
):
    """Every design, rating and parallel included, with every field of the form set in one of
    them: a form submission and the study file that says the same make the same study."""
    web.user()
    web.login(client)
    fields, toml = EQUIVALENT[design]
    wavs = [web.write_wav(tmp_path / f"{c}.wav") for c in ("clip_a", "clip_b")]
    tracks = []
    if design == "adaptive":
        wavs = wavs[:1]
        tracks = [_fap(tmp_path / f"{c}__clip_a.fap") for c in ADAPTIVE_TRACKS]
    models = fields["web-models"]
    data = _as_sent(
        _new_page(client),
        **{"web-title": "Same study", "web-question": "Which one?", **fields},
        **{"web-audio": _files(*wavs), "web-tracks": _files(*tracks)},
    )
    by_form = _post(client, data)
    assert by_form.status_code == 302, _errors(by_form)
    study_file = "\n".join(
        [
            'title = "Same study"',
            'question = "Which one?"',
            textwrap.dedent(toml),
            *(f'[[conditions]]\nname = "{m}"\nmodel = "{m}"\n' for m in models),
            *(
                f'[[conditions]]\nname = "{c}"\ntracks = {{ clip_a = "{c}__clip_a.fap" }}\n'
                for c in (ADAPTIVE_TRACKS if tracks else ())
            ),
            *(f'[[clips]]\nname = "{w.stem}"\naudio = "{w.name}"\n' for w in wavs),
        ]
    )
    by_file = _post(
        client,
        {
            "file-csrf_token": _token(_new_page(client), "file"),
            "file-submit": "1",
            "file-study_file": (io.BytesIO(study_file.encode()), "study.toml"),
            "file-media": _files(*wavs, *tracks),
        },
    )
    assert by_file.status_code == 302, _errors(by_file)
    with app.app_context():
        made = db.session.scalars(sa.select(Study).order_by(Study.id)).all()
        assert len(made) == 2 and made[0].design == design
        assert _study_summary(made[0]) == _study_summary(made[1])


def _errors(response) -> str:
    page = html.unescape(response.get_data(as_text=True))
    return "\n".join(re.findall(r'class="(?:flash[^"]*|error)"[^>]*>\s*([^<]+)<', page)) or page


#: A bad value of a field, and the one line the page says of it (the study file's words where
#: the study file's reader refuses it, the field's label where the form does).
BAD_FIELDS = [
    (
        {"web-design": "parallel", "web-reference": "none", "web-rating_scale": "acr5"},
        "form: rating.scale: design = 'parallel' rates on sliders: expected 'slider', got 'acr5'",
        "web-rating_scale",
    ),
    (
        {"web-design": "reference"},
        "form: reference: missing (required by design = 'reference')",
        "web-reference",
    ),
    (
        {"web-design": "rating", "web-catch_trials": "1", "web-catch_kind": "identical"},
        "form: catch.kind: design = 'rating' takes only 'instructed' checks",
        "web-catch_kind",
    ),
    (
        {"web-design": "rating", "web-practice_pair": "none, random"},
        "form: practice: design = 'rating' has no practice pair",
        "web-practice_pair",
    ),
    ({"web-language": "xx"}, "form: language: no catalogue for 'xx'", "web-language"),
    (
        {
            "web-audio_check": "huggins",
            "web-audio_check_trials": "3",
            "web-audio_check_pass_mark": "5",
        },
        "form: audio_check.pass_mark: at most audio_check.trials (3), got 5",
        "web-audio_check_pass_mark",
    ),
    (
        {"web-audio_check_attempts": "9"},
        "Audio check: attempts allowed: Number must be between 0 and 3.",
        "web-audio_check_attempts",
    ),
    (
        {"web-practice_pair": "none"},
        "form: practice: expected two condition names or false, got an array",
        "web-practice_pair",
    ),
    (
        {"web-practice_clip": "nope"},
        "form: practice_clip: expected one of the clips clip_a, got 'nope'",
        "web-practice_clip",
    ),
    (
        {
            "web-questions-1-name": "q",
            "web-questions-1-text": "Pick",
            "web-questions-1-kind": "choice",
            "web-questions-1-choices": "only one",
        },
        "form: questions[0].choices: expected two or more non-empty strings",
        "web-questions-1-choices",
    ),
    (
        {
            "web-questions-0-name": "q",
            "web-questions-0-text": "How many?",
            "web-questions-0-kind": "number",
            "web-questions-0-minimum": "lots",
        },
        "form: questions[0].min: expected a number, got 'lots'",
        "web-questions-0-minimum",
    ),
    (
        {"web-questions-0-name": "bad name!", "web-questions-0-text": "?"},
        "form: questions[0].name: expected a name of letters",
        "web-questions-0-name",
    ),
    ({"web-exclude": "nonsense"}, "exclude: cannot read rule 'nonsense'", "web-exclude"),
    (
        {"web-size": "5000"},
        "Pixels per face, a multiple of 16 (empty: 368): Number must be between 0 and 4096.",
        "web-size",
    ),
    ({"web-seed": "x"}, "Seed: Not a valid integer value.", "web-seed"),
    (
        {"web-rejoin": "later"},
        "A participant back after being counted as dropped: Not a valid choice.",
        "web-rejoin",
    ),
]


@pytest.mark.parametrize(("fields", "line", "name"), BAD_FIELDS)
def test_a_bad_field_is_one_line_naming_it_and_shown_beside_it(
    app, client, web, tmp_path, fields, line, name
):
    web.user()
    web.login(client)
    wav = web.write_wav(tmp_path / "clip_a.wav")
    data = _as_sent(
        _new_page(client),
        **{"web-title": "T", "web-models": ["none", "random"], "web-audio": _files(wav)},
        **fields,
    )
    response = _post(client, data)
    assert response.status_code == 400
    page = html.unescape(response.get_data(as_text=True))
    flashed = re.findall(r'class="flash[^"]*"[^>]*>\s*([^<]+?)\s*<', page)
    assert any(f.startswith(line) for f in flashed), flashed
    assert all("\n" not in f for f in flashed)
    # and beside the field itself
    field = re.search(
        rf'<label class="(?:field|check)">(?:(?!</label>).)*name="{name}"'
        r"(?:(?!</label>).)*</label>",
        page,
        re.S,
    )
    assert field and 'class="error"' in field.group(0), name


def test_the_page_links_the_study_file_reference_and_its_example(app, client, web, repo_root):
    """What the form does not offer, a study file says: the page links the reference of every
    key and the example."""
    web.user()
    web.login(client)
    page = _new_page(client)
    assert "need a study file" in page
    reference = client.get("/experimenter/studies/new/studyfile.md")
    assert reference.status_code == 200 and reference.mimetype == "text/plain"
    assert (
        reference.get_data(as_text=True)
        == (repo_root / "docs" / "reference" / "studyfile.md").read_text()
    )
    assert 'href="/experimenter/studies/new/studyfile.md"' in page
    example = client.get("/experimenter/studies/new/example.toml")
    assert example.status_code == 200 and b"[[conditions]]" in example.data
    assert 'href="/experimenter/studies/new/example.toml"' in page
    client.post("/experimenter/logout", data={"csrf_token": web.csrf(client, "/experimenter/")})
    assert client.get("/experimenter/studies/new/studyfile.md").status_code == 302


def test_no_input_to_the_form_gives_a_5xx(app, client, web, tmp_path):
    """Any text in any field of the form (each field's name a study file's key, a choice or a
    number): a study or one line naming the field, never a server error."""
    web.user()
    web.login(client)
    wav = web.write_wav(tmp_path / "clip_a.wav")
    base = _as_sent(_new_page(client), **{"web-title": "T", "web-models": ["none", "random"]})
    names = sorted(k for k in base if k not in ("web-csrf_token", "web-submit", "web-kept"))
    text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=40)
    likely = st.sampled_from(
        [
            "",
            "0",
            "1",
            "-1",
            "5",
            "16",
            "9" * 30,
            "1e400",
            "nan",
            "none",
            "random",
            "rating",
            "parallel",
            "reference",
            "adaptive",
            "slider",
            "acr5",
            "huggins",
            "y",
            "de",
            "x, y",
        ]
    )

    @settings(
        max_examples=80,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(st.dictionaries(st.sampled_from(names), st.one_of(likely, text), max_size=8))
    def hostile(changes):
        data = {**base, **changes, "web-audio": _files(wav)}
        response = _post(client, data)
        assert response.status_code in (302, 400), response.get_data(as_text=True)[-800:]
        if response.status_code == 400:
            page = html.unescape(response.get_data(as_text=True))
            assert re.search(r'class="flash[^"]*"', page), page[-800:]

    hostile()
