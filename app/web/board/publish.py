"""Publishing: every closed round's votes pooled, scored, checked for drift, and written out.

:func:`publish` reads each closed round's votes from its report (the ``votes.csv`` its package
holds, the participants its exclusion rules left out taken from ``results.json``), checks each
round's anchors against the rounds before it (:func:`app.leaderboard.drift.drift_check`),
fits the board (:func:`app.leaderboard.board.standings`), measures systems not yet measured
(:mod:`app.leaderboard.objective`), and stores ``leaderboard.json`` on the season. Rounds and
their newcomers become public. :func:`export_static` writes the same board as a folder any
web host serves: ``index.html``, ``leaderboard.json``, ``votes.csv``, ``leaderboard.css``,
``renders/<code>/<segment>.mp4`` and ``rounds/<n>/package.zip``; the platform serves the same
layout under ``/leaderboard/<season>/`` (:mod:`app.web.leaderboard`), so one set of relative
links works in both.
"""

from __future__ import annotations

import datetime as dt
import io
import json
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd
import sqlalchemy as sa
from flask import render_template

from app.analysis.votes import read_votes, write_votes_csv
from app.errors import InputError
from app.leaderboard.board import SystemEntry, board_document, standings
from app.leaderboard.drift import drift_check
from app.leaderboard.votes import pooled_frame
from app.web.board.models import BoardRound, BoardSystem, Season
from app.web.board.seasons import season_spec
from app.web.board.submissions import is_anonymous, public_name
from app.web.extensions import db
from app.web.infra import media
from app.web.infra.storage import report_path
from app.web.models import Clip, Condition, Stimulus, Study, Track, utcnow
from app.web.study.package import build_package

#: Static files the board's page uses, copied beside ``index.html`` by :func:`export_static`.
STYLESHEET = "leaderboard.css"


def published_rounds(season: Season) -> list[BoardRound]:
    return _rounds(season, ("published",))


def _rounds(season: Season, states: Sequence[str]) -> list[BoardRound]:
    return list(
        db.session.scalars(
            sa.select(BoardRound)
            .where(BoardRound.season_id == season.id, BoardRound.status.in_(states))
            .order_by(BoardRound.number)
        )
    )


def round_frame(rnd: BoardRound) -> pd.DataFrame:
    """The votes round ``rnd``'s report analysed, with its number and, in ``excluded``, the
    participants its exclusion rules left out (``results.json``, ``quality.excluded``)."""
    study = rnd.study
    folder = report_path(study).parent.name
    votes = media.fetch(study, f"{folder}/votes.csv")
    if not votes.is_file():
        raise InputError(
            f"round {rnd.number}: no report yet (close the round; its report job writes it)",
            field="round",
        )
    frame = read_votes(votes).frame.copy()
    results = media.fetch(study, f"{folder}/results.json")
    if results.is_file():
        quality = json.loads(results.read_text(encoding="utf-8")).get("quality") or {}
        for person, why in (quality.get("excluded") or {}).items():
            rows = frame["participant"].astype(str) == str(person)
            frame["excluded"] = frame["excluded"].astype(object)
            frame.loc[rows & (frame["excluded"] == ""), "excluded"] = str(why) or "rule"
    frame["round"] = rnd.number
    return frame


def pooled_votes(season: Season, rounds: Sequence[BoardRound]) -> pd.DataFrame:
    """Every analysed vote of ``rounds`` (:func:`app.leaderboard.votes.pooled_frame`)."""
    frames = [round_frame(r) for r in rounds]
    if not frames:
        return pooled_frame(pd.DataFrame({"round": pd.Series([], dtype=int)}))
    return pooled_frame(pd.concat(frames, ignore_index=True))


def render_of(season: Season, system: BoardSystem, segment: str) -> tuple[Study, str] | None:
    """The single-face clip of ``system`` on ``segment``: its study and stored path."""
    study = season.anchors_study if system.kind == "anchor" else system.preview_study
    if study is None:
        return None
    found = db.session.execute(
        sa.select(Stimulus.video_path)
        .join(Clip, Stimulus.clip_id == Clip.id)
        .join(Condition, Stimulus.left_id == Condition.id)
        .where(
            Stimulus.study_id == study.id,
            Clip.name == segment,
            Condition.name == system.code,
            Stimulus.video_path.is_not(None),
        )
    ).first()
    return None if found is None else (study, str(found[0]))


def renders_public(season: Season, system: BoardSystem) -> bool:
    """Whether the board links a system's renders: not the ground truth's while the season
    runs (the test motion is never released then)."""
    return not (
        system.kind == "anchor" and system.model == "ground_truth" and season.status == "open"
    )


