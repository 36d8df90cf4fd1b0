"""Browser test of the participant's side end to end: Debian's chromium driven by Playwright
against a live server. One study with an on-screen attention check, the five-level scale with
reason tags and mismatched (appropriateness) pairs is taken from consent to completion at
desktop (1366x768) and phone (390x844) size. On the way the clip of one trial stalls (its
route holds back the second half of the file until the test lets it through) and another trial
is reloaded after its first play. The votes CSV the experimenter downloads must then hold the
media log these actions caused: the stall with its duration, the replay the reload could not
give back, the levels and the reason tags clicked."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, Trial
from tests.conftest import create_test_study, login, make_clip
from tests.support.browser import (
    trial_page_loads,
)
from tests.support.waits import played, until, until_page

pytestmark = pytest.mark.browser

DESKTOP = {"width": 1366, "height": 768}
PHONE = {"width": 390, "height": 844}
EXTRA = """
mismatched = true

[answer]
scale = 5
reasons = ["lips", "head", "timing"]

[attention]
max_failed = 2
screened_out_code = "RETURN-77"

[viewing]
min_face_px = 120

[[clips]]
name = "s2"
audio = "s1.wav"
"""
# Which step of the schedule stalls and which is reloaded (0 is the first trial).
STALL_STEP, RELOAD_STEP = 1, 2
HELD_MS = 2500  # how long the stalled clip's second half is held back once playback ran dry
#: Playback under way has run out of data: a stall, as the player's media log counts one.
RUN_DRY = (
    "(v => v.currentTime > 0 && !v.paused && !v.ended && v.readyState < v.HAVE_FUTURE_DATA)"
    "(document.querySelector('.player video'))"
)


@pytest.fixture(scope="module")
def stall_clip(tmp_path_factory) -> bytes:
    """A 3 s clip of about 100 kB: its first half holds more than the browser's demuxer reads
    before it starts, so playback can begin on that half and run dry."""
    return make_clip(
        tmp_path_factory.mktemp("stall") / "stall.mp4", seconds=3, size="320x180", bitrate="500k"
    ).read_bytes()


class StalledClip:
    """Serves one trial's clip in two parts: the first half at once, the rest only when
    ``release()`` is called, so playback runs dry in the middle (a stall the player sees as
    ``waiting``). Every other request goes through unchanged."""

    def __init__(self, clip: bytes) -> None:
        self.clip, self.suffix, self.held, self.asked = clip, None, [], []

    def handle(self, route) -> None:
        request = route.request
        if self.suffix is None or not request.url.endswith(self.suffix):
            route.continue_()
            return
        ranged = request.all_headers().get("range", "bytes=0-")
        start = int(ranged.split("=")[1].split("-")[0] or 0)
        self.asked.append(ranged)
        cut = len(self.clip) // 2
        if start >= cut:
            self.held.append((route, start))
            return
        route.fulfill(
            status=206,
            body=self.clip[start:cut],
            headers={
                "Content-Type": "video/mp4",
                "Accept-Ranges": "bytes",
                "Content-Range": f"bytes {start}-{cut - 1}/{len(self.clip)}",
            },
        )

    def release(self) -> None:
        while self.held:
            route, start = self.held.pop(0)
            route.fulfill(
                status=206,
                body=self.clip[start:],
                headers={
                    "Content-Type": "video/mp4",
                    "Accept-Ranges": "bytes",
                    "Content-Range": f"bytes {start}-{len(self.clip) - 1}/{len(self.clip)}",
                },
            )


def _expected(app, trial_id: int) -> tuple[str, str | None]:
    with app.app_context():
        trial = db.session.get(Trial, trial_id)
        return trial.kind, trial.expected


def _press(page, selector: str, touch: bool) -> None:
    (page.tap if touch else page.click)(selector)


def _take_part(
    live_server, chromium, slug: str, pid: str, viewport: dict, clip: bytes, touch: bool
) -> dict[int, dict]:
    """One participant from consent to the completion code; returns what was done per
    trial (choice, strength, reasons, plays, stalled)."""
    context = chromium.new_context(viewport=viewport, is_mobile=touch, has_touch=touch)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    loads = trial_page_loads(page)  # the first, the reloads below, after the last
    stall = StalledClip(clip)
    page.route("**/video/*", stall.handle)
    done: dict[int, dict] = {}
    try:
        page.goto(f"{live_server.url}/s/{slug}?PROLIFIC_PID={pid}&STUDY_ID=st&SESSION_ID=se")
        _press(page, "text=I agree", touch)
        page.wait_for_url("**/instructions")
        _press(page, "#start", touch)
        step = 0
        while True:
            page.wait_for_selector(".player[data-trial-id], .done")
            if "/trial" not in page.url:
                break
            trial = int(page.get_attribute(".player", "data-trial-id"))
            kind, expected = _expected(live_server.app, trial)
            plays = 1
            if step == STALL_STEP:
                # This trial's page is opened again with the route in place.
                stall.suffix = f"/video/{trial}"
                page.reload()
            page.wait_for_selector(".play:not([disabled])")
            _press(page, ".play", touch)
            if step == STALL_STEP:
                # The second half stays held back for HELD_MS once playback has run dry (the
                # stall's length, not a wait for the page), however long it took to get there.
                until_page(page, RUN_DRY)
                until(page, lambda: stall.held, f"the second half asked for: {stall.asked}")
                page.wait_for_timeout(HELD_MS)
                stall.release()
                stall.suffix = None
            if step == RELOAD_STEP:
                # The play was counted by the server: the reload does not give it back.
                page.wait_for_selector(".vote:not([disabled])")
                page.reload()
                page.wait_for_selector(".play:not([disabled])")
                assert int(page.get_attribute(".player", "data-plays")) == 1
                _press(page, ".play", touch)
                plays = 2
            page.wait_for_selector(".vote:not([disabled])")
            # The attention check is answered as its clip says; the others vary the level.
            side = expected if kind == "catch" else ("left", "right")[step % 2]
            strength = 2 if kind == "catch" else 1 + step % 2
            _press(page, f'.vote[data-choice="{side}"][data-strength="{strength}"]', touch)
            page.wait_for_selector(".reasons:not([hidden])")
            tags = ["lips", "timing"][: step % 3]
            for tag in tags:
                page.check(f'.reasons input[value="{tag}"]')
            _press(page, ".reasons .confirm", touch)
            done[trial] = {
                "kind": kind,
                "choice": side,
                "strength": strength,
                "reasons": ";".join(tags),
                "plays": plays,
                "stalled": step == STALL_STEP,
            }
            page.wait_for_selector(f'.player[data-trial-id="{trial}"]', state="detached")
            step += 1
        assert page.inner_text("#completion-code") == "DONE-123"
    finally:
        context.close()
    assert errors == []
    # Each vote's answer carried the next pair: no trial page between pairs.
    assert len(loads) == 1 + 2 + 1, loads
    return done


def test_participants_take_a_full_study_on_desktop_and_phone(
    live_server,
    browser,  # noqa: F811
    stall_clip,
):
    study_id = live_server.study(
        design="unordered_counterbalanced",
        replay="play_to_end",
        catch=1,
        catch_kind="onscreen",
        extra=EXTRA,
    )
    with live_server.app.app_context():
        study = db.session.get(Study, study_id)
        slug = study.slug
    clip = stall_clip
    runs = {
        "desk-1": _take_part(live_server, browser, slug, "desk-1", DESKTOP, clip, False),
        "phone-1": _take_part(live_server, browser, slug, "phone-1", PHONE, clip, True),
    }
    with live_server.app.test_client() as client:
        login(client)  # the study's owner
        response = client.get(f"/experimenter/studies/{study_id}/votes.csv")
        assert response.status_code == 200
        rows = list(csv.DictReader(io.StringIO(response.get_data(as_text=True))))
    with live_server.app.app_context():
        people = {p.prolific_pid: p.number for p in db.session.scalars(sa.select(Participant))}
        positions = {t.id: t.position for t in db.session.scalars(sa.select(Trial))}
        assert all(
            p.finished_at is not None and p.screened_out_at is None
            for p in db.session.scalars(sa.select(Participant))
        )
    by_key = {(r["participant"], int(r["trial"])): r for r in rows}
    kinds = set()
    incidental = 0  # stalls of trials nothing held back: a busy machine may cause one
    for pid, done in runs.items():
        for trial, did in done.items():
            kinds.add(did["kind"])
            row = by_key.pop((f"P{people[pid]:04d}", positions[trial]))
            if did["kind"] == "catch":  # exported with its kind; the analysis leaves it out
                assert row["kind"] == "catch", row
                continue
            assert (row["choice"], int(row["strength"]), row["reasons"], int(row["plays"])) == (
                did["choice"],
                did["strength"],
                did["reasons"],
                did["plays"],
            ), row
            assert row["played_to_end"] == "true" and int(row["watched_ms"]) > 0, (did, row)
            # The held-back half is a stall of about HELD_MS; the start of a play, its seek
            # to the beginning included, is none.
            stalls, stall_ms = int(row["stalls"]), int(row["stall_ms"])
            if did["stalled"]:
                assert stalls >= 1 and stall_ms >= HELD_MS // 4, (did, row)
            else:
                assert stall_ms < HELD_MS // 4, (did, row)
                incidental += stalls > 0
            assert (row["mismatched"] != "") == (did["kind"] == "mismatch")
    # every play starts with a seek to the beginning; were that counted, every trial would stall
    assert incidental <= 1, incidental
    assert by_key == {}  # nothing exported that was not clicked
    assert kinds == {"trial", "mismatch", "catch"}


@pytest.mark.parametrize("name, viewport", [("desktop", DESKTOP), ("phone", PHONE)])
def test_trial_page_layout_and_screenshots(
    live_server,
    browser,  # noqa: F811
    tiny_video,
    tmp_path,
    name,
    viewport,
):
    """The trial page of the five-level scale: both faces in view without scrolling, every
    answer a 44 px touch target, mirror-image buttons, and no shift when the clip loads.
    With ``$FACEPAIR_DEMO_CLIP`` (docs/make_participant_figures.py) the page shows that clip
    and the screenshots go to ``$FACEPAIR_SCREENSHOTS``."""
    clip = Path(os.environ.get("FACEPAIR_DEMO_CLIP", tiny_video))
    shots = Path(os.environ.get("FACEPAIR_SCREENSHOTS", tmp_path))
    study_id = create_test_study(live_server.app, tmp_path, clip, extra=EXTRA)
    with live_server.app.app_context():
        slug = db.session.get(Study, study_id).slug
    touch = name == "phone"
    context = browser.new_context(viewport=viewport, is_mobile=touch, has_touch=touch)
    page = context.new_page()
    try:
        page.goto(f"{live_server.url}/s/{slug}")
        _press(page, "text=I agree", touch)
        _press(page, "#start", touch)
        page.wait_for_selector(".player[data-trial-id]")
        before = page.locator(".stage").bounding_box()
        page.wait_for_selector(".play:not([disabled])")
        assert page.locator(".stage").bounding_box() == before  # no layout shift
        _press(page, ".play", touch)
        played(page)
        page.screenshot(path=shots / f"participant-trial-{name}.png")
        video = page.locator("video").bounding_box()
        assert video["y"] >= 0 and video["y"] + video["height"] <= viewport["height"]
        assert video["x"] >= 0 and video["x"] + video["width"] <= viewport["width"]
        boxes = [page.locator(".vote").nth(i).bounding_box() for i in range(5)]
        assert all(b["height"] >= 44 and b["width"] >= 44 for b in boxes)
        assert all(b["y"] + b["height"] <= viewport["height"] for b in boxes)
        # Mirror images: clearly left and clearly right, slightly left and slightly right.
        for left, right in ((0, 4), (1, 3)):
            assert (boxes[left]["width"], boxes[left]["height"]) == pytest.approx(
                (boxes[right]["width"], boxes[right]["height"]), abs=0.5
            )  # subpixel rounding
        # The next pair comes in place (the vote's answer carries it): the same layout.
        first = page.get_attribute(".player", "data-trial-id")
        page.wait_for_selector(".vote:not([disabled])")
        _press(page, ".vote >> nth=0", touch)
        if page.locator(".reasons .confirm").count():
            _press(page, ".reasons .confirm", touch)
        page.wait_for_selector(f'.player[data-trial-id="{first}"]', state="detached")
        page.wait_for_selector(".play:not([disabled])")
        assert page.inner_text(".progress-text").startswith("Pair 2 of ")
        assert page.locator(".status").inner_text() == ""
        _press(page, ".play", touch)
        played(page)  # as the first pair was measured
        assert page.locator(".stage").bounding_box() == before
        assert [page.locator(".vote").nth(i).bounding_box() for i in range(5)] == boxes
        page.screenshot(path=shots / f"participant-trial-{name}-next.png")
    finally:
        context.close()
