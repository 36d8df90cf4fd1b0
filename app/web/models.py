"""The study design and its results as rows (SQLAlchemy 2 typed models).

A study owns its conditions, clips, pairs, the rendered stimuli (one video per clip and
left/right order), the balancing lists and the participants; a participant owns a schedule of
trials and at most one vote (pair designs) or one rating per condition (rating design) per
trial. Contended writes are guarded by unique constraints:
``(participant, trial)`` and the client's idempotency key on :class:`Vote`, the public token on
:class:`Participant` and the study link on :class:`Study`.
"""

from __future__ import annotations

import datetime as dt
import secrets
from typing import Any

import sqlalchemy as sa
from flask import current_app, has_app_context
from sqlalchemy import orm as so
from werkzeug.security import check_password_hash, generate_password_hash

from app.trials.rules import CHOICES
from app.web.extensions import db


def utcnow() -> dt.datetime:
    return dt.datetime.now(dt.UTC).replace(tzinfo=None)


def password_hash_method() -> str:
    """The application's ``PASSWORD_HASH_METHOD`` (werkzeug's default outside one)."""
    return str(current_app.config["PASSWORD_HASH_METHOD"]) if has_app_context() else "scrypt"


def new_token(nbytes: int = 24) -> str:
    """An unguessable URL-safe token (``nbytes`` random bytes)."""
    return secrets.token_urlsafe(nbytes)


#: Study life cycle: draft -> ready (clips rendered) -> open <-> paused -> closed.
STUDY_STATES = ("draft", "ready", "open", "paused", "closed")
JOB_STATES = ("queued", "running", "done", "failed")


class User(db.Model):
    """An experimenter; sees only the studies they own."""

    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    email: so.Mapped[str] = so.mapped_column(sa.String(200), unique=True)
    password_hash: so.Mapped[str] = so.mapped_column(sa.String(256))
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)

    def set_password(self, password: str) -> None:
        self.password_hash = generate_password_hash(password, password_hash_method())

    def check_password(self, password: str) -> bool:
        return check_password_hash(self.password_hash, password)


class Study(db.Model):
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    owner_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("user.id"), index=True)
    #: The public participant link is ``/s/<slug>``: unguessable, so drafts stay private.
    slug: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True, default=new_token)
    title: so.Mapped[str] = so.mapped_column(sa.String(200))
    instructions: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    question: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    consent: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    #: Pair design name from ``app.trials`` (e.g. all ordered pairs, against a reference).
    design: so.Mapped[str] = so.mapped_column(sa.String(40))
    reference: so.Mapped[str | None] = so.mapped_column(sa.String(80))
    allow_undecided: so.Mapped[bool] = so.mapped_column(default=True)
    undecided_label: so.Mapped[str] = so.mapped_column(
        sa.String(80), default="Undecided", info={"field": "undecided.label"}
    )
    #: Replay policy (``app.trials.rules``): "unlimited", "max_plays" or "play_to_end".
    replay: so.Mapped[str] = so.mapped_column(sa.String(20), default="unlimited")
    max_plays: so.Mapped[int | None] = so.mapped_column(info={"field": "replay.max_plays"})
    catch_trials: so.Mapped[int] = so.mapped_column(default=0, info={"field": "catch.trials"})
    #: "identical" (same condition both sides, expect undecided) or "instructed".
    catch_kind: so.Mapped[str] = so.mapped_column(sa.String(20), default="identical")
    target_participants: so.Mapped[int] = so.mapped_column(default=20)
    completion_code: so.Mapped[str] = so.mapped_column(sa.String(80), default="")
    redirect_url: so.Mapped[str] = so.mapped_column(sa.String(500), default="")
    #: Seed from which every participant's schedule seed is derived (reproducible schedules).
    seed: so.Mapped[int] = so.mapped_column(sa.BigInteger, default=0)
    status: so.Mapped[str] = so.mapped_column(sa.String(20), default="draft")
    #: The study file it was created from (TOML), kept verbatim for the record.
    source_toml: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    #: Render settings and anything else the design needs (JSON).
    settings: so.Mapped[dict[str, Any]] = so.mapped_column(sa.JSON, default=dict)
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    report_at: so.Mapped[dt.datetime | None]
    #: Secret of the pseudonymised Prolific IDs in this study's exports (``app.web.study.privacy``).
    pseudonym_key: so.Mapped[str] = so.mapped_column(sa.String(64), default=lambda: new_token(32))
    #: The pilot link is ``/experimenter/pilot/<pilot_token>``: it enrols pilot participants
    #: before recruitment opens (their votes are flagged and kept out of the analysis).
    pilot_token: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True, default=new_token)

    owner: so.Mapped[User] = so.relationship()
    conditions: so.Mapped[list[Condition]] = so.relationship(
        back_populates="study", order_by="Condition.position", cascade="all, delete-orphan"
    )
    clips: so.Mapped[list[Clip]] = so.relationship(
        back_populates="study", order_by="Clip.position", cascade="all, delete-orphan"
    )
    pairs: so.Mapped[list[Pair]] = so.relationship(
        back_populates="study", order_by="Pair.position", cascade="all, delete-orphan"
    )
    lists: so.Mapped[list[StudyList]] = so.relationship(
        back_populates="study", order_by="StudyList.index", cascade="all, delete-orphan"
    )