def _objective(season: Season, system: BoardSystem, segments: Sequence[str]) -> dict[str, Any]:
    """The system's objective measures from the tracks its single-face study rendered."""
    from app.leaderboard.objective import objective_measures
    from app.stimuli.io import load_track
    from app.stimuli.speech import extract_features

    study = season.anchors_study if system.kind == "anchor" else system.preview_study
    if study is None:
        return {}
    spec = season_spec(season)
    by_name = {s.name: s for s in spec.segments}
    rows = db.session.execute(
        sa.select(Clip.name, Track.path)
        .join(Track, Track.clip_id == Clip.id)
        .join(Condition, Track.condition_id == Condition.id)
        .where(Clip.study_id == study.id, Condition.name == system.code)
    ).all()
    tracks = {name: load_track(media.fetch(study, path)) for name, path in rows}
    tracks = {k: v for k, v in tracks.items() if k in segments}
    if not tracks:
        return {}
    truths = {k: load_track(by_name[k].ground_truth) for k in tracks}
    features = {k: extract_features(by_name[k].audio, fps=tracks[k].fps) for k in tracks}
    return objective_measures(tracks, truths, features)


def publish(season: Season, *, today: dt.date | None = None) -> dict[str, Any]:
    """Fit and store the board of every closed round; returns ``leaderboard.json``. Not
    committed."""
    rounds = _rounds(season, ("closed", "published"))
    if not rounds:
        raise InputError(f"season {season.name}: no closed round to publish", field="round")
    spec = season_spec(season)
    frame = pooled_votes(season, rounds)
    systems = {
        s.code: s
        for s in db.session.scalars(
            sa.select(BoardSystem).where(BoardSystem.season_id == season.id)
        )
    }
    fixed = list(spec.rounds.anchors)
    seen = [c for r in rounds for c in r.systems]
    codes = fixed + [c for c in dict.fromkeys(seen) if c not in fixed]
    publish_rules = spec.publish
    for rnd in rounds:
        links = [(a, b) for a, b, reason, _ in rnd.plan if reason == "drift link"]
        rnd.drift = drift_check(
            frame[frame["round"] <= rnd.number],
            codes,
            links,
            rnd.number,
            bootstrap=publish_rules.bootstrap,
            seed=spec.seed,
            alpha=publish_rules.drift_alpha,
        )
    drifted = [r.number for r in rounds if (r.drift or {}).get("drifted")]
    segments = [s.name for s in spec.segments]
    fitted = standings(
        frame,
        codes,
        fixed,
        publish_rules,
        seed=spec.seed,
        segments=segments,
        drifted_rounds=drifted,
    )
    entries = []
    for code in codes:
        system = systems[code]
        if system.objective is None:
            system.objective = _objective(season, system, segments)
        anonymous = is_anonymous(system, today)
        renders = [
            {"segment": seg, "url": f"renders/{code}/{seg}.mp4"}
            for seg in segments
            if renders_public(season, system) and render_of(season, system, seg) is not None
        ]
        team = system.submitter.team if system.submitter is not None else "facepair"
        entries.append(
            SystemEntry(
                code=code,
                name=public_name(system, today),
                anchor=system.kind == "anchor",
                team="" if anonymous else team,
                paper="" if anonymous else system.paper,
                training_data="" if anonymous else system.training_data,
                anonymous_until=system.anonymous_until.isoformat()
                if anonymous and system.anonymous_until
                else None,
                renders=tuple(renders),
                objective=system.objective or {},
            )
        )
    now = utcnow()
    round_rows = []
    for rnd in rounds:
        people = frame.loc[frame["round"] == rnd.number, "participant"].nunique()
        round_rows.append(
            {
                "number": rnd.number,
                "systems": [public_name(systems[c], today) for c in rnd.systems],
                "newcomers": [public_name(systems[c], today) for c in rnd.newcomers],
                "anchors": [public_name(systems[c], today) for c in rnd.anchors],
                "segments": list(rnd.segments),
                "votes": int((frame["round"] == rnd.number).sum()),
                "participants": int(people),
                "pairs": [
                    [public_name(systems[a], today), public_name(systems[b], today), why]
                    for a, b, why, _ in rnd.plan
                ],
                "drift": _named_drift(rnd.drift, systems, today),
                "package": f"rounds/{rnd.number}/package.zip",
                "published_at": (rnd.published_at or now).strftime("%Y-%m-%dT%H:%M:%SZ"),
            }
        )
        if rnd.status != "published":
            rnd.status, rnd.published_at = "published", now
    for code in codes:
        if systems[code].kind == "submitted" and systems[code].status == "in_round":
            systems[code].status = "published"
    board = board_document(
        season={
            "name": season.name,
            "title": season.title,
            "status": season.status,
            "manifest_sha256": season.manifest_sha256,
            "licence": season.manifest.get("licence"),
            "segments": [
                {"name": s["name"], "transcript": s["transcript"], "duration_s": s["duration_s"]}
                for s in season.manifest["segments"]
            ],
        },
        entries=entries,
        fitted=fitted,
        rounds=round_rows,
        rules=publish_rules,
        published_at=now.strftime("%Y-%m-%dT%H:%M:%SZ"),
        links={
            "votes": "votes.csv",
            "reproduce": (
                f"facepair analyze votes.csv --bootstrap {publish_rules.bootstrap} "
                f"--seed {spec.seed} --json results.json"
            ),
        },
    )
    season.board = board
    season.published_at = now
    return board


