"""The clips' renditions on the participant's side: the MP4 and, where the study has one, its
WebM (VP9 + Opus) for browsers without H.264, offered on every page that plays a clip, served
as the MP4 is (its type, ranges, a file name by place), carried by an answer for the next trial;
and the end of a session whose browser plays neither: the final page in the study's language,
the list slot given back, the reason in participants.csv."""

from __future__ import annotations

import csv
import io
import re

import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant, StudyList
from tests.conftest import ParticipantActions
from tests.support.studies import study_slug

BROWSER_REASON = "browser cannot play the clips (no H.264 or WebM/VP9)"


def _get(client, url, **kwargs):
    """GET ``url`` and close the response (file responses hold the file open)."""
    response = client.get(url, **kwargs)
    response.close()
    return response


def _attributes(page: str, name: str) -> list[str]:
    return re.findall(rf'{name}="([^"]*)"', page)


def test_every_clip_page_offers_the_webm_where_the_study_has_one(app, client, web, tiny_webm):
    study_id = web.study(design="all_ordered", webm=tiny_webm)
    token = ParticipantActions(client, app).join(study_slug(app, study_id))
    instructions = client.get(f"/p/{token}/instructions").get_data(as_text=True)
    assert _attributes(instructions, "data-webm-url") == [f"/p/{token}/practice.webm"]
    assert _attributes(instructions, "data-unplayable-url") == [
        f"/api/v1/participants/{token}/unplayable"
    ]
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    trial = int(_attributes(page, "data-trial-id")[0])
    (following,) = re.findall(r'data-preload-url="/p/[^/]+/video/(\d+)"', page)
    assert _attributes(page, "data-webm-url") == [f"/p/{token}/webm/{trial}"]
    assert _attributes(page, "data-preload-webm-url") == [f"/p/{token}/webm/{following}"]


def test_a_study_without_webm_offers_the_mp4_alone(app, client, web):
    """Clips rendered before renditions existed: the page offers what exists, and the WebM
    routes have nothing to send."""
    token = ParticipantActions(client, app).join(study_slug(app, web.study()))
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    trial = int(_attributes(page, "data-trial-id")[0])
    assert "webm" not in page
    assert _attributes(page, "data-unplayable-url")  # the end is still reported
    assert _get(client, f"/p/{token}/webm/{trial}").status_code == 404
    assert _get(client, f"/p/{token}/practice.webm").status_code == 404
    assert _get(client, f"/p/{token}/video/{trial}").status_code == 200


def test_the_webm_is_served_as_the_mp4_is(app, client, web, tiny_webm):
    token = ParticipantActions(client, app).join(study_slug(app, web.study(webm=tiny_webm)))
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    trial = int(_attributes(page, "data-trial-id")[0])
    whole = _get(client, f"/p/{token}/webm/{trial}")
    assert whole.status_code == 200 and whole.mimetype == "video/webm"
    assert whole.headers["Accept-Ranges"] == "bytes"
    assert re.fullmatch(
        r'inline; filename="?pair-\d\d\.webm"?', whole.headers["Content-Disposition"]
    )
    assert whole.headers["Cache-Control"].startswith("private, max-age=")
    size = tiny_webm.stat().st_size
    part = _get(client, f"/p/{token}/webm/{trial}", headers={"Range": "bytes=0-99"})
    assert part.status_code == 206 and part.mimetype == "video/webm"
    assert part.headers["Content-Range"] == f"bytes 0-99/{size}"
    practice = _get(client, f"/p/{token}/practice.webm")
    assert practice.status_code == 200 and practice.mimetype == "video/webm"
    assert 'filename="practice.webm"' in practice.headers["Content-Disposition"].replace(
        "filename=practice.webm", 'filename="practice.webm"'
    )
    # another participant's trial is not theirs to fetch
    other = ParticipantActions(app.test_client(), app)
    other.join(study_slug(app, web.study(webm=tiny_webm)))
    assert _get(other.client, f"/p/{other.token}/webm/{trial}").status_code == 404


def test_an_answer_carries_the_next_trials_webm(app, client, participant, web, tiny_webm):
    token = participant.join(study_slug(app, web.study(design="all_ordered", webm=tiny_webm)))
    trial = participant.current_trial()
    answer = participant.vote(trial).get_json()["next_trial"]
    assert answer["webm_url"] == f"/p/{token}/webm/{answer['trial_id']}"
    following = answer["preload_url"].rsplit("/", 1)[1]
    assert answer["preload_webm_url"] == f"/p/{token}/webm/{following}"
    without = ParticipantActions(app.test_client(), app)
    without.join(study_slug(app, web.study(design="all_ordered")))
    plain = without.vote(without.current_trial()).get_json()["next_trial"]
    assert plain["webm_url"] is None and plain["preload_webm_url"] is None


def test_the_rating_designs_offer_the_webm(app, client, web, tiny_webm):
    """One face a trial (the rating design), and every version of a clip beside its reference
    (the parallel design): each by its place, as its MP4."""
    rating = ParticipantActions(client, app)
    study_id = web.study(design="rating", catch_kind="instructed", webm=tiny_webm)
    token = rating.join(study_slug(app, study_id))
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    trial = int(_attributes(page, "data-trial-id")[0])
    assert _attributes(page, "data-webm-url") == [f"/p/{token}/webm/{trial}"]
    rated = client.post(
        "/api/v1/ratings",
        json={
            "token": token,
            "trial_id": trial,
            "score": 3,
            "plays": 1,
            "idempotency_key": "rating-1",
        },
    )
    assert rated.status_code == 201, rated.get_json()
    answer = rated.get_json()["next_trial"]
    assert answer["webm_url"] == f"/p/{token}/webm/{answer['trial_id']}"

    parallel = ParticipantActions(app.test_client(), app)
    study = web.study(design="parallel", extra='reference = "none"\n', webm=tiny_webm)
    token = parallel.join(study_slug(app, study))
    page = parallel.client.get(f"/p/{token}/trial").get_data(as_text=True)
    trial = int(_attributes(page, "data-trial-id")[0])
    assert _attributes(page, "data-reference-webm-url") == [f"/p/{token}/webm/{trial}"]
    assert _attributes(page, "data-item-webm-url") == [f"/p/{token}/webm/{trial}/item/"]
    item = _get(parallel.client, f"/p/{token}/webm/{trial}/item/1")
    assert item.status_code == 200 and item.mimetype == "video/webm"
    assert "clip-01-2.webm" in item.headers["Content-Disposition"]
    assert _get(parallel.client, f"/p/{token}/webm/{trial}/item/9").status_code == 404