class LoginSession(db.Model):
    """An experimenter's login, kept on the server so it can be ended (ASVS 3.3): the signed
    cookie holds only a random key, whose SHA-256 is stored here (a database read does not
    give a usable cookie)."""

    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    user_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("user.id"), index=True)
    #: SHA-256 (hex) of the key in the session cookie.
    key_hash: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True)
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    #: The last request seen (written at most once a minute): the idle timeout counts from it.
    seen_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    #: Set by logout, "log out everywhere" or a password change; the cookie is then refused.
    ended_at: so.Mapped[dt.datetime | None] = so.mapped_column()


class RateCounter(db.Model):
    """One window of a consent limit, counted in the database where there is no Redis
    (:mod:`app.web.infra.throttle`), so every web process raises the same count."""

    #: The limit and what it counts: a study, or a study and a keyed hash of a client address
    #: (never the address itself).
    key: so.Mapped[str] = so.mapped_column(sa.String(200), primary_key=True)
    count: so.Mapped[int]
    #: The end of the window; the next count starts a new one, the next consent deletes it.
    expires_at: so.Mapped[dt.datetime] = so.mapped_column(index=True)


#: What a collaborator may do with a shared study: look (read) or everything but delete (full).
SHARE_ACCESS = ("read", "full")


class StudyShare(db.Model):
    """A study shared by its owner with another experimenter's account."""

    __table_args__ = (sa.UniqueConstraint("study_id", "user_id"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    user_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("user.id"), index=True)
    #: One of :data:`SHARE_ACCESS`.
    access: so.Mapped[str] = so.mapped_column(sa.String(10), default="read")

    user: so.Mapped[User] = so.relationship()


class Condition(db.Model):
    """One experimental condition: a model with settings, or an uploaded .fap track."""

    __table_args__ = (sa.UniqueConstraint("study_id", "name"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    name: so.Mapped[str] = so.mapped_column(sa.String(80), info={"field": "conditions.name"})
    #: Registry name in ``app.stimuli.conditions`` or "upload" for an uploaded track.
    model: so.Mapped[str] = so.mapped_column(sa.String(80), info={"field": "conditions.model"})
    params: so.Mapped[dict[str, Any]] = so.mapped_column(
        sa.JSON, default=dict, info={"field": "conditions.settings"}
    )
    #: Uploaded tracks by clip name (relative to the study's media folder).
    uploads: so.Mapped[dict[str, str]] = so.mapped_column(sa.JSON, default=dict)
    position: so.Mapped[int] = so.mapped_column(default=0)

    study: so.Mapped[Study] = so.relationship(back_populates="conditions")


class Clip(db.Model):
    """One utterance: its audio and, optionally, captured ground-truth motion."""

    __table_args__ = (sa.UniqueConstraint("study_id", "name"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    name: so.Mapped[str] = so.mapped_column(sa.String(80), info={"field": "clips.name"})
    #: Paths relative to the study's media folder.
    audio_path: so.Mapped[str] = so.mapped_column(sa.String(500))
    ground_truth_path: so.Mapped[str | None] = so.mapped_column(sa.String(500))
    position: so.Mapped[int] = so.mapped_column(default=0)

    study: so.Mapped[Study] = so.relationship(back_populates="clips")


class Track(db.Model):
    """The generated (or uploaded) motion track of one condition on one clip."""

    __table_args__ = (sa.UniqueConstraint("condition_id", "clip_id"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    condition_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("condition.id"))
    clip_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("clip.id"), index=True)
    path: so.Mapped[str] = so.mapped_column(sa.String(500))

    condition: so.Mapped[Condition] = so.relationship()
    clip: so.Mapped[Clip] = so.relationship()


class Pair(db.Model):
    """A pair of conditions to compare, in the order the design gives it."""

    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    first_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("condition.id"))
    second_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("condition.id"))
    position: so.Mapped[int] = so.mapped_column(default=0)

    study: so.Mapped[Study] = so.relationship(back_populates="pairs")
    first: so.Mapped[Condition] = so.relationship(foreign_keys=[first_id])
    second: so.Mapped[Condition] = so.relationship(foreign_keys=[second_id])

    @property
    def label(self) -> str:
        return f"{self.first.name} vs {self.second.name}"


class Stimulus(db.Model):
    """A rendered side-by-side video: one clip, one condition on each side.

    Two variants share the clip and conditions of an ordinary stimulus: an attention check
    carries an on-screen ``instruction`` drawn into the clip, and an appropriateness pair shows
    on its ``foreign_side`` the motion made for another clip (``foreign_clip``) under this
    clip's speech.
    """

    __table_args__ = (
        sa.UniqueConstraint("clip_id", "left_id", "right_id", "instruction", "foreign_side"),
    )
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    clip_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("clip.id"))
    left_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("condition.id"))
    right_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("condition.id"))
    #: Relative to the study's media folder; None until rendered.
    video_path: so.Mapped[str | None] = so.mapped_column(sa.String(500))
    #: The same clip as WebM (VP9 + Opus) for browsers without H.264, beside the MP4; None
    #: where it has none (rendered before renditions: ``facepair study renditions``).
    webm_path: so.Mapped[str | None] = so.mapped_column(sa.String(500))
    #: The side an attention check tells the participant to press ("left"/"right"), or "".
    instruction: so.Mapped[str] = so.mapped_column(sa.String(10), default="")
    #: The side showing another clip's motion in an appropriateness pair, or "".
    foreign_side: so.Mapped[str] = so.mapped_column(sa.String(10), default="")
    foreign_clip_id: so.Mapped[int | None] = so.mapped_column(sa.ForeignKey("clip.id"))

    clip: so.Mapped[Clip] = so.relationship(foreign_keys=[clip_id])
    foreign_clip: so.Mapped[Clip | None] = so.relationship(foreign_keys=[foreign_clip_id])
    left: so.Mapped[Condition] = so.relationship(foreign_keys=[left_id])
    right: so.Mapped[Condition] = so.relationship(foreign_keys=[right_id])


