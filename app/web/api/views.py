"""JSON endpoints under ``/api/v1``.

``POST /api/v1/votes`` (and ``POST /api/v1/ratings``, the rating design's answer) is
idempotent: the same ``idempotency_key`` (or a second vote on an
answered trial) returns the stored vote with status 200 instead of 201. Participants
authenticate with their token in the body (votes) or the URL (progress); job status needs the
owning experimenter's login.
"""

from __future__ import annotations

import json
import re
from typing import Any, NamedTuple

import sqlalchemy as sa
from flask import Response, abort, current_app, jsonify, make_response, request, url_for

from app.trials.rules import instructed_side
from app.web.api.blueprint import bp
from app.web.extensions import db
from app.web.infra import limits
from app.web.infra.accounts import current_user, study_access
from app.web.infra.i18n import use_language
from app.web.infra.limits import fits
from app.web.jobs.sweep import sweep_study_jobs
from app.web.models import Job, Participant, Trial
from app.web.study.medialog import MediaLogError, environment_fields
from app.web.study.participants import end_for_browser
from app.web.study.plays import PlayRejected, count_play, is_participant
from app.web.study.progress import progress as participant_progress
from app.web.study.ratings import record_rating, shown_items
from app.web.study.renditions import versions_have_webm, webm_offered
from app.web.study.studies import participation
from app.web.study.useragent import browser_of
from app.web.study.votes import (
    AnswerRejected,
    Voter,
    participant_for_vote,
    record_vote,
)
from app.web.study.wording import ended_reason

#: A vote is a few hundred bytes; anything much larger is not one.
MAX_BODY = 64 * 1024


def _error(message: str, status: int):  # type: ignore[no-untyped-def]
    return jsonify({"error": message}), status


def _json_object() -> dict[str, Any] | str:
    """The request's JSON object, or why there is none (one line naming the problem)."""
    length = request.content_length
    if (length or 0) > MAX_BODY:
        return f"body: larger than {MAX_BODY // 1024} KB"
    if not request.is_json:
        return "body: expected a JSON object"
    try:
        if length is not None:
            # Exactly Content-Length bytes (at most MAX_BODY, checked above) straight from the
            # server's stream, without werkzeug's guarded stream around it, which a vote's
            # few hundred bytes do not need. A body without a length (chunked) goes through
            # werkzeug, with its limits.
            payload = json.loads(request.environ["wsgi.input"].read(length))
        else:
            payload = request.get_json(silent=True)
    except RecursionError:
        return "body: JSON nested too deeply"
    except ValueError:  # not JSON, or not UTF-8
        return "body: expected a JSON object"
    return payload if isinstance(payload, dict) else "body: expected a JSON object"


def _refused(exc: AnswerRejected, participant: Participant):  # type: ignore[no-untyped-def]
    """The answer to a refused vote or rating, its transaction rolled back."""
    db.session.rollback()
    if exc.closed:
        # ``error`` for scripts (English); ``message`` for the participant's page.
        use_language(participation(participant.study).language)
        return jsonify(
            {"error": exc.message, "message": ended_reason(exc.message), "closed": True}
        ), exc.status
    return _error(exc.message, exc.status)


def _answer_request() -> tuple[dict[str, Any], Voter] | Response:
    """The answer request's JSON object and its participant (locked) with the trial, or the
    error response (400 for a body that is no JSON object, 403 for an unknown token)."""
    payload = _json_object()
    if isinstance(payload, str):
        return make_response(_error(payload, 400))
    voter = participant_for_vote(payload.get("token"), payload.get("trial_id"))
    if voter is None:
        return make_response(_error("unknown participant", 403))
    return payload, voter


@bp.post("/votes")
def post_vote():  # type: ignore[no-untyped-def]
    request_ = _answer_request()
    if not isinstance(request_, tuple):
        return request_
    payload, voter = request_
    try:
        outcome = record_vote(voter.participant, payload, voter.trial)
    except AnswerRejected as exc:
        return _refused(exc, voter.participant)
    vote = outcome.vote
    urls = _participant_urls(payload["token"])
    body = {
        "status": "recorded" if outcome.created else "duplicate",
        "vote": {
            "trial_id": vote.trial_id,
            "choice": vote.choice,
            "plays": vote.plays,
            "response_ms": vote.response_ms,
            "strength": vote.strength,
        },
        "answered": outcome.answered,
        "total": outcome.total,
        "next": urls.resume,
    }
    if outcome.answered >= outcome.total:
        body["next_trial"] = None  # every pair answered
    elif outcome.upcoming is not None:
        body["next_trial"] = _next_trial(urls, outcome.upcoming)
    db.session.commit()
    # The answer as jsonify would give it, without its indentation check and sorting: a
    # vote's answer is read by a script, not a person.
    return current_app.response_class(
        json.dumps(body, separators=(",", ":")),
        status=201 if outcome.created else 200,
        mimetype="application/json",
    )