def _assigned(app, study_id) -> int:
    with app.app_context():
        return db.session.scalar(
            sa.select(sa.func.sum(StudyList.n_assigned)).where(StudyList.study_id == study_id)
        )


def test_a_browser_that_plays_no_rendition_ends_the_session(app, client, web, tiny_webm):
    """The page reports that no rendition plays: the participant's slot goes back at once, the
    session ends with a page in the study's language that says which browsers work, and the
    exports say why."""
    study_id = web.study(webm=tiny_webm, extra='language = "de"')
    slug = study_slug(app, study_id)
    person = ParticipantActions(client, app)
    token = person.join(slug, "PROLIFIC_PID=pp-webkit&SESSION_ID=se-1")
    assert _assigned(app, study_id) == 1
    webkit = (
        "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/605.1.15 (KHTML, like Gecko) "
        "Version/18.0 Safari/605.1.15 Epiphany/605.1.15"
    )
    ended = client.post(f"/api/v1/participants/{token}/unplayable", headers={"User-Agent": webkit})
    assert ended.status_code == 200 and ended.json["next"] == f"/p/{token}/unplayable"
    assert _assigned(app, study_id) == 0
    again = client.post(f"/api/v1/participants/{token}/unplayable")
    assert again.status_code == 200 and _assigned(app, study_id) == 0  # released once
    final = client.get(f"/p/{token}/unplayable")
    text = final.get_data(as_text=True)
    assert final.status_code == 200 and '<html lang="de" dir="ltr">' in text
    assert "Videos" in text and "Chrome" in text and "Firefox" in text and "Safari" in text
    # every way back into the study ends on that page
    for url in (f"/p/{token}", f"/p/{token}/instructions", f"/p/{token}/trial"):
        back = client.get(url, follow_redirects=True)
        assert back.request.path == f"/p/{token}/unplayable", url
    with app.app_context():
        row = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert row.dropped_at is not None and row.exclusion_reason == BROWSER_REASON
        assert (row.environment["browser"], row.environment["browser_version"]) == (
            "GNOME Web",
            "",
        )
    web.login(client)
    rows = list(
        csv.DictReader(
            io.StringIO(
                client.get(f"/experimenter/studies/{study_id}/participants.csv").get_data(
                    as_text=True
                )
            )
        )
    )
    assert [(r["status"], r["excluded"], r["browser"]) for r in rows] == [
        ("excluded", f"excluded: {BROWSER_REASON}", "GNOME Web")
    ]


def test_an_old_study_says_it_had_no_webm_to_offer(app, client, web):
    """Clips without a WebM: the reason says so, so the experimenter knows that making the
    renditions (facepair study renditions) would have let this browser in."""
    study_id = web.study()
    token = ParticipantActions(client, app).join(study_slug(app, study_id))
    ended = client.post(f"/api/v1/participants/{token}/unplayable")
    assert ended.status_code == 200
    with app.app_context():
        row = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert row.exclusion_reason == "browser cannot play the clips (no H.264; no WebM offered)"


def test_the_end_is_refused_to_strangers_and_the_finished(app, client, participant, web):
    assert client.post("/api/v1/participants/nobody/unplayable").status_code == 404
    token = participant.join(study_slug(app, web.study()))
    while (trial := participant.current_trial()) is not None:
        participant.vote(trial)
    finished = client.post(f"/api/v1/participants/{token}/unplayable")
    assert finished.status_code == 409
    # a participant who is not ended is sent on from the final page's address
    assert client.get(f"/p/{token}/unplayable").status_code == 302


def test_hostile_ends_and_clip_requests_never_give_a_5xx(app, client, web, tiny_webm):
    """Any token, trial number and User-Agent header: a refusal or the end, never a 5xx; the
    environment's browser is a bounded, printable name."""
    token = ParticipantActions(client, app).join(study_slug(app, web.study(webm=tiny_webm)))
    header = st.text(st.characters(min_codepoint=32, max_codepoint=255), max_size=400)
    path = st.text(st.characters(codec="ascii", categories=("L", "N", "P")), max_size=40)

    @settings(
        max_examples=60,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(st.one_of(st.just(token), path), st.integers(-(2**70), 2**70), header)
    def hostile(who, trial, agent):
        for url in (f"/p/{who}/webm/{trial}", f"/p/{who}/practice.webm", f"/p/{who}/unplayable"):
            got = _get(client, url, headers={"User-Agent": agent})
            assert got.status_code < 500, (url, got.status_code)
        ended = client.post(f"/api/v1/participants/{who}/unplayable", headers={"User-Agent": agent})
        assert ended.status_code < 500, ended.status_code
        if who != token:
            assert ended.status_code in (308, 404, 405), ended.status_code

    hostile()
    with app.app_context():
        row = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        if row.excluded_at is not None:
            browser = row.environment["browser"]
            assert browser.isprintable() and len(browser) <= 40