class StudyList(db.Model):
    """The assignment table: one row per counterbalancing list with its running count.

    A new participant takes the least-filled list and the count is raised by a conditional
    UPDATE in the same transaction that creates the participant, never by counting rows.
    """

    __table_args__ = (sa.UniqueConstraint("study_id", "index"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"))
    index: so.Mapped[int]
    #: Participants holding or having completed this list (dropped ones give it back).
    n_assigned: so.Mapped[int] = so.mapped_column(default=0)
    #: Participants ever assigned (never decreases; numbers the arrivals).
    n_arrived: so.Mapped[int] = so.mapped_column(default=0)

    study: so.Mapped[Study] = so.relationship(back_populates="lists")


class Participant(db.Model):
    #: One Prolific ID enrols once per study: a second arrival resumes the first (NULLs, i.e.
    #: arrivals without an ID, are distinct in both SQLite and PostgreSQL).
    __table_args__ = (
        sa.UniqueConstraint("study_id", "number"),
        sa.UniqueConstraint("study_id", "prolific_pid"),
        # Those taking part now, by their last request: what every consent's release of
        # idle participants reads (app.web.study.enrolment.release_dropped).
        sa.Index(
            "ix_participant_active",
            "study_id",
            "last_seen_at",
            postgresql_where=sa.text("finished_at IS NULL AND dropped_at IS NULL"),
            sqlite_where=sa.text("finished_at IS NULL AND dropped_at IS NULL"),
        ),
    )
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    #: The participant's only credential: in their URL and a cookie.
    token: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True, default=new_token)
    list_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study_list.id"))
    #: Arrival number within the study (from the assignment table, see ``app.web.study.enrolment``).
    number: so.Mapped[int]
    #: Seed of this participant's schedule (trial order, sides, catch positions).
    seed: so.Mapped[int] = so.mapped_column(sa.BigInteger)
    prolific_pid: so.Mapped[str | None] = so.mapped_column(
        sa.String(64), info={"field": "PROLIFIC_PID"}
    )
    prolific_study_id: so.Mapped[str | None] = so.mapped_column(
        sa.String(64), info={"field": "STUDY_ID"}
    )
    prolific_session_id: so.Mapped[str | None] = so.mapped_column(
        sa.String(64), info={"field": "SESSION_ID"}
    )
    user_agent: so.Mapped[str] = so.mapped_column(sa.String(300), default="")
    consented_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    started_at: so.Mapped[dt.datetime | None]
    finished_at: so.Mapped[dt.datetime | None]
    last_seen_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    #: Set when an unfinished participant timed out and gave their list slot back.
    dropped_at: so.Mapped[dt.datetime | None]
    #: Set when the attention stop rule (``attention.max_failed``) ended the session.
    screened_out_at: so.Mapped[dt.datetime | None]
    #: Screen, viewport, pixel ratio, touch, browser family and version, and the viewing
    #: check, recorded once before the first trial (``app.environment``).
    environment: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)
    #: Enrolled through the pilot link: kept out of exports and the analysis unless asked for.
    pilot: so.Mapped[bool] = so.mapped_column(default=False, server_default=sa.false())
    #: Excluded by the experimenter (with ``exclusion_reason``); their list slot went back.
    excluded_at: so.Mapped[dt.datetime | None]
    exclusion_reason: so.Mapped[str] = so.mapped_column(
        sa.String(300), default="", server_default=""
    )
    #: How the participant was taken out: "excluded" or "returned" (their Prolific
    #: submission); "" while they are not (``app.web.study.participants.REMOVALS``).
    exclusion_kind: so.Mapped[str] = so.mapped_column(sa.String(10), default="", server_default="")
    #: Questionnaire answers by page and question name (``app.web.study.questionnaires``); a page
    #: answered is a key, so an empty page of optional questions still counts as done.
    answers: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON, default=dict)
    #: The audio check before the first trial (``app.web.study.audiocheck``): the answers of
    #: each attempt, the score of each, and ``passed`` once decided; None without a check.
    audio_check: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)

    study: so.Mapped[Study] = so.relationship()
    study_list: so.Mapped[StudyList] = so.relationship()
    trials: so.Mapped[list[Trial]] = so.relationship(
        back_populates="participant", order_by="Trial.position", cascade="all, delete-orphan"
    )


