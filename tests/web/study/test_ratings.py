"""Recording a rating (``app.web.study.ratings``) through ``POST /api/v1/ratings``: stored
exactly once, every field checked in one line naming it, the attention stop rule and the
participant's progress as for votes; on SQLite and PostgreSQL."""

from __future__ import annotations

import html
import re
import secrets
from typing import Any

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant, Rating, Study
from tests.support.rating import PARALLEL, parallel_participants, rate_all, rate_trial

SLIDER = '[rating]\nscale = "slider"\n'


def _join(app, participant, web, **toml: Any) -> tuple[str, int]:
    study_id = web.study(design="rating", catch_kind="instructed", **toml)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    token = participant.join(slug)
    trial = participant.current_trial()
    assert trial is not None
    return token, trial


def _ratings(app) -> list[Rating]:
    with app.app_context():
        return list(db.session.scalars(sa.select(Rating).order_by(Rating.id)))


def test_a_participant_rates_every_trial_once_and_finishes(app, client, participant, web):
    token, trial = _join(app, participant, web)
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    assert "Excellent" in page and "Bad" in page
    video = client.get(f"/p/{token}/video/{trial}")
    assert "filename=clip-01.mp4" in video.headers["Content-Disposition"]
    video.close()
    first = rate_trial(client, token, trial, 5, key="rating-key-1")
    assert first.status_code == 201, first.get_json()
    body = first.get_json()
    assert body["status"] == "recorded" and body["rating"]["score"] == 5
    assert (body["answered"], body["total"]) == (1, 2)
    again = rate_trial(client, token, trial, 2, key="rating-key-1")
    assert again.status_code == 200 and again.get_json()["rating"]["score"] == 5
    other_key = rate_trial(client, token, trial, 3)
    assert other_key.status_code == 200 and other_key.get_json()["status"] == "duplicate"
    second = participant.current_trial()
    assert second is not None and second != trial
    reused = rate_trial(client, token, second, 3, key="rating-key-1")
    assert reused.status_code == 409 and "idempotency_key" in reused.get_json()["error"]
    assert rate_trial(client, token, second, 1).status_code == 201
    assert participant.current_trial() is None
    rows = _ratings(app)
    assert [r.score for r in rows] == [5, 1]
    assert rows[0].watched_ms == 500 and rows[0].played_to_end is True
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert person.finished_at is not None
        assert {r.condition_id for r in rows} == {
            c.id for c in db.session.get(Study, person.study_id).conditions
        }


def test_the_slider_takes_0_to_100_and_votes_are_refused(app, client, participant, web):
    token, trial = _join(app, participant, web, extra=SLIDER)
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    assert 'type="range"' in page
    refused = rate_trial(client, token, trial, 101)
    assert refused.status_code == 400
    assert refused.get_json()["error"] == "score: expected a whole number from 0 to 100"
    vote = participant.vote(trial)
    assert vote.status_code >= 400
    assert rate_trial(client, token, trial, 63).status_code == 201


def test_a_refused_rating_is_a_rating_error_never_a_vote_error(app, participant, web):
    """What only a rating is checked for is refused with ``RatingRejected``, what every answer
    is checked for with their shared base; neither is a ``VoteRejected``."""
    from app.web.study.ratings import RatingRejected, record_rating
    from app.web.study.votes import AnswerRejected, VoteRejected

    token, trial = _join(app, participant, web)
    payload = {"trial_id": trial, "plays": 1, "watched_to_end": True, "idempotency_key": "k" * 16}
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        with pytest.raises(RatingRejected) as bad_score:
            record_rating(person, {**payload, "score": 99})
        assert bad_score.value.status == 400 and bad_score.value.message.startswith("score: ")
        with pytest.raises(AnswerRejected) as bad_key:
            record_rating(person, {**payload, "score": 4, "idempotency_key": "short"})
        assert bad_key.value.status == 400 and bad_key.value.message.startswith("idempotency_key")
        assert not isinstance(bad_score.value, VoteRejected)
        assert not isinstance(bad_key.value, VoteRejected | RatingRejected)
        db.session.rollback()


def _shown(page: str, *names: str) -> dict[str, str]:
    """The rater's data attributes ``names`` on a rating page."""
    found = {}
    for name in names:
        match = re.search(rf'data-{name}="([^"]*)"', page)
        assert match, name
        found[name] = html.unescape(match.group(1))
    return found


