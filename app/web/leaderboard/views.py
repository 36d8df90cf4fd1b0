"""The public board: ``/leaderboard/<season>/`` and the files beside it, laid out as the static
export lays them out (``app.web.board.publish.export_static``), so the page's relative links
work in both: ``leaderboard.json``, ``votes.csv``, ``renders/<code>/<segment>.mp4``,
``rounds/<n>/package.zip``, and the segments' speech for submitters."""

from __future__ import annotations

import io
from pathlib import Path

import sqlalchemy as sa
from flask import Response, abort, jsonify, redirect, render_template, send_file, url_for

from app.web.board.models import BoardSystem, Season
from app.web.board.publish import board_page, render_of, round_package, votes_csv
from app.web.board.seasons import season_by_name, season_spec
from app.web.extensions import db
from app.web.infra.media import media_response
from app.web.leaderboard.blueprint import bp

#: Seconds a browser or proxy may keep the public board's files.
PUBLIC_CACHE = 300


def season_or_404(name: str) -> Season:
    season = season_by_name(name)
    if season is None:
        abort(404)
    return season


@bp.get("/")
def seasons():  # type: ignore[no-untyped-def]
    rows = db.session.scalars(sa.select(Season).order_by(Season.created_at.desc())).all()
    return render_template("leaderboard/seasons.html", seasons=rows)


@bp.get("/<name>")
def season_redirect(name: str):  # type: ignore[no-untyped-def]
    """The board's page is a folder (its links are relative to it)."""
    return redirect(url_for(".board", name=name))


@bp.get("/<name>/")
def board(name: str):  # type: ignore[no-untyped-def]
    season = season_or_404(name)
    page = board_page(
        season, stylesheet=url_for("static", filename="leaderboard.css"), static=False
    )
    response = Response(page, mimetype="text/html")
    response.cache_control.public = True
    response.cache_control.max_age = PUBLIC_CACHE
    return response


@bp.get("/<name>/leaderboard.json")
def board_json(name: str):  # type: ignore[no-untyped-def]
    season = season_or_404(name)
    if season.board is None:
        abort(404, description="no round of this season is published yet")
    response = jsonify(season.board)
    response.headers["Access-Control-Allow-Origin"] = "*"  # any site may show the board
    response.cache_control.max_age = PUBLIC_CACHE
    return response


@bp.get("/<name>/votes.csv")
def board_votes(name: str):  # type: ignore[no-untyped-def]
    season = season_or_404(name)
    if season.board is None:
        abort(404, description="no round of this season is published yet")
    return Response(
        votes_csv(season),
        mimetype="text/csv",
        headers={"Content-Disposition": f'attachment; filename="{season.name}-votes.csv"'},
    )


@bp.get("/<name>/renders/<code>/<segment>.mp4")
def render(name: str, code: str, segment: str):  # type: ignore[no-untyped-def]
    """A published system's single-face clip of one segment (only what the board links)."""
    season = season_or_404(name)
    listed = {
        (row["code"], r["segment"])
        for row in (season.board or {}).get("systems", [])
        for r in row["renders"]
    }
    if (code, segment) not in listed:
        abort(404)
    system = db.session.scalar(
        sa.select(BoardSystem).where(BoardSystem.season_id == season.id, BoardSystem.code == code)
    )
    found = render_of(season, system, segment) if system is not None else None
    if found is None:
        abort(404)
    return media_response(
        found[0],
        found[1],
        mimetype="video/mp4",
        cache_seconds=PUBLIC_CACHE,
        download_name=f"{code}-{segment}.mp4",
    )


@bp.get("/<name>/rounds/<int:number>/package.zip")
def package(name: str, number: int):  # type: ignore[no-untyped-def]
    season = season_or_404(name)
    if not any(r["number"] == number for r in (season.board or {}).get("rounds", [])):
        abort(404)
    data, filename = round_package(season, number)
    return send_file(
        io.BytesIO(data), mimetype="application/zip", as_attachment=True, download_name=filename
    )


@bp.get("/<name>/segments/<filename>")
def segment_audio(name: str, filename: str):  # type: ignore[no-untyped-def]
    """A segment's speech (``s01.wav``): what submitters make their motion from."""
    season = season_or_404(name)
    found = next(
        (s for s in season_spec(season).segments if speech_name(s.name, s.audio) == filename),
        None,
    )
    if found is None or not found.audio.is_file():
        abort(404)
    return send_file(found.audio, as_attachment=True, download_name=filename)


def speech_name(segment: str, audio: Path) -> str:
    """The file name a segment's speech is offered under."""
    return f"{segment}{audio.suffix.lower()}"