class Trial(db.Model):
    """One row of a participant's schedule: which video, in which position."""

    __table_args__ = (sa.UniqueConstraint("participant_id", "position"),)
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    participant_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("participant.id"))
    position: so.Mapped[int]
    #: The design pair shown (either side order); None for an "identical" catch trial.
    pair_id: so.Mapped[int | None] = so.mapped_column(sa.ForeignKey("pair.id"))
    stimulus_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("stimulus.id"))
    #: "trial" or "catch" (``app.trials.trial.TRIAL_KINDS``).
    kind: so.Mapped[str] = so.mapped_column(sa.String(10), default="trial")
    #: For a catch trial, the answer an attentive participant gives.
    expected: so.Mapped[str | None] = so.mapped_column(sa.String(10))
    #: Plays the server granted (one request per play), so a reload gives none back.
    plays: so.Mapped[int] = so.mapped_column(default=0)

    participant: so.Mapped[Participant] = so.relationship(back_populates="trials")
    pair: so.Mapped[Pair | None] = so.relationship()
    stimulus: so.Mapped[Stimulus] = so.relationship()
    vote: so.Mapped[Vote | None] = so.relationship(back_populates="trial", uselist=False)


class MediaSummary:
    """The media log's summary (``app.web.study.medialog``) of an answer, exported as columns,
    with the rest of the log as JSON: the same on a :class:`Vote` and a :class:`Rating`."""

    watched_ms: so.Mapped[int | None]
    played_to_end: so.Mapped[bool | None]
    stalls: so.Mapped[int | None]
    stall_ms: so.Mapped[int | None]
    focus_lost: so.Mapped[int | None]
    #: The rest of the media log: pauses, seeks, displayed video size, stall durations.
    media: so.Mapped[dict[str, Any] | None] = so.mapped_column(sa.JSON)


