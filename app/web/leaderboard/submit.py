"""Submitters' pages: the submission form, its JSON twin for ``facepair leaderboard submit
--url``, and the private preview (``/leaderboard/<season>/preview/<token>``) where a submitter
sees the checks and the renders and queues the system for the next round."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from flask import (
    abort,
    current_app,
    flash,
    jsonify,
    redirect,
    render_template,
    request,
    url_for,
)
from flask_wtf.csrf import validate_csrf
from werkzeug.utils import secure_filename
from wtforms.validators import ValidationError

from app.errors import InputError
from app.web.board.publish import render_of
from app.web.board.seasons import season_spec, start_jobs
from app.web.board.submissions import (
    Description,
    SubmissionRefused,
    by_preview_token,
    preview_job,
    queue_system,
    refresh,
    submit,
)
from app.web.extensions import csrf, db, limiter
from app.web.infra.media import media_response
from app.web.leaderboard.blueprint import bp
from app.web.leaderboard.views import season_or_404, speech_name

#: Files one submission may hold (segments times samples stays far below it).
MAX_FILES = 2000


def _upload_limit() -> str:
    return str(current_app.config.get("LEADERBOARD_UPLOAD_LIMIT") or "1000000 per second")


@contextmanager
def _uploaded() -> Iterator[tuple[dict[str, Path], list[str]]]:
    """The request's files saved in a private folder under their own (made safe) names, and
    the problems with the upload itself (names that cannot be files, repeats, too many)."""
    problems: list[str] = []
    files: dict[str, Path] = {}
    uploads = request.files.getlist("files")
    with tempfile.TemporaryDirectory(prefix="facepair-submission-") as folder:
        if len(uploads) > MAX_FILES:
            problems.append(f"files: {len(uploads)} files, at most {MAX_FILES}")
            uploads = []
        for upload in uploads:
            given = (upload.filename or "").replace("\\", "/").rsplit("/", 1)[-1]
            name = secure_filename(given)
            if not given:
                continue
            if not name or name.startswith("."):
                problems.append(f"{given[:80]!r}: not a file name that can be kept")
                continue
            if name in files:
                problems.append(f"{name}: sent twice")
                continue
            path = Path(folder) / name
            upload.save(path)
            files[name] = path
        yield files, problems


def _run(season_name: str) -> tuple[object, object, list[str]]:
    """Submit the request's form and files; the system and key, or the problems."""
    season = season_or_404(season_name)
    with _uploaded() as (files, upload_problems):
        try:
            form = Description.from_mapping(request.form)
            if upload_problems:
                raise SubmissionRefused(upload_problems)
            # no files at all: the description's problems and one line per missing segment
            system, key, jobs = submit(season, form, files)
        except InputError as exc:
            db.session.rollback()
            problems = exc.problems if isinstance(exc, SubmissionRefused) else [str(exc)]
            return None, None, problems
        db.session.commit()
    start_jobs(current_app._get_current_object(), jobs)  # type: ignore[attr-defined]
    return system, key, []


@bp.route("/<name>/submit", methods=["GET", "POST"])
@limiter.limit(_upload_limit, methods=["POST"])
def submit_form(name: str):  # type: ignore[no-untyped-def]
    season = season_or_404(name)
    spec = season_spec(season)
    speech = [(s.name, speech_name(s.name, s.audio), s.transcript) for s in spec.segments]
    if request.method == "GET":
        return render_template(
            "leaderboard/submit.html", season=season, spec=spec, speech=speech, problems=[], form={}
        )
    try:
        validate_csrf(request.form.get("csrf_token"))
    except ValidationError:
        abort(400, description="the form expired; load the page again")
    system, key, problems = _run(name)
    if problems:
        page = render_template(
            "leaderboard/submit.html",
            season=season,
            spec=spec,
            speech=speech,
            problems=problems,
            form=request.form,
        )
        return page, 400
    if key:
        flash(f"Your submitter key (shown once; keep it to submit another system): {key}", "ok")
    return redirect(url_for(".preview", name=name, token=system.preview_token))  # type: ignore[attr-defined]


