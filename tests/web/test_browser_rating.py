"""Browser test of the rating designs end to end: Debian's chromium driven by Playwright against
a live server. One participant rates every clip on the five ACR levels with the keyboard at
desktop size (1366x768), another on the 0-100 slider by touch at phone size (390x844), each
from consent to the completion code, an attention check ("rate it Bad") among the trials; in
the parallel design a participant plays the reference and every version of each clip and
rates each on its slider, at both sizes; a rating given offline, or left pending across a
reload, is sent once. The ratings stored, the ratings.csv the
experimenter downloads and its analysis must then hold what was clicked. With
``$FACEPAIR_DEMO_CLIP_SINGLE`` (docs/make_participant_figures.py) the pages show that clip and
the screenshots go to ``$FACEPAIR_SCREENSHOTS``."""

from __future__ import annotations

import io
import os
from pathlib import Path

import pandas as pd
import pytest
import sqlalchemy as sa

from app.analysis.rating_results import analyze_ratings, read_ratings
from app.web.extensions import db
from app.web.models import Participant, Rating, Study, Trial
from tests.conftest import create_test_study, login
from tests.support.browser import (
    trial_page_loads,
)
from tests.support.waits import played, until

pytestmark = pytest.mark.browser

DESKTOP = {"width": 1366, "height": 768}
PHONE = {"width": 390, "height": 844}
CLIPS = """
[[clips]]
name = "s2"
audio = "s1.wav"
"""
SLIDER = '[rating]\nscale = "slider"\n'
#: The ACR levels the keyboard participant gives, trial after trial (the check: 1, Bad).
KEYS = ("5", "2", "4", "3")
#: The slider participant's ratings: Home (0) then this many steps of ArrowRight.
STEPS = (80, 35, 60, 15)


def _kind(app, trial_id: int) -> str:
    with app.app_context():
        return db.session.get(Trial, trial_id).kind


def _take_part(live_server, chromium, slug, pid, *, slider: bool):
    """A participant from consent to the completion code; returns trial id -> score given."""
    touch = slider
    viewport = PHONE if slider else DESKTOP
    context = chromium.new_context(viewport=viewport, is_mobile=touch, has_touch=touch)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    loads = trial_page_loads(page)
    requested: list[str] = []
    page.on("request", lambda r: requested.append(r.url))
    press = page.tap if touch else page.click
    given: dict[int, int] = {}
    preloaded = 0
    try:
        page.goto(f"{live_server.url}/s/{slug}?PROLIFIC_PID={pid}&STUDY_ID=st&SESSION_ID=se")
        press("text=I agree")
        page.wait_for_url("**/instructions")
        assert page.locator("text=Practice pair").count() == 0
        press("#start")
        step = 0
        while True:
            page.wait_for_selector(".rater[data-trial-id], .done")
            if "/trial" not in page.url:
                break
            trial = int(page.get_attribute(".rater", "data-trial-id"))
            kind = _kind(live_server.app, trial)
            # the next clip comes in place with the bar and the check as its page shows them
            assert page.inner_text(".progress-text") == f"Clip {step + 1} of 5"
            bar = page.locator(".study-bar progress")
            assert (bar.get_attribute("value"), bar.get_attribute("max")) == (str(step), "5")
            instructed = page.locator(".instructed")
            if kind == "catch":
                assert instructed.inner_text() == "For this clip, please answer Bad."
            else:
                assert instructed.count() == 0
            page.wait_for_selector(".play:not([disabled])")
            # the next clip is fetched while this one is rated
            following = page.get_attribute(".rater", "data-preload-url")
            if following:
                until(
                    page,
                    lambda wanted=following: any(url.endswith(wanted) for url in requested),
                    f"the next clip fetched ahead: {following}",
                )
                preloaded += 1
            if slider:
                press(".play")
                page.wait_for_selector("input[type=range]:not([disabled])")
                assert page.is_disabled(".next")  # not before the slider was moved
                page.focus("input[type=range]")
                page.keyboard.press("Home")
                score = 0 if kind == "catch" else STEPS[step % len(STEPS)]
                for _ in range(score):
                    page.keyboard.press("ArrowRight")
                assert int(page.input_value("input[type=range]")) == score
                press(".next")
            else:
                page.keyboard.press("Space")
                page.wait_for_selector(".level:not([disabled])")
                score = 1 if kind == "catch" else int(KEYS[step % len(KEYS)])
                page.keyboard.press(str(score))
            given[trial] = score
            page.wait_for_selector(f'.rater[data-trial-id="{trial}"]', state="detached")
            step += 1
        assert page.inner_text("#completion-code") == "DONE-123"
    finally:
        context.close()
    assert errors == []
    assert len(loads) == 2, loads  # the first clip's page, and the one the last rating opens
    assert preloaded == len(given) - 1  # every clip but the first was fetched ahead
    return given