class Vote(MediaSummary, db.Model):
    """A participant's answer to one trial: stored exactly once."""

    __table_args__ = (
        sa.UniqueConstraint("participant_id", "trial_id"),
        sa.CheckConstraint(sa.column("choice").in_(CHOICES), name="choice"),
    )
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    #: No index of its own: the unique (participant_id, trial_id) index leads with it.
    participant_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("participant.id"))
    trial_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("trial.id"), index=True)
    #: Chosen by the browser per trial; a retried request carries the same key.
    idempotency_key: so.Mapped[str] = so.mapped_column(sa.String(64), unique=True)
    #: One of ``app.trials.rules.CHOICES`` (a CHECK constraint holds the database to it).
    choice: so.Mapped[str] = so.mapped_column(sa.String(10))
    #: Milliseconds from the start of the first playback to the vote.
    response_ms: so.Mapped[int | None]
    plays: so.Mapped[int] = so.mapped_column(default=0)
    #: Browser clock (ISO 8601) when the clip was shown; the server clock when stored.
    presented_at: so.Mapped[dt.datetime | None]
    voted_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    #: On the 5-level scale, 2 = clearly, 1 = slightly, 0 = cannot decide; None on 3 levels.
    strength: so.Mapped[int | None]
    #: Reason tags ticked after the choice (the study file's ``reasons``).
    reasons: so.Mapped[list[str] | None] = so.mapped_column(sa.JSON)

    trial: so.Mapped[Trial] = so.relationship(back_populates="vote")
    participant: so.Mapped[Participant] = so.relationship()


class Rating(MediaSummary, db.Model):
    """A participant's score of one condition in one trial of a rating design: stored exactly
    once, like a :class:`Vote` (one row per rated condition: the trial's one condition in the
    ``rating`` design, every version of the clip in ``parallel``, all with the request's
    idempotency key)."""

    __table_args__ = (
        # Leads with the participant: a participant's progress counts their ratings by it.
        sa.UniqueConstraint("participant_id", "trial_id", "condition_id"),
        sa.UniqueConstraint("idempotency_key", "condition_id"),
        sa.CheckConstraint(sa.column("score").between(0, 100), name="score"),
    )
    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    participant_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("participant.id"))
    trial_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("trial.id"), index=True)
    condition_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("condition.id"))
    #: Chosen by the browser per trial; a retried request carries the same key.
    idempotency_key: so.Mapped[str] = so.mapped_column(sa.String(64))
    #: ACR 1 (Bad) to 5 (Excellent), or 0-100 on the slider (``app.trials.rating``).
    score: so.Mapped[int]
    #: Milliseconds from the start of the first playback to the rating.
    response_ms: so.Mapped[int | None]
    plays: so.Mapped[int] = so.mapped_column(default=0)
    #: Browser clock (ISO 8601) when the clip was shown; the server clock when stored.
    presented_at: so.Mapped[dt.datetime | None]
    rated_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)

    trial: so.Mapped[Trial] = so.relationship()
    condition: so.Mapped[Condition] = so.relationship()


class Job(db.Model):
    """A background job (generate tracks, render clips, report) and its visible progress."""

    id: so.Mapped[int] = so.mapped_column(primary_key=True)
    study_id: so.Mapped[int] = so.mapped_column(sa.ForeignKey("study.id"), index=True)
    kind: so.Mapped[str] = so.mapped_column(sa.String(20))
    status: so.Mapped[str] = so.mapped_column(sa.String(20), default="queued")
    done: so.Mapped[int] = so.mapped_column(default=0)
    total: so.Mapped[int] = so.mapped_column(default=0)
    message: so.Mapped[str] = so.mapped_column(sa.Text, default="")
    created_at: so.Mapped[dt.datetime] = so.mapped_column(default=utcnow)
    finished_at: so.Mapped[dt.datetime | None]
    #: Last sign of life from the process running it (start and every progress report); a
    #: running job silent for longer than JOB_STALE_AFTER_SECONDS is swept as failed.
    heartbeat_at: so.Mapped[dt.datetime | None]

    study: so.Mapped[Study] = so.relationship()

    def as_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": self.kind,
            "status": self.status,
            "done": self.done,
            "total": self.total,
            "message": self.message,
            "fraction": (self.done / self.total) if self.total else 0.0,
        }
