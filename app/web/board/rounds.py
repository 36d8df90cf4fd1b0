"""Rounds: the queued systems and the anchors in one paired study, planned by information gain.

:func:`create_round` takes every queued system (the newcomers) and the anchors: the season's
fixed anchors, the current top systems of the published board, and any system measured only
in a round whose anchors drifted (so it is measured again). It plans the pairs
(:func:`app.leaderboard.pairing.plan_pairs`: drift links, then expected information gain
under the posterior of the earlier rounds' votes) and makes the round's study on the study
platform: the season's frozen ``[test]`` and ``[render]`` settings, HEMVIP2's five levels,
the mismatched-speech pairs of the coherence test, and only the planned pairs (both orders,
across the counterbalancing lists). The study is then the platform's: its jobs render it
(locally or on render workers), its link (and Prolific, ``facepair prolific publish``)
recruits, its report and package are the round's record. A round never touches an earlier
round's study or votes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sqlalchemy as sa

from app.errors import InputError
from app.leaderboard.pairing import pair_budget, plan_pairs
from app.trials.schedule import foreign_clip
from app.trials.studyfile import parse_study
from app.web.board.models import BoardRound, BoardSystem, Season
from app.web.board.publish import pooled_votes, published_rounds
from app.web.board.seasons import season_spec, segment_clips, verify_pins
from app.web.board.store import season_dir, season_file
from app.web.board.submissions import refresh
from app.web.extensions import db
from app.web.models import Job, Stimulus, Study
from app.web.study.studies import change_status, create_study, stimulus_combinations


def rounds_of(season: Season) -> list[BoardRound]:
    return list(
        db.session.scalars(
            sa.select(BoardRound)
            .where(BoardRound.season_id == season.id)
            .order_by(BoardRound.number)
        )
    )


def round_by_number(season: Season, number: int | None = None) -> BoardRound:
    """Round ``number`` of the season (the latest when None); one line when there is none."""
    rounds = rounds_of(season)
    if not rounds:
        raise InputError(f"season {season.name} has no round yet", field="round")
    if number is None:
        return rounds[-1]
    for found in rounds:
        if found.number == number:
            return found
    raise InputError(f"season {season.name} has no round {number}", field="round")


def systems_of(season: Season) -> list[BoardSystem]:
    return list(
        db.session.scalars(
            sa.select(BoardSystem)
            .where(BoardSystem.season_id == season.id)
            .order_by(BoardSystem.id)
        )
    )


def _carried(season: Season, limit: int) -> list[str]:
    """Codes of the submitted systems that join the round as anchors: the published board's
    top ``limit`` by score, and every one marked to be measured again (drift)."""
    board = season.board or {}
    rows = [
        r for r in board.get("systems", []) if not r.get("anchor") and r.get("score") is not None
    ]
    rows.sort(key=lambda r: -float(r["score"]))
    codes = [r["code"] for r in rows[:limit]]
    codes += [r["code"] for r in rows if r.get("remeasure") and r["code"] not in codes]
    live = {s.code for s in systems_of(season) if s.status == "published"}
    return [c for c in codes if c in live]


def _segments(season: Season, number: int) -> list[str]:
    """The round's segments: all, or ``[rounds] segments`` of them drawn for this round."""
    spec = season_spec(season)
    names = [s.name for s in spec.segments]
    k = spec.rounds.segments
    if not k or k >= len(names):
        return names
    rng = np.random.default_rng([spec.seed % 2**63, number])
    keep = set(rng.choice(len(names), size=k, replace=False).tolist())
    return [n for i, n in enumerate(names) if i in keep]


def prior_wins(season: Season, codes: Sequence[str]) -> np.ndarray:
    """(n, n) naturalness judgements of i over j in the published rounds (ties as halves)."""
    n = len(codes)
    wins = np.zeros((n, n))
    frame = pooled_votes(season, published_rounds(season))
    if frame.empty:
        return wins
    index = {c: k for k, c in enumerate(codes)}
    rows = frame[
        ~frame["mismatched"].isin(("left", "right"))
        & frame["left"].isin(index)
        & frame["right"].isin(index)
        & (frame["left"] != frame["right"])
    ]
    for left, right, choice in zip(rows["left"], rows["right"], rows["choice"], strict=True):
        i, j = index[left], index[right]
        if choice == "left":
            wins[i, j] += 1.0
        elif choice == "right":
            wins[j, i] += 1.0
        elif choice == "undecided":
            wins[i, j] += 0.5
            wins[j, i] += 0.5
    return wins


