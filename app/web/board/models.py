"""The leaderboard's rows: seasons, submitters, systems and rounds.

A season's benchmark files live in ``MEDIA_ROOT/season-<id>/`` (:mod:`app.web.board.store`);
everything shown to participants or submitters is a study of the study platform (a round's
paired study, a system's preview, the anchors' renders), so jobs, render workers, storage
backends, exports and packages are the studies' own.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

import sqlalchemy as sa
from sqlalchemy import orm as so

from app.web.extensions import db
from app.web.models import Study, User, new_token, utcnow

#: A season's state: ``open`` takes submissions and runs rounds; ``closed`` is final (the
#: ground truth's renders and the draw seed are public then).
SEASON_STATES = ("open", "closed")
#: A submitted system's state: ``previewing`` (its preview study is being rendered),
#: ``preview`` (rendered; only its submitter sees it), ``queued`` (for the next round),
#: ``in_round`` (a round is comparing it), ``published`` (on the board), ``withdrawn``.
SYSTEM_STATES = ("previewing", "preview", "queued", "in_round", "published", "withdrawn")
#: A round's state: ``preparing`` (its study is being rendered), ``ready``, ``open``
#: (participants vote), ``closed`` (report and package written), ``published``.
ROUND_STATES = ("preparing", "ready", "open", "closed", "published")


class Season(db.Model):
    """One leaderboard season: its file, its manifest (the frozen state, by SHA-256) and the
    last published board."""

    __tablename__ = "board_season"
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    #: The season file's ``name``: in every public URL.
    name: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True)
    title: so.Mapped[str] = so.mapped_column(sa.String(200))
    #: The experimenter who owns the season's studies (the file's ``organiser``).
    organiser_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("user.id"), index=True)
    status: so.Mapped[str] = so.mapped_column(sa.String(10), default="open")
    #: The season file as written (the record; its SHA-256 is in the manifest).
    source_toml: so.Mapped[str] = so.mapped_column(sa.Text)
    #: The season file as a mapping, its paths naming the copies in the season's folder
    #: (``app.web.board.store``): what rounds read (``app.web.board.seasons.season_spec``).
    settings: so.Mapped[dict[str, Any]] = so.mapped_column(sa.JSON)
    manifest: so.Mapped[dict[str, Any]] = so.mapped_column(sa.JSON)
    manifest_sha256: so.Mapped[str] = so.mapped_column(sa.String(64))
    #: Secret until the season closes: draws stochastic systems' samples (its SHA-256 is the
    #: manifest's ``draw_commitment``).
    draw_seed: so.Mapped[int] = so.mapped_column(sa.BigInteger)
    #: The anchors' single-face renders on every segment (a rating-design study, never opened).
    anchors_study_id: so.Mapped[int | None] = so.mapped_column(
        sa.ForeignKey("study.id", ondelete="SET NULL")
    )
    #: The last published ``leaderboard.json``.
    board: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)
    published_at: so.Mapped[dt.datetime | None]
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)

    organiser: so.Mapped[User] = so.relationship()
    anchors_study: so.Mapped[Study | None] = so.relationship()


class Submitter(db.Model):
    """A team that submits systems to a season; it proves itself by a key shown once."""

    __tablename__ = "board_submitter"
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    season_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("board_season.id"), index=True)
    team: so.Mapped[str] = so.mapped_column(sa.String(200))
    #: A contact e-mail that will still work when the season ends.
    contact: so.Mapped[str] = so.mapped_column(sa.String(200))
    #: SHA-256 of the submitter key (the key itself is shown once, never stored).
    key_hash: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True)
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)


class BoardSystem(db.Model):
    """A system on the board: an anchor (a stimulus model) or a submitted one (its tracks)."""

    __tablename__ = "board_system"
    __table_args__ = (
        sa.UniqueConstraint("season_id", "code"),
        sa.UniqueConstraint("season_id", "name"),
    )
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    season_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("board_season.id"))
    #: Its name in every study and vote: the anchor's model, or ``sysNN`` (never the system's
    #: name, so a package names no anonymous system).
    code: so.Mapped[str] = so.mapped_column(sa.String(16))
    name: so.Mapped[str] = so.mapped_column(sa.String(80))
    #: ``anchor`` or ``submitted``.
    kind: so.Mapped[str] = so.mapped_column(sa.String(10))
    #: The anchor's stimulus model, or ``upload``.
    model: so.Mapped[str] = so.mapped_column(sa.String(80), default="upload")
    status: so.Mapped[str] = so.mapped_column(sa.String(12), default="previewing")
    submitter_id: so.Mapped[int | None] = so.mapped_column(sa.ForeignKey("board_submitter.id"))
    paper: so.Mapped[str] = so.mapped_column(sa.String(500), default="")
    training_data: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    #: The licence granted for its tracks, renders and votes, and when.
    licence: so.Mapped[str] = so.mapped_column(sa.String(80), default="")
    licence_granted_at: so.Mapped[dt.datetime | None]
    #: Shown instead of ``name`` (and team and paper hidden) until ``anonymous_until``.
    anonymous_name: so.Mapped[str | None] = so.mapped_column(sa.String(80))
    anonymous_until: so.Mapped[dt.date | None]
    #: The upload check (``app.leaderboard.checks``) and the files: segment -> the drawn file
    #: and every sample, relative to the season's folder.
    check: so.Mapped[dict[str, Any]] = so.mapped_column(sa.JSON, default=dict)
    files: so.Mapped[dict[str, Any]] = so.mapped_column(sa.JSON, default=dict)
    #: Objective measures against the ground truth, kept beside the scores (never in them).
    objective: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)
    #: The private preview link is ``/leaderboard/<season>/preview/<preview_token>``.
    preview_token: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True, default=new_token)
    preview_study_id: so.Mapped[int | None] = so.mapped_column(
        sa.ForeignKey("study.id", ondelete="SET NULL")
    )
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    queued_at: so.Mapped[dt.datetime | None]

    season: so.Mapped[Season] = so.relationship()
    submitter: so.Mapped[Submitter | None] = so.relationship()
    preview_study: so.Mapped[Study | None] = so.relationship()


class BoardRound(db.Model):
    """One round: its study, who was in it and why, its planned pairs and its drift check."""

    __tablename__ = "board_round"
    __table_args__ = (sa.UniqueConstraint("season_id", "number"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    season_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("board_season.id"))
    number: so.Mapped[int]
    status: so.Mapped[str] = so.mapped_column(sa.String(12), default="preparing")
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    #: System codes: all of the round, its newcomers, its anchors (fixed and carried).
    systems: so.Mapped[list[str]] = so.mapped_column(sa.JSON)
    newcomers: so.Mapped[list[str]] = so.mapped_column(sa.JSON)
    anchors: so.Mapped[list[str]] = so.mapped_column(sa.JSON)
    segments: so.Mapped[list[str]] = so.mapped_column(sa.JSON)
    #: The planned pairs (``app.leaderboard.pairing``) as [first, second, reason, gain].
    plan: so.Mapped[list[Any]] = so.mapped_column(sa.JSON)
    #: The drift check against the earlier rounds (``app.leaderboard.drift``), at publication.
    drift: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    published_at: so.Mapped[dt.datetime | None]

    season: so.Mapped[Season] = so.relationship()
    study: so.Mapped[Study] = so.relationship()