@bp.post("/<name>/api/submissions")
@csrf.exempt
@limiter.limit(_upload_limit)
def api_submit(name: str):  # type: ignore[no-untyped-def]
    """The form as JSON (``facepair leaderboard submit --url``): 201 with the private preview's
    link (and a new submitter's key), or 400 with every problem, one line each."""
    system, key, problems = _run(name)
    if problems:
        return jsonify({"errors": problems}), 400
    return jsonify(
        {
            "system": system.name,  # type: ignore[attr-defined]
            "code": system.code,  # type: ignore[attr-defined]
            "preview": url_for(
                ".preview",
                name=name,
                token=system.preview_token,  # type: ignore[attr-defined]
                _external=True,
            ),
            "key": key,
            "check": system.check,  # type: ignore[attr-defined]
        }
    ), 201


def _preview_system(name: str, token: str):  # type: ignore[no-untyped-def]
    season = season_or_404(name)
    system = by_preview_token(season, token)
    if system is None:
        abort(404)
    return season, system


@bp.get("/<name>/preview/<token>")
def preview(name: str, token: str):  # type: ignore[no-untyped-def]
    season, system = _preview_system(name, token)
    refresh(system)
    db.session.commit()
    segments = [s["name"] for s in season.manifest["segments"]]
    clips = {seg: render_of(season, system, seg) is not None for seg in segments}
    page = render_template(
        "leaderboard/preview.html",
        season=season,
        system=system,
        job=preview_job(system),
        clips=clips,
    )
    response = current_app.make_response(page)
    response.headers["Cache-Control"] = "no-store"
    response.headers["Referrer-Policy"] = "no-referrer"  # the link is the credential
    return response


@bp.get("/<name>/preview/<token>/<segment>.mp4")
def preview_clip(name: str, token: str, segment: str):  # type: ignore[no-untyped-def]
    season, system = _preview_system(name, token)
    found = render_of(season, system, segment)
    if found is None:
        abort(404)
    return media_response(found[0], found[1], mimetype="video/mp4", download_name=f"{segment}.mp4")


@bp.get("/<name>/preview/<token>/<segment>.vtt")
def preview_captions(name: str, token: str, segment: str):  # type: ignore[no-untyped-def]
    """The segment's transcript as captions over its whole length (WebVTT)."""
    season, _system = _preview_system(name, token)
    found = next((s for s in season.manifest["segments"] if s["name"] == segment), None)
    if found is None:
        abort(404)
    return current_app.response_class(
        webvtt(found["transcript"], float(found["duration_s"])), mimetype="text/vtt"
    )


def webvtt(text: str, seconds: float) -> str:
    """One cue holding ``text`` for ``seconds``.

    >>> print(webvtt("Will we ever", 1.5), end="")
    WEBVTT
    <BLANKLINE>
    00:00:00.000 --> 00:00:01.500
    Will we ever
    """
    minutes, rest = divmod(max(seconds, 0.001), 60.0)
    hours, minutes = divmod(int(minutes), 60)
    end = f"{hours:02d}:{minutes:02d}:{rest:06.3f}"
    line = " ".join(text.replace("-->", "->").split())
    return f"WEBVTT\n\n00:00:00.000 --> {end}\n{line}\n"


@bp.post("/<name>/preview/<token>/queue")
def queue(name: str, token: str):  # type: ignore[no-untyped-def]
    season, system = _preview_system(name, token)
    try:
        validate_csrf(request.form.get("csrf_token"))
    except ValidationError:
        abort(400, description="the form expired; load the page again")
    try:
        queue_system(system)
    except InputError as exc:
        db.session.rollback()
        flash(str(exc), "error")
    else:
        db.session.commit()
        flash("Queued: the next round of this season will compare it.", "ok")
    return redirect(url_for(".preview", name=name, token=token))