@bp.post("/ratings")
def post_rating():  # type: ignore[no-untyped-def]
    """One trial's rating in the ``rating`` design (:func:`app.web.study.ratings.record_rating`):
    201 when stored, 200 with the stored rating for a retry."""
    request_ = _answer_request()
    if not isinstance(request_, tuple):
        return request_
    payload, rater = request_
    try:
        outcome = record_rating(rater.participant, payload, rater.trial)
    except AnswerRejected as exc:
        return _refused(exc, rater.participant)
    stored = outcome.rating
    if rater.participant.study.design == "parallel":
        # in the order the page shows the items (condition ids never leave the server)
        items = shown_items(rater.participant, rater.trial)  # type: ignore[arg-type]
        given: dict[str, Any] = {"scores": [stored.scores.get(c.id) for c in items]}
    else:
        given = {"score": next(iter(stored.scores.values()))}
    body = {
        "status": "recorded" if outcome.created else "duplicate",
        "rating": {
            "trial_id": stored.trial_id,
            **given,
            "plays": stored.plays,
            "response_ms": stored.response_ms,
        },
        "answered": outcome.answered,
        "total": outcome.total,
    }
    urls = _participant_urls(payload["token"])
    body["next"] = urls.resume
    if outcome.answered >= outcome.total:
        body["next_trial"] = None  # every clip rated
    elif outcome.upcoming is not None:
        body["next_trial"] = _next_rating(rater.participant, urls, outcome.upcoming)
    db.session.commit()
    return jsonify(body), 201 if outcome.created else 200


def _next_rating(participant: Participant, urls: ParticipantUrls, row: Any) -> dict[str, Any]:
    """The next trial as ``participant/rating.html`` or ``parallel.html`` shows it, for
    ``static/rating.js`` to go on to without loading the page (which stays the reference): the
    clip's URLs (MP4, WebM), the next one's to preload and whether it is a catch trial; for the
    parallel design the reference's URLs, the items' URLs up to the item's number and how
    many items the page shows."""
    shown: dict[str, Any] = {"trial_id": row.trial_id, "plays": row.plays}
    if participant.study.design != "parallel":
        return {**shown, **_clip_urls(urls, row), "catch": row.kind == "catch"}
    trial = db.session.get(Trial, row.trial_id)
    token, trial_id = participant.token, row.trial_id
    item_url = url_for("participant.item_video", token=token, trial_id=trial_id, item=0)
    webm = versions_have_webm(trial.stimulus.clip_id)  # type: ignore[union-attr]
    item_webm = url_for("participant.item_webm", token=token, trial_id=trial_id, item=0)
    return {
        **shown,
        "reference_url": f"{urls.video}{trial_id}",
        "item_url": item_url[:-1],
        "reference_webm_url": f"{urls.webm}{trial_id}" if webm else None,
        "item_webm_url": item_webm[:-1] if webm else None,
        "items": len(shown_items(participant, trial)),  # type: ignore[arg-type]
    }


#: A token of only these characters (every token facepair issues) is one ``url_for`` writes
#: as it is into a path.
_VERBATIM = re.compile(r"[A-Za-z0-9_.~-]+")
#: Stands for the token in the routes built once (:func:`_participant_urls`).
_TOKEN = "~token~"


class ParticipantUrls(NamedTuple):
    """A participant's resume URL and their clips' URLs (MP4, WebM) up to the trial's id."""

    resume: str
    video: str
    webm: str

    def with_token(self, token: str) -> ParticipantUrls:
        return ParticipantUrls(*(url.replace(_TOKEN, token) for url in self))


def _participant_urls(token: str) -> ParticipantUrls:
    """The participant's resume URL and their clips' URLs up to the trial's id, as
    ``url_for`` builds them; the routes are built once per application and script root
    (every vote answers with them), and a token ``url_for`` would quote is built the usual
    way."""
    routes = current_app.extensions.setdefault("facepair.participant_urls", {})
    root = request.script_root
    if root not in routes and len(routes) < 8:  # a deployment's one root, or a few proxies'
        built = _built(_TOKEN)
        # None: the root itself holds the placeholder, so every vote builds its URLs.
        routes[root] = built if all(url.count(_TOKEN) == 1 for url in built) else None
    found = routes.get(root)
    if found is None or not _VERBATIM.fullmatch(token):
        return _built(token)
    return found.with_token(token)


def _built(token: str) -> ParticipantUrls:
    video = url_for("participant.video", token=token, trial_id=0)
    webm = url_for("participant.video_webm", token=token, trial_id=0)
    return ParticipantUrls(
        url_for("participant.resume", token=token), video.removesuffix("0"), webm.removesuffix("0")
    )