def _layout(page, viewport: dict) -> None:
    """The face and every answer control in view without scrolling, 44 px touch targets."""
    face = page.locator("video").bounding_box()
    assert face["y"] >= 0 and face["y"] + face["height"] <= viewport["height"]
    controls = page.locator(".level, input[type=range], .next")
    for i in range(controls.count()):
        box = controls.nth(i).bounding_box()
        assert box["y"] + box["height"] <= viewport["height"], (i, box, viewport)
        assert box["height"] >= 44 and box["width"] >= 44, (i, box)


def test_two_participants_rate_every_clip_on_acr_and_on_the_slider(
    live_server,
    browser,  # noqa: F811
    tmp_path,
):
    acr = live_server.study(design="rating", catch=1, catch_kind="instructed", extra=CLIPS)
    slider = live_server.study(
        design="rating", catch=1, catch_kind="instructed", extra=SLIDER + CLIPS
    )
    with live_server.app.app_context():
        slugs = {i: db.session.get(Study, i).slug for i in (acr, slider)}
    given = {
        acr: _take_part(live_server, browser, slugs[acr], "desk-1", slider=False),
        slider: _take_part(live_server, browser, slugs[slider], "phone-1", slider=True),
    }
    with live_server.app.app_context():
        stored = {r.trial_id: r.score for r in db.session.scalars(sa.select(Rating))}
        assert all(p.finished_at for p in db.session.scalars(sa.select(Participant)))
    assert stored == {**given[acr], **given[slider]}
    with live_server.app.test_client() as client:
        login(client)
        for study_id, scale in ((acr, "acr5"), (slider, "slider")):
            text = client.get(f"/experimenter/studies/{study_id}/ratings.csv").get_data(
                as_text=True
            )
            table = read_ratings(pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False))
            assert (table["scale"] == scale).all() and len(table) == len(given[study_id])
            # 2 conditions x 2 clips and one check: every clip of every condition once
            real = table[table["kind"] == "trial"]
            assert sorted(zip(real["clip"], real["condition"], strict=True)) == sorted(
                (c, k) for c in ("s1", "s2") for k in ("none", "random")
            )
            results = analyze_ratings(table)
            assert results["input"]["catch"] == {"trials": 1, "failed": 0}
            assert results["input"]["ratings"] == 4 and results["input"]["left_out"] == {}
            kinds = {t: _kind(live_server.app, t) for t in given[study_id]}
            scores = sorted(s for t, s in given[study_id].items() if kinds[t] == "trial")
            assert sorted(real["score"].tolist()) == scores


@pytest.mark.parametrize("name, viewport", [("desktop", DESKTOP), ("phone", PHONE)])
def test_rating_page_layout_and_screenshots(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
):
    """The rating page at desktop and phone size: the face and the five levels (desktop) or
    the slider and Next (phone) in view, 44 px targets, no layout shift when the clip loads."""
    clip = Path(os.environ.get("FACEPAIR_DEMO_CLIP_SINGLE", tiny_video))
    shots = Path(os.environ.get("FACEPAIR_SCREENSHOTS", tmp_path))
    extra = CLIPS if name == "desktop" else SLIDER + CLIPS
    study_id = create_test_study(
        live_server.app, tmp_path, clip, design="rating", catch_kind="instructed", extra=extra
    )
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    touch = name == "phone"
    context = browser.new_context(viewport=viewport, is_mobile=touch, has_touch=touch)
    page = context.new_page()
    press = page.tap if touch else page.click
    try:
        page.goto(f"{live_server.url}/s/{slug}")
        press("text=I agree")
        press("#start")
        page.wait_for_selector(".rater[data-trial-id]")
        before = page.locator(".stage").bounding_box()
        page.wait_for_selector(".play:not([disabled])")
        assert page.locator(".stage").bounding_box() == before  # no layout shift
        press(".play")
        played(page)
        if touch:
            page.focus("input[type=range]")
            page.keyboard.press("End")
            for _ in range(28):
                page.keyboard.press("ArrowLeft")
        _layout(page, viewport)
        page.screenshot(path=shots / f"participant-rating-{name}.png")
    finally:
        context.close()