def _optional(page: str, name: str) -> str | None:
    """A data attribute a rating page may leave out (None then)."""
    match = re.search(rf'data-{name}="([^"]*)"', page)
    return None if match is None else html.unescape(match.group(1))


def test_each_rating_answer_carries_the_next_clip_as_its_page_shows_it(
    app, client, participant, web
):
    """What ``static/rating.js`` goes on to in place must be what loading the trial page
    would show: the clip, its plays and whether it is a check."""
    token, _ = _join(app, participant, web, catch=2)
    carried = None
    seen = 0
    preloaded: list[str | None] = []
    while (trial := participant.current_trial()) is not None:
        page = client.get(f"/p/{token}/trial").get_data(as_text=True)
        shown = _shown(page, "trial-id", "plays", "video-url")
        if carried is not None:
            preload = re.search(r'data-preload-url="([^"]*)"', page)
            assert carried == {
                "trial_id": int(shown["trial-id"]),
                "plays": int(shown["plays"]),
                "video_url": shown["video-url"],
                "preload_url": None if preload is None else html.unescape(preload.group(1)),
                # the WebM renditions: none here (the test's renders write MP4s only)
                "webm_url": _optional(page, "webm-url"),
                "preload_webm_url": _optional(page, "preload-webm-url"),
                "catch": 'class="instructed"' in page,
            }
            preloaded.append(carried["preload_url"])
        answer = rate_trial(client, token, trial, 1)  # "Bad": every check passed
        assert answer.status_code == 201, answer.get_json()
        carried = answer.get_json()["next_trial"]
        seen += 1
        assert (carried is None) == (seen == 4)  # two clips and two checks; after the last: none
    assert seen == 4
    # each page preloads the clip after it (by its place in the schedule), the last none
    assert all(preloaded[:-1]) and preloaded[-1] is None


def test_a_parallel_answer_carries_the_next_page(app, client, participant, web):
    second_clip = '[[clips]]\nname = "s2"\naudio = "s1.wav"\n'
    study_id = web.study(design="parallel", extra=PARALLEL + second_clip)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    token = participant.join(slug)
    carried = None
    seen = 0
    while (trial := participant.current_trial()) is not None:
        page = client.get(f"/p/{token}/trial").get_data(as_text=True)
        shown = _shown(page, "trial-id", "plays", "reference-url", "item-url", "items")
        if carried is not None:
            assert carried == {
                "trial_id": int(shown["trial-id"]),
                "plays": int(shown["plays"]),
                "reference_url": shown["reference-url"],
                "item_url": shown["item-url"],
                "items": int(shown["items"]),
                "reference_webm_url": _optional(page, "reference-webm-url"),
                "item_webm_url": _optional(page, "item-webm-url"),
            }
        payload = {"token": token, "trial_id": trial, "scores": [70, 30], "plays": 3}
        answer = client.post(
            "/api/v1/ratings", json={**payload, "idempotency_key": f"parallel-{trial}"}
        )
        assert answer.status_code == 201, answer.get_json()
        carried = answer.get_json()["next_trial"]
        seen += 1
        assert (carried is None) == (seen == 2)
    assert seen == 2


