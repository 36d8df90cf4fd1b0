"""The participant pages in the study's language (``app.web.infra.i18n``): complete catalogues,
``<html lang dir>``, and a pseudo-locale that shows any fixed string which escaped gettext."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest
import sqlalchemy as sa
from babel.messages.pofile import read_po, write_po
from flask import render_template

from app.trials.participation import LANGUAGES
from app.web.extensions import db
from app.web.infra.i18n import TRANSLATIONS, use_language
from app.web.models import Participant, Study, Trial
from app.web.study import audiocheck
from app.web.study.enrolment import SESSION_ENDED
from app.web.study.wording import ended_reason
from tests.conftest import ParticipantActions, csrf_token
from tests.support.studies import study_slug

REPO = Path(__file__).resolve().parents[3]
PLACEHOLDER = re.compile(r"%\(\w+\)[sd]|%%")
SHIPPED = sorted(p.name for p in TRANSLATIONS.iterdir() if (p / "LC_MESSAGES").is_dir())


def _catalogue(lang: str):
    with open(TRANSLATIONS / lang / "LC_MESSAGES" / "messages.po", "rb") as source:
        return read_po(source)


def _template():
    with open(TRANSLATIONS / "messages.pot", "rb") as source:
        return read_po(source)


def test_the_study_file_languages_are_the_shipped_catalogues():
    assert tuple(SHIPPED) == LANGUAGES
    assert {"ar", "de", "en", "es", "fr", "ja"} <= set(SHIPPED)


def test_the_template_holds_every_string_of_the_source(tmp_path):
    """``messages.pot`` is what ``pybabel extract`` finds today: no string marked for
    translation is missing from the catalogues' template (docs/reference/studyfile.md)."""
    fresh = tmp_path / "messages.pot"
    subprocess.run(
        [sys.executable, "-m", "babel.messages.frontend", "extract"]
        + ["-F", str(TRANSLATIONS / "babel.cfg"), "-k", "lazy_gettext", "-o", str(fresh), "."],
        cwd=REPO,
        check=True,
        capture_output=True,
    )
    with open(fresh, "rb") as source:
        found = {(m.context, m.id) for m in read_po(source) if m.id}
    # a message is its context (msgctxt) and its text: "none" as a demographic answer is
    # not the same message as a plain "none"
    assert found == {(m.context, m.id) for m in _template() if m.id}


@pytest.mark.parametrize("lang", SHIPPED)
def test_every_catalogue_is_complete_with_matching_placeholders(lang):
    template = {(m.context, m.id) for m in _template() if m.id}
    catalogue = _catalogue(lang)
    assert not catalogue.fuzzy
    seen = set()
    for message in catalogue:
        if not message.id:
            continue
        seen.add((message.context, message.id))
        assert not message.fuzzy, (lang, message.id)
        ids = [message.id] if isinstance(message.id, str) else list(message.id)
        strings = [message.string] if isinstance(message.string, str) else list(message.string)
        assert len(strings) == catalogue.num_plurals or isinstance(message.id, str)
        wanted = set(PLACEHOLDER.findall(" ".join(ids))) - {"%%"}
        for text in strings:
            assert text.strip(), (lang, message.id)
            got = set(PLACEHOLDER.findall(text)) - {"%%"}
            if isinstance(message.id, str):
                assert got == wanted, (lang, message.id, text)
            else:  # a plural form may spell its number out ("one", "two")
                assert got <= wanted, (lang, message.id, text)
    assert seen == template, (lang, template - seen)


# --- pages -------------------------------------------------------------------------------


def test_html_lang_and_dir_follow_the_study_language(app, client, web):
    german = study_slug(app, web.study(extra='language = "de-AT"'))
    page = client.get(f"/s/{german}").get_data(as_text=True)
    assert '<html lang="de-AT" dir="ltr">' in page and "Ich stimme zu" in page
    arabic = study_slug(app, web.study(extra='language = "ar"'))
    page = client.get(f"/s/{arabic}").get_data(as_text=True)
    assert '<html lang="ar" dir="rtl">' in page and "أوافق" in page
    # The experimenter's side stays English.
    assert '<html lang="en" dir="ltr">' in client.get("/experimenter/login").get_data(as_text=True)