PARALLEL = 'reference = "none"\n' + CLIPS


def _shown(app, trial_id: int) -> list[str]:
    """The conditions of a parallel trial in the order its page shows them."""
    from app.web.study.ratings import shown_items

    with app.app_context():
        trial = db.session.get(Trial, trial_id)
        return [c.name for c in shown_items(trial.participant, trial)]


def _set_slider(page, selector: str, score: int) -> None:
    page.focus(selector)
    page.keyboard.press("Home")
    for _ in range(score):
        page.keyboard.press("ArrowRight")


@pytest.mark.parametrize("name, viewport", [("desktop", DESKTOP), ("phone", PHONE)])
def test_a_participant_rates_every_version_in_parallel(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
):
    """Every version played and rated before Next, the hidden reference rated high; the
    ratings stored and exported (with the item and the hidden reference marked) and the
    post-screening leaving nobody out. With ``$FACEPAIR_DEMO_CLIP_SINGLE`` the first page is
    the screenshot ``participant-parallel-<size>.png``."""
    clip = Path(os.environ.get("FACEPAIR_DEMO_CLIP_SINGLE", tiny_video))
    shots = Path(os.environ.get("FACEPAIR_SCREENSHOTS", tmp_path))
    study_id = create_test_study(live_server.app, tmp_path, clip, design="parallel", extra=PARALLEL)
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    touch = name == "phone"
    context = browser.new_context(viewport=viewport, is_mobile=touch, has_touch=touch)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    press = page.tap if touch else page.click
    loads = trial_page_loads(page)
    given: dict[int, dict[str, int]] = {}
    try:
        page.goto(f"{live_server.url}/s/{slug}")
        press("text=I agree")
        press("#start")
        while True:
            page.wait_for_selector(".rater[data-trial-id], .done")
            if "/trial" not in page.url:
                break
            trial = int(page.get_attribute(".rater", "data-trial-id"))
            assert page.inner_text(".progress-text") == f"Clip {len(given) + 1} of 2"
            shown = _shown(live_server.app, trial)
            assert page.locator("input[type=range]").count() == len(shown) == 2
            press(".item-play.reference")
            # The reference's play granted and its clip asked for: a version's button pressed
            # while a play is asked for does nothing.
            page.wait_for_selector(".rater video[src]")
            scores = {}
            for item, condition in enumerate(shown):
                assert page.is_disabled(".next")  # not before every version was played and rated
                press(f'.item-play[data-item="{item}"]')
                page.wait_for_selector(f'.item-play[data-item="{item}"].played')
                scores[condition] = 95 if condition == "none" else 30 + 10 * item
                _set_slider(page, f'input[data-item="{item}"]', scores[condition])
            if not given:
                _layout(page, viewport)
                page.screenshot(path=shots / f"participant-parallel-{name}.png")
            given[trial] = scores
            press(".next")
            page.wait_for_selector(f'.rater[data-trial-id="{trial}"]', state="detached")
        assert page.inner_text("#completion-code") == "DONE-123"
    finally:
        context.close()
    assert errors == []
    assert len(loads) == 2, loads  # the second clip came in place
    with live_server.app.app_context():
        stored = {
            (r.trial_id, r.condition.name): r.score for r in db.session.scalars(sa.select(Rating))
        }
    assert stored == {(t, c): s for t, scores in given.items() for c, s in scores.items()}
    with live_server.app.test_client() as client:
        login(client)
        text = client.get(f"/experimenter/studies/{study_id}/ratings.csv").get_data(as_text=True)
    table = read_ratings(pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False))
    assert len(table) == 4 and (table["scale"] == "slider").all()
    assert table["reference"].tolist() == (table["condition"] == "none").tolist()
    assert sorted(table["item"].astype(int).tolist()) == [1, 1, 2, 2]
    results = analyze_ratings(table)
    assert results["screening"]["excluded"] == {} and results["input"]["participants"] == 1
    assert results["mos"]["raw_mos"]["none"] == 95