def test_a_missed_check_ends_the_session_under_the_stop_rule(app, client, participant, web):
    token, trial = _join(app, participant, web, catch=2, extra="[attention]\nmax_failed = 1\n")
    closed = None
    for _ in range(6):
        trial = participant.current_trial()
        if trial is None:
            break
        page = client.get(f"/p/{token}/trial").get_data(as_text=True)
        response = rate_trial(client, token, trial, 4)  # never "Bad": fails the first check
        if 'class="instructed"' in page:
            assert response.status_code == 201
            # screened out: no next clip to go on to; the page learns why from the trial page
            assert "next_trial" not in response.get_json()
            closed = rate_trial(client, token, participant.current_trial() or trial, 4)
            break
    assert closed is not None and closed.status_code == 409 and closed.get_json()["closed"]
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert person.screened_out_at is not None


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    field=st.sampled_from(
        ["score", "plays", "response_ms", "presented_at", "idempotency_key", "media", "trial_id"]
    ),
    value=st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(2**70), 2**70),
        st.floats(allow_nan=True),
        st.text(max_size=80),
        st.lists(st.integers(), max_size=3),
        st.dictionaries(st.text(max_size=8), st.integers(), max_size=3),
    ),
)
def test_any_field_value_is_stored_or_refused_in_one_line(
    app, client, participant, web, field: str, value: Any
):
    if participant.token is None:
        _join(app, participant, web)
    trial = participant.current_trial() or 1
    payload = {
        "token": participant.token,
        "trial_id": trial,
        "score": 3,
        "plays": 1,
        "idempotency_key": secrets.token_hex(8),
        field: value,
    }
    response = client.post("/api/v1/ratings", json=payload)
    assert response.status_code < 500
    if response.status_code >= 400:
        error = response.get_json()["error"]
        assert "\n" not in error
        named = field.split("_")[0] if field != "idempotency_key" else field
        assert (
            named in error
            or "trial" in error
            or field == "media"
            or error.startswith("the study")
            or "watch" in error
        ), error


def test_a_body_that_is_no_rating_is_refused(app, client, participant, web):
    token, trial = _join(app, participant, web)
    assert client.post("/api/v1/ratings", data="x").status_code == 400
    assert rate_trial(client, "no-such-token", trial).status_code == 403
    assert rate_trial(client, token, trial, "4").get_json()["error"].startswith("score:")


def test_ratings_csv_and_the_closing_report(app, client, participant, web, tmp_path):
    import json

    from click.testing import CliRunner

    from app.analysis.rating_results import RATING_COLUMNS
    from app.cli import main
    from app.web.models import Job

    study_id = web.study(design="rating", catch_kind="instructed", catch=1)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for score in (4, 5, 3):
        rate_all(app, client, participant, slug, score)
        client.delete_cookie(f"fp-{study_id}")
    rate_all(app, client, participant, slug, 5, check=3)  # misses the check
    client.delete_cookie(f"fp-{study_id}")
    web.login(client)
    text = client.get(f"/experimenter/studies/{study_id}/ratings.csv").get_data(as_text=True)
    lines = text.splitlines()
    assert lines[0] == ",".join(c for c, _ in RATING_COLUMNS)
    assert len(lines) == 1 + 4 * 3  # two trials and a check each
    excluded = {line.split(",")[0] for line in lines if "failed a catch trial" in line}
    assert len(excluded) == 1
    (missed,) = excluded
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    assert 'id="export-ratings"' in page and 'id="export-votes"' not in page
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    with app.app_context():
        job = db.session.scalar(sa.select(Job).where(Job.kind == "report"))
        assert job.status == "done", job.message
    response = client.get(f"/experimenter/studies/{study_id}/report/")
    html = response.get_data(as_text=True)
    response.close()
    assert "Mean opinion scores" in html and missed in html
    assert "3 participants included, 1 left out." in html
    assert "facepair analyze ratings.csv" in html
    (tmp_path / "ratings.csv").write_text(text)
    result = CliRunner().invoke(
        main, ["analyze", str(tmp_path / "ratings.csv"), "--json", str(tmp_path / "r.json")]
    )
    assert result.exit_code == 0, result.output
    again = json.loads((tmp_path / "r.json").read_text())
    assert again["input"]["participants"] == 3 and again["input"]["left_out"] == {
        missed: "failed a catch trial (0 of 1 passed)"
    }
    assert again["mos"]["raw_mos"] == {"none": 4.0, "random": 4.0}


def _join_parallel(app, participant, web) -> tuple[str, int]:
    study_id = web.study(design="parallel", extra=PARALLEL)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    token = participant.join(slug)
    return token, participant.current_trial()