def test_the_please_wait_page_speaks_the_study_language(app, web):
    """The consent limit answers before the view reads the study: its page still finds the
    study's language."""
    app.config["CONSENT_LIMIT_PER_ADDRESS"] = "1 per minute"
    slug = study_slug(app, web.study(extra='language = "es"'))
    browser = app.test_client()
    codes = []
    for _ in range(2):
        browser.delete_cookie(f"fp-{_study_id(app, slug)}")
        form = {"csrf_token": csrf_token(browser, f"/s/{slug}")}
        codes.append((answer := browser.post(f"/s/{slug}", data=form)).status_code)
    assert codes == [302, 429]
    page = answer.get_data(as_text=True)
    assert '<html lang="es" dir="ltr">' in page and "Espere un momento, por favor" in page


def _study_id(app, slug: str) -> int:
    with app.app_context():
        return db.session.scalar(sa.select(Study.id).where(Study.slug == slug))


def test_a_closed_vote_says_why_in_the_study_language(app, client, participant, web):
    study_id = web.study(extra='language = "fr"')
    token = participant.join(study_slug(app, study_id))
    trial = participant.current_trial()
    with app.app_context():
        db.session.get(Study, study_id).status = "closed"
        db.session.commit()
    answer = participant.vote(trial)
    assert answer.status_code == 409
    assert answer.json["error"] == "this study is closed"  # for scripts
    assert answer.json["message"] == "Cette étude est terminée. Merci de votre participation."
    assert token


def _pseudo(text: str) -> str:
    """Every letter outside a placeholder as its full-width twin: an ASCII letter left on a
    page is a string that did not go through the catalogue."""
    parts = re.split(r"(%\(\w+\)[sd]|%%)", text)
    return "".join(
        p if PLACEHOLDER.fullmatch(p) else re.sub(r"[A-Za-z]", lambda m: chr(ord(m[0]) + 0xFEE0), p)
        for p in parts
    )


@pytest.fixture
def pseudo_app(app, tmp_path):
    """``app`` whose English catalogue is the pseudo-locale (a later folder overrides) for
    this test only."""
    catalogue = _template()
    catalogue.locale = "en"
    for message in catalogue:
        if not message.id:
            continue
        if isinstance(message.id, str):
            message.string = _pseudo(message.id)
        else:
            message.string = (_pseudo(message.id[0]), _pseudo(message.id[1]))
    folder = tmp_path / "pseudo" / "en" / "LC_MESSAGES"
    folder.mkdir(parents=True)
    with open(folder / "messages.po", "wb") as out:
        write_po(out, catalogue)
    directories = app.extensions["babel"].translation_directories
    directories.append(str(tmp_path / "pseudo"))
    try:
        yield app
    finally:
        # the app may serve later tests (one per database): they read the real catalogues
        directories.remove(str(tmp_path / "pseudo"))


class _Visible(HTMLParser):
    """Visible text and the attributes people read (aria-label, title, alt, placeholder, a
    button's value), less the study's own text (``data-study-text``), scripts and ``<head>``."""

    VOID = {"input", "br", "img", "meta", "link", "hr", "source"}
    READ = ("aria-label", "title", "alt", "placeholder")

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[tuple[str, bool]] = []
        self.texts: list[str] = []
        self.blob = ""

    def _skipped(self) -> bool:
        return any(skip for _, skip in self.stack)

    def handle_starttag(self, tag, attrs):
        attributes = dict(attrs)
        skip = tag in ("script", "style", "head") or "data-study-text" in attributes
        if not self._skipped() and not skip:
            self.texts += [attributes[a] or "" for a in self.READ if a in attributes]
            if tag == "input" and attributes.get("type") == "submit":
                self.texts.append(attributes.get("value") or "")
        if tag == "script" and attributes.get("id") == "i18n":
            self.blob = "pending"
        if tag not in self.VOID:
            self.stack.append((tag, skip))

    def handle_endtag(self, tag):
        while self.stack:
            if self.stack.pop()[0] == tag:
                break

    def handle_data(self, data):
        if self.blob == "pending":
            self.blob = data
        elif not self._skipped():
            self.texts.append(data)