@pytest.mark.parametrize("design", ["rating", "parallel"])
def test_an_experimenter_runs_a_rating_study_through_the_pipeline(
    live_server,
    browser,  # noqa: F811
    tmp_path,
    stub_pipeline,
    design,
):
    """The study file uploaded, its single faces generated and rendered (the stub pipeline),
    recruitment opened, a participant from the study link to the code, and the ratings
    downloaded from the study page are the ones stored."""
    from tests.support.browser import create_and_open

    live_server.user()
    toml = tmp_path / "study.toml"
    extra = 'reference = "none"\n' if design == "parallel" else ""
    toml.write_text(live_server.toml(design=design, catch_kind="instructed", extra=extra))
    wav = live_server.write_wav(tmp_path / "s1.wav")
    context = browser.new_context(viewport=DESKTOP, accept_downloads=True)
    page = context.new_page()
    try:
        create_and_open(page, live_server.url, toml, wav)  # one face per condition: 2 clips
        link = page.inner_text("#participant-link")
        person = browser.new_context(viewport=DESKTOP).new_page()
        try:
            person.goto(link)
            person.click("text=I agree")
            person.click("#start")
            while "/trial" in person.url:
                person.wait_for_selector(".rater[data-trial-id]")
                trial = person.get_attribute(".rater", "data-trial-id")
                if design == "parallel":
                    for item in ("reference", "0", "1"):
                        person.click(f'.item-play[data-item="{item}"]')
                        if item != "reference":
                            person.wait_for_selector(f'.item-play[data-item="{item}"].played')
                            _set_slider(person, f'input[data-item="{item}"]', 95)
                    person.click(".next")
                else:
                    person.wait_for_selector(".play:not([disabled])")
                    person.keyboard.press("Space")
                    person.wait_for_selector(".level:not([disabled])")
                    person.keyboard.press("1")  # Bad: the check, if this is one, is passed
                person.wait_for_selector(f'.rater[data-trial-id="{trial}"]', state="detached")
                person.wait_for_load_state()
            assert person.inner_text("#completion-code") == "DONE-123"
        finally:
            person.context.close()
        page.reload()
        with page.expect_download() as download:
            page.click("#export-ratings")
        text = Path(download.value.path()).read_text()
    finally:
        context.close()
    table = read_ratings(pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False))
    with live_server.app.app_context():
        stored = sorted(r.score for r in db.session.scalars(sa.select(Rating)))
    assert sorted(table["score"].tolist()) == stored
    assert stored == ([95, 95] if design == "parallel" else [1, 1])


def test_a_rating_given_offline_is_kept_and_sent_once(
    live_server,
    browser,  # noqa: F811
):
    """The connection drops as a clip is rated: the page says the rating is kept and sends it
    when the connection is back; a rating left pending across a reload goes out first, with
    its key, and is stored once."""
    study_id = live_server.study(design="rating", catch_kind="instructed", extra=CLIPS)
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    context = browser.new_context(viewport=DESKTOP)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    try:
        page.goto(f"{live_server.url}/s/{slug}")
        page.click("text=I agree")
        page.click("#start")
        page.wait_for_selector(".play:not([disabled])")
        first = int(page.get_attribute(".rater", "data-trial-id"))
        page.keyboard.press("Space")
        page.wait_for_selector(".level:not([disabled])")
        context.set_offline(True)
        page.keyboard.press("4")
        page.wait_for_selector(".status-offline")
        assert "kept on this page" in page.inner_text(".status")
        context.set_offline(False)
        page.wait_for_selector(f'.rater[data-trial-id="{first}"]', state="detached")
        # The next rating cannot reach the server, then the page is reloaded: the kept rating
        # goes out first, before the page plays anything.
        page.wait_for_selector(".play:not([disabled])")
        second = int(page.get_attribute(".rater", "data-trial-id"))
        page.keyboard.press("Space")
        page.wait_for_selector(".level:not([disabled])")
        page.route("**/api/v1/ratings", lambda route: route.abort())
        page.keyboard.press("2")
        page.wait_for_selector(".status-offline")
        page.unroute("**/api/v1/ratings")
        page.reload()
        page.wait_for_selector(f'.rater[data-trial-id="{second}"]', state="detached")
    finally:
        context.close()
    assert errors == []
    with live_server.app.app_context():
        stored = {r.trial_id: r.score for r in db.session.scalars(sa.select(Rating))}
    assert stored == {first: 4, second: 2}