def _named_drift(
    drift: dict[str, Any] | None, systems: dict[str, BoardSystem], today: dt.date | None
) -> dict[str, Any] | None:
    if drift is None:
        return None
    links = [
        {**link, "anchors": [public_name(systems[a], today) for a in link["anchors"]]}
        for link in drift.get("links", [])
    ]
    return {**drift, "links": links}


def votes_csv(season: Season) -> str:
    """The published rounds' analysed votes as one votes CSV (the analysis's own format), the
    participants named by round: what ``facepair analyze`` refits the scores from."""
    frames = [round_frame(r) for r in published_rounds(season)]
    buffer = io.StringIO()
    if frames:
        frame = pd.concat(frames, ignore_index=True)
        frame["study"] = "round-" + frame["round"].astype(str)
        frame["participant"] = (
            "r" + frame["round"].astype(str) + "/" + frame["participant"].astype(str)
        )
        frame = frame.drop(columns=["round"])
        write_votes_csv(read_votes(frame), buffer)
    return buffer.getvalue()


def round_package(season: Season, number: int) -> tuple[bytes, str]:
    """The published round's study package (every vote, pseudonymous) and its file name."""
    for rnd in published_rounds(season):
        if rnd.number == number:
            return build_package(rnd.study), f"{season.name}-round-{number}-package.zip"
    raise InputError(f"no published round {number}", field="round")


def board_page(season: Season, *, stylesheet: str, static: bool) -> str:
    """The board's HTML page (``templates/leaderboard/board.html``) from the stored board."""
    from app.leaderboard.objective import MEASURES

    return render_template(
        "leaderboard/board.html",
        season=season,
        board=season.board,
        stylesheet=stylesheet,
        static=static,
        measures=MEASURES,
        axis=score_axis(season.board),
    )


def score_axis(board: dict[str, Any] | None) -> tuple[float, float] | None:
    """The range the page's interval bars share: every score and bound, with a margin."""
    values = [
        float(v)
        for row in (board or {}).get("systems", [])
        for v in (row["score"], row["ci_low"], row["ci_high"])
        if v is not None
    ]
    if not values:
        return None
    low, high = min(values), max(values)
    margin = max(high - low, 1.0) * 0.05
    return low - margin, high + margin


def export_static(season: Season, out: Path) -> list[Path]:
    """Write the published board as a folder any web host serves; returns the files."""
    if season.board is None:
        raise InputError(f"season {season.name} has no published board yet", field="season")
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def put(rel: str, data: bytes) -> None:
        path = out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        written.append(path)

    put("leaderboard.json", (json.dumps(season.board, indent=1) + "\n").encode())
    put("index.html", board_page(season, stylesheet=STYLESHEET, static=True).encode())
    put("votes.csv", votes_csv(season).encode())
    css = Path(__file__).resolve().parents[1] / "static" / STYLESHEET
    put(STYLESHEET, css.read_bytes())
    systems = {
        s.code: s
        for s in db.session.scalars(
            sa.select(BoardSystem).where(BoardSystem.season_id == season.id)
        )
    }
    for row in season.board["systems"]:
        for render in row["renders"]:
            found = render_of(season, systems[row["code"]], render["segment"])
            if found is not None:
                target = out / render["url"]
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(media.fetch(found[0], found[1]), target)
                written.append(target)
    for rnd in season.board["rounds"]:
        data, _ = round_package(season, rnd["number"])
        put(rnd["package"], data)
    return written