def test_a_parallel_trial_stores_every_item_once(app, client, participant, web):
    from app.web.study.ratings import shown_items

    token, trial = _join_parallel(app, participant, web)
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    assert page.count('type="range"') == 2 and "random" not in page  # blinding
    for item in (0, 1):
        video = client.get(f"/p/{token}/video/{trial}/item/{item}")
        assert (
            video.status_code == 200
            and f"clip-01-{item + 1}.mp4" in video.headers["Content-Disposition"]
        )
        video.close()
    assert client.get(f"/p/{token}/video/{trial}/item/2").status_code == 404

    def rate(scores: Any, plays: int = 3, key: str = "parallel-key-1"):
        payload = {
            "token": token,
            "trial_id": trial,
            "scores": scores,
            "plays": plays,
            "idempotency_key": key,
        }
        return client.post("/api/v1/ratings", json=payload)

    assert rate([80]).get_json()["error"] == "scores: expected a list of 2 scores, one per item"
    assert rate([80, 101]).get_json()["error"].startswith("scores[1]: expected a whole number")
    early = rate([80, 20], plays=1)
    assert early.status_code == 422 and early.get_json()["error"].startswith("plays:")
    first = rate([80, 20])
    assert first.status_code == 201, first.get_json()
    body = first.get_json()
    assert body["rating"]["scores"] == [80, 20] and (body["answered"], body["total"]) == (1, 1)
    again = rate([1, 2])
    assert again.status_code == 200 and again.get_json()["rating"]["scores"] == [80, 20]
    with app.app_context():
        from app.web.models import Trial

        row = db.session.get(Trial, trial)
        shown = [c.name for c in shown_items(row.participant, row)]
    stored = {r.condition.name: r.score for r in _ratings_with_conditions(app)}
    assert stored == dict(zip(shown, [80, 20], strict=True))


def _ratings_with_conditions(app) -> list[Any]:
    with app.app_context():
        rows = list(db.session.scalars(sa.select(Rating).order_by(Rating.id)))
        for row in rows:
            _ = row.condition.name
        return rows


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    value=st.one_of(
        st.none(),
        st.integers(),
        st.text(max_size=5),
        st.lists(
            st.one_of(st.integers(-5, 200), st.floats(), st.text(max_size=3), st.none()),
            max_size=4,
        ),
    )
)
def test_any_scores_value_is_stored_or_refused_in_one_line(app, client, participant, web, value):
    if participant.token is None:
        _join_parallel(app, participant, web)
    trial = participant.current_trial()
    if trial is None:
        return
    payload = {
        "token": participant.token,
        "trial_id": trial,
        "scores": value,
        "plays": 2,
        "idempotency_key": secrets.token_hex(8),
    }
    response = client.post("/api/v1/ratings", json=payload)
    assert response.status_code < 500
    if response.status_code >= 400:
        error = response.get_json()["error"]
        assert "\n" not in error and error.startswith("scores"), error


def test_the_experimenter_pages_of_rating_studies(app, client, participant, web):
    """The study page, the monitor and the downloads of a rating and a parallel study, with
    an answer stored, answer without an error."""
    studies = [
        web.study(design="rating", catch_kind="instructed"),
        web.study(design="parallel", extra=PARALLEL),
    ]
    for study_id in studies:
        with app.app_context():
            slug = db.session.get(Study, study_id).slug
        token = participant.join(slug)
        trial = participant.current_trial()
        answer = {"scores": [70, 90]} if study_id == studies[1] else {"score": 3}
        payload = {"token": token, "trial_id": trial, "plays": 2, **answer}
        payload["idempotency_key"] = f"pages-{study_id:04d}-key"
        assert client.post("/api/v1/ratings", json=payload).status_code == 201
        client.delete_cookie(f"fp-{study_id}")
    web.login(client)
    for study_id in studies:
        for path in ("", "/monitor", "/ratings.csv", "/participants.csv", "/votes.csv"):
            response = client.get(f"/experimenter/studies/{study_id}{path}")
            assert response.status_code == 200, (study_id, path, response.status_code)
        page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
        assert 'id="export-ratings"' in page and 'id="export-votes"' not in page


def test_the_closing_report_of_a_parallel_study_post_screens(app, client, participant, web):
    from app.web.models import Job, Trial
    from app.web.study.ratings import shown_items

    study_id = web.study(design="parallel", extra=PARALLEL)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for reference_score in (95, 50):  # the second misses the hidden reference
        token = participant.join(slug)
        trial = participant.current_trial()
        with app.app_context():
            row = db.session.get(Trial, trial)
            shown = [c.name for c in shown_items(row.participant, row)]
        scores = [reference_score if c == "none" else 60 for c in shown]
        payload = {"token": token, "trial_id": trial, "scores": scores, "plays": 2}
        payload["idempotency_key"] = f"report-{trial:08d}"
        assert client.post("/api/v1/ratings", json=payload).status_code == 201
        client.delete_cookie(f"fp-{study_id}")
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    with app.app_context():
        job = db.session.scalar(sa.select(Job).where(Job.kind == "report"))
        assert job.status == "done", job.message
    response = client.get(f"/experimenter/studies/{study_id}/report/")
    html = response.get_data(as_text=True).replace("&#x27;", "'")
    response.close()
    assert "Design: parallel against the hidden reference none" in html
    assert "rated the hidden reference below 90 on 1 of 1 clips" in html
    assert "1 participant included, 1 left out." in html