def create_round(season: Season) -> tuple[BoardRound, list[int]]:
    """The next round with every queued system; returns it and the jobs to start after the
    commit (the study's tracks and clips). Not committed."""
    if season.status != "open":
        raise InputError(f"season {season.name} is closed", field="season")
    systems = systems_of(season)
    for system in systems:
        refresh(system)
    newcomers = sorted(
        (s for s in systems if s.kind == "submitted" and s.status == "queued"),
        key=lambda s: (s.queued_at, s.id),
    )
    if not newcomers:
        raise InputError(
            "no system is queued: a submission is queued once its submitter has seen its preview",
            field="round",
        )
    busy = [r.number for r in rounds_of(season) if r.status in ("preparing", "ready", "open")]
    if busy:
        raise InputError(f"round {busy[0]} is still running; close it first", field="round")
    verify_pins(season)
    spec = season_spec(season)
    number = len(rounds_of(season)) + 1
    fixed = list(spec.rounds.anchors)
    carried = [c for c in _carried(season, spec.rounds.top) if c not in fixed]
    codes = fixed + carried + [s.code for s in newcomers]
    anchors = fixed + carried
    segments = _segments(season, number)
    plan = plan_pairs(
        codes,
        prior_wins(season, codes),
        newcomers=[s.code for s in newcomers],
        anchors=anchors,
        budget=pair_budget(len(codes), spec.rounds.pairs),
    )
    by_code = {s.code: s for s in systems}
    conditions: list[dict[str, Any]] = []
    for code in codes:
        system = by_code[code]
        if system.kind == "anchor":
            conditions.append({"name": code, "model": system.model})
        else:
            tracks = {seg: str(season_file(season, system.files[seg]["drawn"])) for seg in segments}
            conditions.append({"name": code, "tracks": tracks})
    seed = (spec.seed + 7919 * number) % 2**63
    title = f"{season.title}: round {number}"
    mapping = spec.study_mapping(
        title=title, seed=seed, conditions=conditions, clips=segment_clips(spec, segments)
    )
    source = f"{season.name}-round-{number}.toml"
    study_spec = parse_study(mapping, source=source, base_dir=season_dir(season))
    study = create_study(season.organiser, study_spec, source_toml=study_spec.to_portable_toml())
    restrict_pairs(study, [(p.first, p.second) for p in plan])
    rnd = BoardRound(
        season_id=season.id,
        number=number,
        status="preparing",
        study_id=study.id,
        systems=codes,
        newcomers=[s.code for s in newcomers],
        anchors=anchors,
        segments=segments,
        plan=[[p.first, p.second, p.reason, round(p.gain, 6)] for p in plan],
    )
    db.session.add(rnd)
    for system in newcomers:
        system.status = "in_round"
    job = Job(study_id=study.id, kind="prepare")
    db.session.add(job)
    db.session.flush()
    return rnd, [job.id]


def restrict_pairs(study: Study, pairs: Sequence[tuple[str, str]]) -> None:
    """Keep only ``pairs`` (unordered, by condition name) of a draft study's design, and make
    its stimuli exactly what the schedules can then show (the pairs in both orders, the catch
    trials' and the mismatched-speech clips of every condition)."""
    wanted = {frozenset(p) for p in pairs}
    for pair in list(study.pairs):
        if frozenset((pair.first.name, pair.second.name)) not in wanted:
            study.pairs.remove(pair)
            db.session.delete(pair)
    for position, pair in enumerate(study.pairs):
        pair.position = position
    db.session.flush()
    names = {c.name: c.id for c in study.conditions}
    clips = {c.name: c.id for c in study.clips}
    order = [c.name for c in study.clips]
    want = {
        (clips[clip], names[left], names[right], instruction, foreign): clip
        for clip, left, right, instruction, foreign in stimulus_combinations(study)
    }
    have = db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id)).all()
    for stimulus in have:
        key = (
            stimulus.clip_id,
            stimulus.left_id,
            stimulus.right_id,
            stimulus.instruction,
            stimulus.foreign_side,
        )
        if key not in want:
            db.session.delete(stimulus)
        else:
            del want[key]
    for (clip_id, left, right, instruction, foreign), clip in want.items():
        lender = clips[foreign_clip(order, clip)] if foreign else None
        db.session.add(
            Stimulus(
                study_id=study.id,
                clip_id=clip_id,
                left_id=left,
                right_id=right,
                instruction=instruction,
                foreign_side=foreign,
                foreign_clip_id=lender,
            )
        )
    db.session.flush()


def refresh_round(rnd: BoardRound) -> BoardRound:
    """A preparing round whose study is rendered is ``ready``."""
    if rnd.status == "preparing" and rnd.study.status == "ready":
        rnd.status = "ready"
    return rnd


def open_round(rnd: BoardRound) -> None:
    """Open the round's study to participants (its link; ``facepair prolific publish`` with the
    season's ``[test.prolific]`` table)."""
    refresh_round(rnd)
    if rnd.status != "ready":
        raise InputError(
            f"round {rnd.number} is {rnd.status}; it opens once its clips are rendered",
            field="round",
        )
    change_status(rnd.study, "open")
    rnd.status = "open"


def close_round(rnd: BoardRound) -> list[int]:
    """Close the round's study; returns the report job to start after the commit (the report,
    its votes and the package are the round's record)."""
    if rnd.status != "open":
        raise InputError(f"round {rnd.number} is {rnd.status}, not open", field="round")
    change_status(rnd.study, "close")
    rnd.status = "closed"
    job = Job(study_id=rnd.study_id, kind="report")
    db.session.add(job)
    db.session.flush()
    return [job.id]


def plan_lines(rnd: BoardRound) -> list[str]:
    """The round's plan as lines a person reads."""
    return [f"{a} vs {b}: {reason} ({gain:.3f} nats)" for a, b, reason, gain in rnd.plan]