def _clip_urls(urls: ParticipantUrls, row: Any) -> dict[str, str | None]:
    """The next trial's clip URLs and the one after it's, to preload: each MP4, and each WebM
    where the clip has one (:func:`app.web.study.progress.next_trial_of`)."""
    following = row.following
    return {
        "video_url": f"{urls.video}{row.trial_id}",
        "webm_url": f"{urls.webm}{row.trial_id}" if row.webm else None,
        "preload_url": None if following is None else f"{urls.video}{following}",
        "preload_webm_url": (
            f"{urls.webm}{following}" if following is not None and row.following_webm else None
        ),
    }


def _next_trial(urls: ParticipantUrls, row: Any) -> dict[str, Any]:
    """The next pair as ``participant/trial.html`` shows it, for the player to go on to
    without loading that page (``static/pair.js``); the page stays the reference."""
    return {
        "trial_id": row.trial_id,
        "plays": row.plays,
        **_clip_urls(urls, row),
        "instructed": instructed_side(row.kind, row.expected, lambda: row.instruction),
    }


@bp.post("/plays")
def post_play():  # type: ignore[no-untyped-def]
    """One play of a trial's clip, asked for before it starts: counted on the trial
    (:func:`app.web.study.plays.count_play`), so the replay policy holds across reloads. 409
    when no play is left (``max_plays``)."""
    payload = _json_object()
    if isinstance(payload, str):
        return _error(payload, 400)
    token, trial_id = payload.get("token"), payload.get("trial_id")
    if not isinstance(token, str) or not fits(Participant.token, token):
        return _error("unknown participant", 403)
    if isinstance(trial_id, bool) or not isinstance(trial_id, int) or not fits(Trial.id, trial_id):
        if not is_participant(token):
            return _error("unknown participant", 403)
        return _error("trial_id: expected a whole number", 400)
    try:
        play = count_play(token, trial_id)
    except PlayRejected as exc:
        return _error(exc.message, exc.status)
    # a refused play wrote nothing: the commit ends the transaction (SQLite's write lock) now
    db.session.commit()
    if play.refusal is not None:
        return jsonify({"error": play.refusal, "plays": play.plays, "plays_left": play.left}), 409
    return jsonify({"plays": play.plays, "plays_left": play.left}), 200


@bp.post("/participants/<token>/environment")
def post_environment(token: str):  # type: ignore[no-untyped-def]
    """The device and the viewing check, reported once before the first trial (a later
    report replaces it until the first trial is shown)."""
    participant = (
        db.session.scalar(sa.select(Participant).where(Participant.token == token))
        if fits(Participant.token, token)
        else None
    )
    if participant is None:
        return _error("unknown participant", 404)
    payload = _json_object()
    if isinstance(payload, str):
        return _error(payload, 400)
    agent = limits.printable(request.user_agent.string)[:300]
    try:
        found = environment_fields(
            payload, agent, min_face_px=participation(participant.study).min_face_px
        )
    except MediaLogError as exc:
        return _error(str(exc), 400)
    if participant.started_at is None or participant.environment is None:
        participant.environment = found
        db.session.commit()
    return jsonify({"viewing_ok": found["viewing_ok"]}), 200


@bp.post("/participants/<token>/unplayable")
def post_unplayable(token: str):  # type: ignore[no-untyped-def]
    """The participant's browser played none of the clip's renditions (each one it tried was
    served and refused as a format it cannot play): their session ends and their list slot
    goes back (:func:`app.web.study.participants.end_for_browser`); the answer names the final
    page. Repeating it changes nothing; a finished participant is refused (409)."""
    participant = (
        db.session.scalar(sa.select(Participant).where(Participant.token == token))
        if fits(Participant.token, token)
        else None
    )
    if participant is None:
        return _error("unknown participant", 404)
    if participant.finished_at is not None:
        return _error("this participant has finished", 409)
    if end_for_browser(participant, webm_offered=webm_offered(participant)):
        # The browser by its name: the failure may come before the environment's report.
        agent = limits.printable(request.user_agent.string)[:300]
        environment = dict(participant.environment or {})
        if not environment.get("browser"):
            environment["browser"], environment["browser_version"] = browser_of(agent)
            participant.environment = environment
    db.session.commit()
    return jsonify({"next": url_for("participant.unplayable", token=token)}), 200


@bp.get("/participants/<token>/progress")
def progress(token: str):  # type: ignore[no-untyped-def]
    participant = db.session.scalar(sa.select(Participant).where(Participant.token == token))
    if participant is None:
        return _error("unknown participant", 404)
    answered, total = participant_progress(participant)
    return jsonify(
        {"answered": answered, "total": total, "finished": participant.finished_at is not None}
    )


@bp.get("/jobs/<int:job_id>")
def job_status(job_id: int):  # type: ignore[no-untyped-def]
    user = current_user()
    if user is None:
        return _error("login required", 401)
    job = db.session.get(Job, job_id)
    if job is None or study_access(job.study, user.id) is None:
        abort(404)
    if job.status in ("queued", "running"):
        sweep_study_jobs(job.study_id)
        db.session.refresh(job)
    return jsonify(job.as_dict())
