"""The participant's pages in the study's language, in chromium at desktop (1366x768), phone
(390x844, touch) and small-phone (300x640, touch) size: a right-to-left (Arabic) page mirrors
its flow, but its "left" answer is still the button nearer the left face, and casts "left";
a German page speaks German from consent to the vote; the audio check plays its sounds
before the first trial. Debian's chromium through Playwright."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, Vote
from app.web.study import audiocheck
from tests.conftest import create_test_study
from tests.support.browser import device_context, screenshot
from tests.support.studies import study_slug

pytestmark = pytest.mark.browser

SIZES = [
    ("desktop", {"width": 1366, "height": 768}, False),
    ("phone", {"width": 390, "height": 844}, True),
    ("small", {"width": 300, "height": 640}, True),
]


#: The study's own words in its language (the study file's title, question and undecided
#: label; the test study's are English).
WORDS = {
    "ar": ("دراسة الوجوه المتحركة", "أي الوجهين يتحرك بشكل أكثر طبيعية؟", "لا أستطيع أن أقرر"),
    "de": ("Sprechende Gesichter", "Welches Gesicht bewegt sich natürlicher?", "Weiß nicht"),
}


def _first_trial(live_server, chromium, tmp_path, clip, viewport, touch, agree: str, **toml):
    """The first trial's page of a new study in its ``language`` (``extra``), clip ready.
    With ``$FACEPAIR_DEMO_CLIP`` (docs/make_participant_figures.py) it shows that clip."""
    clip = Path(os.environ.get("FACEPAIR_DEMO_CLIP", clip))
    study_id = create_test_study(live_server.app, tmp_path, clip, **toml)
    language = toml["extra"].split('"')[1]
    with live_server.app.app_context():
        study = db.session.get(Study, study_id)
        study.title, study.question, study.undecided_label = WORDS[language]
        db.session.commit()
    context = device_context(chromium, viewport, touch)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{live_server.url}/s/{study_slug(live_server.app, study_id)}")
    press = page.tap if touch else page.click
    press(f"text={agree}")
    page.wait_for_url("**/instructions")
    press("#start")
    page.wait_for_selector(".player[data-trial-id]")
    page.wait_for_selector(".play:not([disabled])")
    return context, page, press, errors


def _centre_x(page, selector: str) -> float:
    box = page.locator(selector).bounding_box()
    assert box is not None, selector
    return box["x"] + box["width"] / 2


@pytest.mark.parametrize("name, viewport, touch", SIZES)
def test_the_left_answer_is_under_the_left_face_in_a_right_to_left_study(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
    touch,
):
    setup = (live_server, browser, tmp_path, tiny_video, viewport, touch)
    context, page, press, errors = _first_trial(*setup, "أوافق", extra='language = "ar"')
    try:
        assert page.get_attribute("html", "dir") == "rtl"
        assert page.get_attribute("html", "lang") == "ar"
        stage = page.locator(".stage").bounding_box()
        assert stage is not None
        left_face = stage["x"] + stage["width"] / 4
        right_face = stage["x"] + 3 * stage["width"] / 4
        left = _centre_x(page, '.vote[data-choice="left"]')
        right = _centre_x(page, '.vote[data-choice="right"]')
        assert abs(left - left_face) < abs(left - right_face), (left, left_face, right_face)
        assert abs(right - right_face) < abs(right - left_face)
        assert page.inner_text('.vote[data-choice="left"] .label') == "الأيسر"
        assert page.inner_text('.vote[data-choice="undecided"] .label') == WORDS["ar"][2]
        # The side labels on the clip keep their places too.
        labels = page.locator(".side-labels span")
        assert labels.nth(0).inner_text() == "الأيسر"
        assert labels.nth(0).bounding_box()["x"] < labels.nth(1).bounding_box()["x"]
        # The page itself is mirrored: the study's title starts the bar, on the right.
        title = page.locator(".study-bar [data-study-text]").bounding_box()
        assert title["x"] + title["width"] > viewport["width"] * 0.9
        trial = int(page.get_attribute(".player", "data-trial-id"))
        press(".play")
        page.wait_for_selector(".vote:not([disabled])")
        screenshot(page, f"participant-trial-arabic-{name}")
        press('.vote[data-choice="left"]')
        page.wait_for_selector(f'.player[data-trial-id="{trial}"]', state="detached")
    finally:
        context.close()
    assert errors == []
    with live_server.app.app_context():
        vote = db.session.scalar(sa.select(Vote).where(Vote.trial_id == trial))
        assert vote.choice == "left"


@pytest.mark.parametrize("name, viewport, touch", SIZES)
def test_a_german_study_speaks_german_to_the_vote(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
    touch,
):
    setup = (live_server, browser, tmp_path, tiny_video, viewport, touch)
    context, page, press, errors = _first_trial(
        *setup,
        "Ich stimme zu",
        replay="max_plays",
        max_plays=2,
        extra='language = "de"\n[[clips]]\nname = "s2"\naudio = "s1.wav"\n',
    )
    try:
        assert page.get_attribute("html", "lang") == "de"
        assert page.inner_text(".progress-text") == "Paar 1 von 2"
        assert page.inner_text(".plays-left") == "Noch 2 Wiedergaben"
        press(".play")
        page.wait_for_selector(".vote:not([disabled])")
        page.wait_for_selector(".play:has-text('Erneut abspielen')")
        assert page.inner_text(".plays-left") == "Noch 1 Wiedergabe"
        screenshot(page, f"participant-trial-german-{name}")
        trial = int(page.get_attribute(".player", "data-trial-id"))
        press('.vote[data-choice="right"]')
        page.wait_for_selector(f'.player[data-trial-id="{trial}"]', state="detached")
        # The second pair comes in place, the bar (its label in German) moved on with it.
        assert page.inner_text(".progress-text") == "Paar 2 von 2"
        assert page.get_attribute(".study-bar progress", "value") == "1"
        page.wait_for_selector(".play:not([disabled])")
        press(".play")
        page.wait_for_selector(".vote:not([disabled])")
        press('.vote[data-choice="left"]')
        # Every pair answered: the completion page, in German too.
        page.wait_for_selector("h1:text('Vielen Dank!')")
        assert "Ihr Abschlusscode:" in page.inner_text(".done")
    finally:
        context.close()
    assert errors == []


@pytest.mark.parametrize("name, viewport, touch", SIZES)
def test_the_audio_check_plays_its_sounds_and_opens_the_trials(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
    touch,
):
    """The check before the first trial, in chromium: the answers open once the three sounds
    have played, each answer goes to the server, and a pass leads to the first pair."""
    study_id = create_test_study(
        live_server.app,
        tmp_path,
        tiny_video,
        extra='[audio_check]\nkind = "huggins"\ntrials = 2\npass_mark = 2\n',
    )
    context = device_context(browser, viewport, touch)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    press = page.tap if touch else page.click
    try:
        page.goto(f"{live_server.url}/s/{study_slug(live_server.app, study_id)}")
        press("text=I agree")
        page.wait_for_url("**/instructions")
        press("#start")
        page.wait_for_url("**/audio-check")
        token = page.url.split("/p/")[1].split("/")[0]
        for question in (1, 2):
            assert f"Question {question} of 2" in page.inner_text(".audio-progress")
            assert page.locator(".sound-choice").first.is_disabled()
            # at four times the speed: what is checked is that the answers open once the
            # sounds have ended, not how long the sounds are (4 s a question)
            page.evaluate(
                "for (const a of document.querySelectorAll('audio'))"
                " { a.defaultPlaybackRate = 4; a.playbackRate = 4; }"
            )
            press(".play-sounds")
            page.wait_for_selector(".sound-choice:not([disabled])")
            if question == 1:
                screenshot(page, f"participant-audio-check-{name}")
            with live_server.app.app_context():
                person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
                target = audiocheck._targets(person.audio_check, 1, 2)[question - 1]
            with page.expect_navigation():
                press(f'.sound-choice[value="{target}"]')
        page.wait_for_selector("text=Your sound works well")
        press("#audio-continue")
        page.wait_for_selector(".player[data-trial-id]")
    finally:
        context.close()
    assert errors == []
    with live_server.app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert person.audio_check["passed"] is True and person.audio_check["scores"] == [2]


#: A rating and a parallel study's own words in each language (title, question, consent,
#: instructions), and what the parallel page says before a play and once every version was
#: played and rated.
RATING_WORDS = {
    "en": {
        "study": ("Talking faces", "How natural is the motion?", "You agree.", "Watch closely."),
        "agree": "I agree",
        "rating": "an animated face, one at a time",
        "parallel": "each in several versions",
        "start": "Click “Reference” or a version's number to watch it.",
        "done": "Every version is played and rated: press Next, or change a rating first.",
    },
    "de": {
        "study": (
            WORDS["de"][0],
            "Wie natürlich ist die Bewegung?",
            "Sie stimmen der Teilnahme zu.",
            "Sehen Sie genau hin.",
        ),
        "agree": "Ich stimme zu",
        "rating": "eines nach dem anderen",
        "parallel": "jedes in mehreren Versionen",
        "start": "Klicken Sie auf „Referenz“ oder auf die Nummer einer Version, um sie anzusehen.",
        "done": "Jede Version ist abgespielt und bewertet: Drücken Sie auf Weiter oder ändern Sie "
        "vorher noch eine Bewertung.",
    },
    "ar": {
        "study": (
            WORDS["ar"][0],
            "ما مدى طبيعية الحركة؟",
            "أنت توافق على المشاركة.",
            "شاهد بتمعّن.",
        ),
        "agree": "أوافق",
        "rating": "واحدًا تلو الآخر",
        "parallel": "كل مقطع في عدة نسخ",
        "start": "انقر على «المرجع» أو على رقم نسخة لمشاهدتها.",
        "done": "تم تشغيل كل النسخ وتقييمها: اضغط «التالي»، أو غيّر أحد التقييمات أولًا.",
    },
}


@pytest.mark.parametrize("design", ["rating", "parallel"])
@pytest.mark.parametrize("language", RATING_WORDS)
def test_the_rating_designs_speak_of_their_own_pages(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    language,
    design,
):
    """A rating and a parallel study at desktop size in English, German and Arabic: the consent
    page describes the design's own task, and the parallel page names its own buttons (it has
    no Play button) and, with every version played and rated, says Next is next, as the
    instructions promise, with the keyboard alone. Screenshots of consent, instructions and
    the first trial to ``$FACEPAIR_SCREENSHOTS``."""
    words = RATING_WORDS[language]
    clip = Path(os.environ.get("FACEPAIR_DEMO_CLIP_SINGLE", tiny_video))
    extra = f'language = "{language}"\n'
    if design == "parallel":
        extra += 'reference = "none"\n'
    study_id = create_test_study(
        live_server.app, tmp_path, clip, design=design, catch_kind="instructed", extra=extra
    )
    with live_server.app.app_context():
        study = db.session.get(Study, study_id)
        study.title, study.question, study.consent, study.instructions = words["study"]
        db.session.commit()
    context = device_context(browser, {"width": 1366, "height": 768}, False)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    name = f"participant-{design}-{{}}-{language}"
    try:
        page.goto(f"{live_server.url}/s/{study_slug(live_server.app, study_id)}")
        consent = page.inner_text("main")
        other = "parallel" if design == "rating" else "rating"
        assert words[design] in consent and words[other] not in consent
        screenshot(page, name.format("consent"))
        page.click(f"text={words['agree']}")
        page.wait_for_url("**/instructions")
        screenshot(page, name.format("instructions"))
        page.click("#start")
        page.wait_for_selector(".rater[data-trial-id]")
        if design == "rating":
            page.wait_for_selector(".play:not([disabled])")
            screenshot(page, name.format("trial"))
            return
        page.wait_for_selector(".overlay-text")
        assert page.inner_text(".overlay-text") == words["start"]
        screenshot(page, name.format("trial"))
        # The keyboard alone, as the instructions say: Tab to each button and slider, Space
        # presses a button, the arrow keys move a slider.
        page.focus(".item-play.reference")
        page.keyboard.press("Space")
        # the play was granted: the overlay gives way to the clip (and stays away after it)
        page.wait_for_selector(".rater .overlay", state="hidden")
        for item in range(page.locator("input[type=range]").count()):
            page.keyboard.press("Tab")
            page.keyboard.press("Space")
            page.wait_for_selector(f'.item-play[data-item="{item}"].played')
            page.keyboard.press("Tab")
            for _ in range(5):
                page.keyboard.press("ArrowRight")
        assert page.inner_text(".rater .hint") == words["done"]
        page.keyboard.press("Tab")
        trial = page.get_attribute(".rater", "data-trial-id")
        page.keyboard.press("Space")
        page.wait_for_selector(f'.rater[data-trial-id="{trial}"]', state="detached")
    finally:
        context.close()
    assert errors == []