def _escaped(html: str) -> list[str]:
    """What a page shows in ASCII letters outside study text: strings that escaped gettext;
    the script's strings (the JSON blob) are read too."""
    parser = _Visible()
    parser.feed(html)
    texts = list(parser.texts)
    if parser.blob and parser.blob != "pending":

        def walk(value):
            if isinstance(value, dict):
                for item in value.values():
                    yield from walk(item)
            elif isinstance(value, list):
                for item in value:
                    yield from walk(item)
            else:
                yield PLACEHOLDER.sub("", str(value))

        texts += list(walk(json.loads(parser.blob)))
    return [t.strip() for t in texts if re.search(r"[A-Za-z]", t)]


PSEUDO_STUDY = dict(
    replay="max_plays",
    max_plays=2,
    catch=1,
    catch_kind="instructed",
    extra="""demographics = true
[answer]
reasons = ["lips", "eyes"]
[attention]
max_failed = 2
[[questions]]
name = "hours"
text = "Hours of screen time a day"
type = "number"
min = 0
max = 24
""",
)


#: Answers to the built-in demographic questions: the stored codes, in every language.
DEMOGRAPHIC_ANSWERS = {
    "age_band": "65 or over",
    "gender": "prefer not to say",
    "native_language": "Welsh",
    "vision_corrected": "yes, and I am wearing them now",
    "animation_experience": "I work in animation",
}


AUDIO_CHECK = """[audio_check]
kind = "antiphase"
trials = 1
pass_mark = 1
attempts = 2
"""


def test_no_fixed_string_escapes_translation_on_any_participant_page(pseudo_app, web):
    """Consent, questionnaire (the built-in demographic questions and the study's own, with
    an error), instructions, trial, done, already started,
    busy, paused, closed and session-ended pages, and the audio check's question, retry and
    result pages, under the pseudo-locale."""
    app = pseudo_app
    client = app.test_client()
    slug = study_slug(app, web.study(**PSEUDO_STUDY))
    pages = {"consent": client.get(f"/s/{slug}?PROLIFIC_PID=p1&SESSION_ID=s1")}
    person = ParticipantActions(client, app)
    token = person.join(slug, "PROLIFIC_PID=p1&SESSION_ID=s1")
    url = f"/p/{token}/questions/before"
    pages["questionnaire"] = client.post(
        url, data={"csrf_token": csrf_token(client, url), "hours": "99"}
    )
    answered = {"csrf_token": csrf_token(client, url), "hours": "3", **DEMOGRAPHIC_ANSWERS}
    assert client.post(url, data=answered).status_code == 302
    pages["instructions"] = client.get(f"/p/{token}/instructions")
    pages["trial"] = client.get(f"/p/{token}/trial")
    while (trial := person.current_trial()) is not None:
        with app.app_context():
            expected = db.session.get(Trial, trial).expected
        person.vote(trial, expected or "left")
    pages["done"] = client.get(f"/p/{token}/done")
    # The audio check: a question, the retry after a failed attempt, the end.
    checked = study_slug(app, web.study(extra=AUDIO_CHECK))
    listener = ParticipantActions(app.test_client(), app)
    heard = listener.join(checked)
    url = f"/p/{heard}/audio-check"
    pages["audio check"] = listener.client.get(url)
    for attempt in (1, 2):
        with app.app_context():
            person = db.session.scalar(sa.select(Participant).where(Participant.token == heard))
            wrong = (audiocheck._targets(person.audio_check, attempt, 1)[0] + 1) % 3
        form = {"attempt": attempt, "question": 1, "choice": wrong}
        token_field = {"csrf_token": csrf_token(listener.client, url)}
        answered = listener.client.post(url, data=form | token_field)
        if answered.status_code != 302:  # the end (a redirect has no page of ours)
            pages["audio check end"] = answered
        if attempt == 1:
            pages["audio check retry"] = listener.client.get(url)
            listener.client.post(
                url, data={"csrf_token": csrf_token(listener.client, url), "retry": "1"}
            )
    assert "audio check end" in pages and "audio check retry" in pages
    stranger = app.test_client()
    pages["already started"] = stranger.get(f"/s/{slug}?PROLIFIC_PID=p1&SESSION_ID=other")
    paused = study_slug(app, web.study(status="paused"))
    pages["paused"] = client.get(f"/s/{paused}")
    with app.app_context():
        study = db.session.scalar(sa.select(Study).where(Study.slug == slug))
        participant = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        with app.test_request_context(f"/s/{slug}"):
            use_language("en")
            busy = render_template("participant/busy.html")
            closed = render_template("participant/unavailable.html", study=study)
            viewing = render_template("participant/unavailable.html", study=study, viewing=200)
            passed = render_template(
                "participant/audio_check.html",
                participant=participant,
                study=study,
                spec=audiocheck.audio_spec(participant),
                phase="done",
                passed=True,
                form=None,
            )
            ended = render_template(
                "participant/unavailable.html", study=study, reason=ended_reason(SESSION_ENDED)
            )
            # the end of a session whose browser plays none of the clips' renditions
            unplayable = render_template(
                "participant/unavailable.html", study=study, unplayable=True
            )
        assert participant is not None
    problems = {}
    for name, response in pages.items():
        assert response.status_code < 500 or name == "paused", name
        problems[name] = _escaped(response.get_data(as_text=True))
    rendered = {"busy": busy, "closed": closed, "viewing": viewing, "ended": ended}
    rendered["unplayable"] = unplayable
    for name, html in (rendered | {"audio check passed": passed}).items():
        problems[name] = _escaped(html)
    assert {name: found for name, found in problems.items() if found} == {}
    # The pages did render their fixed text (in full-width letters), not nothing.
    assert "Ｐａｉｒ" in pages["trial"].get_data(as_text=True)
    # The demographic questions are facepair's own words: through the catalogue, with the
    # stored codes as the options' values.
    questionnaire = pages["questionnaire"].get_data(as_text=True)
    assert "Ｙｏｕｒ ａｇｅ" in questionnaire and "ｐｒｅｆｅｒ ｎｏｔ ｔｏ ｓａｙ" in questionnaire
    assert 'value="prefer not to say"' in questionnaire