def test_the_monitor_tallies_ratings_per_condition(app, client, participant, web):
    """Three participants rate every clip 4, 5 and 3 and pass the check; a fourth rates 2 and
    misses it: each condition shows its count and raw mean, and the checks 3 of 4."""
    from app.web.models import Condition, Trial

    study_id = web.study(design="rating", catch_kind="instructed", catch=1)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    for score, check in ((4, 1), (5, 1), (3, 1), (2, 4)):
        rate_all(app, client, participant, slug, score, check=check)
        client.delete_cookie(f"fp-{study_id}")
    with app.app_context():
        from app.web.study.monitor import rating_monitor

        stats = rating_monitor(db.session.get(Study, study_id))
        names = list(
            db.session.scalars(
                sa.select(Condition.name)
                .where(Condition.study_id == study_id)
                .order_by(Condition.position)
            )
        )
        real = db.session.scalar(
            sa.select(sa.func.count()).select_from(Trial).where(Trial.kind == "trial")
        )
    assert [c["name"] for c in stats["conditions"]] == names
    per_condition = real // 4 // len(names)  # each participant rates each condition this often
    for c in stats["conditions"]:
        assert c["ratings"] == 4 * per_condition and c["mean"] == pytest.approx(3.5)
    assert stats["ratings"] == real and stats["checks"] == {"total": 4, "passed": 3}
    web.login(client)
    page = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert "Ratings per condition" in page and "Votes per pair" not in page
    assert 'id="stat-ratings">' + str(real) in page and "3.50" in page


def test_a_parallel_study_its_post_screening_empties_says_so(app, client, participant, web):
    """Both participants miss the hidden reference: the report page speaks of ratings and
    names the post-screening and whom it left out, ratings.csv says why beside each rating,
    and the monitor counts them."""
    import csv
    import io

    from app.web.models import Job

    study_id = parallel_participants(app, client, participant, web, (50, 40))
    web.login(client)
    text = client.get(f"/experimenter/studies/{study_id}/ratings.csv").get_data(as_text=True)
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == 4 and {r["excluded"] for r in rows} == {""}
    assert {r["participant"]: r["screened"] for r in rows} == {
        "P0000": "rated the hidden reference below 90 on 1 of 1 clips (more than 15 %; "
        "ITU-R BS.1534-3 sec. 4.1.2)",
        "P0001": "rated the hidden reference below 90 on 1 of 1 clips (more than 15 %; "
        "ITU-R BS.1534-3 sec. 4.1.2)",
    }
    monitor = client.get(f"/experimenter/studies/{study_id}/monitor").get_data(as_text=True)
    assert 'id="stat-screened">2<' in monitor
    assert "would leave out 2 of the 2 participants" in monitor
    assert monitor.count("no: rated the hidden reference below 90") == 2
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    with app.app_context():
        job = db.session.scalar(sa.select(Job).where(Job.kind == "report"))
        assert job.status == "done" and job.message.startswith("no ratings to analyse yet")
    response = client.get(f"/experimenter/studies/{study_id}/report/")
    page = html.unescape(response.get_data(as_text=True))
    response.close()
    assert "No ratings to analyse yet" in page and "vote" not in page.lower()
    assert "2 participants joined: 0 left out by exclusions, 2 by the hidden-reference " in page
    assert "Post-screening (ITU-R BS.1534-3, sec. 4.1.2, adapted to video)" in page
    assert "P0000: rated the hidden reference below 90 on 1 of 1 clips" in page
    assert "P0001: rated the hidden reference below 90 on 1 of 1 clips" in page
    study_page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    assert 'id="report-pdf"' not in study_page