@pytest.mark.parametrize(
    "name",
    ["participant.js", "pair.js", "instructions.js", "audio_check.js", "done.js", "rating.js"],
)
def test_the_script_shows_no_string_of_its_own(name):
    """Every sentence a participant page's script shows comes from the page's JSON blob: the
    script's string literals hold no words with spaces besides these (selectors, media
    queries)."""
    script = (REPO / "app/web/static" / name).read_text(encoding="utf-8")
    code = re.sub(r"/\*.*?\*/|//[^\n]*", "", script, flags=re.S)
    literals = re.findall(r'"((?:[^"\\\n]|\\.)*)"', code)
    allowed = {
        "use strict",
        "(pointer: coarse)",
        ".vote:not([disabled])",
        ".level:not([disabled])",
        ".study-bar progress",
    }
    worded = {s for s in literals if re.search(r"[A-Za-z]{2,} [A-Za-z]", s)} - allowed
    assert worded == set()


@pytest.mark.parametrize("design", ["acr5", "slider", "parallel"])
def test_no_fixed_string_escapes_translation_on_the_rating_pages(pseudo_app, web, design):
    """The rating designs' instructions and trial pages (the rating design's check among
    them) and their done page under the pseudo-locale."""
    app = pseudo_app
    client = app.test_client()
    if design == "parallel":
        toml = dict(design="parallel", extra='reference = "none"\n')
    else:
        extra = f'[rating]\nscale = "{design}"\n[attention]\nmax_failed = 2\n'
        toml = dict(design="rating", catch=1, catch_kind="instructed", extra=extra)
    slug = study_slug(app, web.study(**toml))
    person = ParticipantActions(client, app)
    token = person.join(slug)
    pages = {"instructions": client.get(f"/p/{token}/instructions")}
    low = 1 if design == "acr5" else 0  # the bottom of the scale passes the check
    while (trial := person.current_trial()) is not None:
        with app.app_context():
            kind = db.session.get(Trial, trial).kind
        pages[f"trial-{kind}"] = client.get(f"/p/{token}/trial")
        answer = {"token": token, "trial_id": trial, "plays": 2}
        answer |= {"scores": [90, 90]} if design == "parallel" else {"score": low}
        answer["idempotency_key"] = f"pseudo-{trial:08d}"
        assert client.post("/api/v1/ratings", json=answer).status_code == 201
    pages["done"] = client.get(f"/p/{token}/done")
    problems = {name: _escaped(r.get_data(as_text=True)) for name, r in pages.items()}
    assert {name: found for name, found in problems.items() if found} == {}
    kinds = {"trial-trial"} | ({"trial-catch"} if design != "parallel" else set())
    assert set(pages) == {"instructions", "done"} | kinds
    assert "Ｃｌｉｐ" in pages["trial-trial"].get_data(as_text=True)
