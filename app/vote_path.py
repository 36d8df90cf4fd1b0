"""The vote's usual case in one or two SQL statements: a participant's vote on a trial of their own.

:func:`app.voting.record_vote` goes through the ORM: a statement for the participant, one for
the trial, one to mark the participant seen, the INSERT and the progress counts, each with the
ORM's Python work around it, which the load benchmark's profile showed to be most of a vote's
cost. :func:`cast` checks the vote with the same functions (:func:`app.voting.check_open`,
:func:`app.voting.vote_fields`) and stores it through SQLAlchemy Core on the session's
connection, in the request's one transaction:

1. one row: the participant, their study, the trial (only if it is theirs) and its vote if
   any, the participant's row locked (``FOR UPDATE``), so one participant's votes are stored
   one after the other and the counts below see every earlier one;
2. the vote inserted ``ON CONFLICT DO NOTHING`` (the unique idempotency key and
   ``(participant, trial)`` settle races), the participant marked as seen, the progress
   counted, and the next pair read as the trial page shows it
   (:func:`app.enrolment.upcoming`), which the answer carries so that the browser goes on to
   it without loading a trial page (``static/participant.js``): one statement on PostgreSQL
   (data-modifying CTEs), four in process on SQLite.

On PostgreSQL the two statements go straight to the driver (:func:`_cast_on_driver`,
:mod:`app.driver`), in a transaction of their own, without the ORM session. The vote that
finishes the schedule stays there too: under a ``catch_failed`` rule it asks whether the
report leaves the participant out (:func:`app.participants.failed_catch`), then marks them
finished, giving their list slot back if so, in one more statement each. What that path does
not settle before its commit (a missed attention check under a stop rule, a key the insert
met elsewhere) is rolled back and taken by the session's path below, which returns None where
the ORM's path must decide; an unknown token or a participant screened out or dropped goes to
the ORM's path at once, as the session's path would read the same row and send it there.

Once an application has stored a vote there, it knows its study's rules (:class:`StudyRules`),
and the next vote is first checked against them and tried in one statement in autocommit
(:func:`_cast_at_once`, :func:`_at_once`): both statements' work, in one round trip where the
transaction takes four (BEGIN, two statements, COMMIT), which in a bare psycopg loop cut a
vote's PostgreSQL CPU by a quarter and the driver's by half. That statement stores the vote
only where the facts it reads are those the checks were given (the study's rules, the
participant still taking part, the trial theirs, the page's play count the server's, not the
last vote, no vote of theirs committed while it waited for their row); otherwise it stores
nothing (but, where it was accepted and met a key of another trial, the sign of life) and the
transaction decides, with the study's own facts. A server running one study at a time thus
takes the transaction for the first vote of each process, the last vote of each participant,
a vote whose play count the page and the server disagree on, votes racing on one
participant's row, and every vote of a study with a stop rule for attention checks (a missed
one may end the session). Its processes keep one study's rules each: a server running studies
with other rules at once pays a round trip more whenever the study changes.

On the session's path (SQLite's), the vote that completes the schedule marks the participant
finished (one more UPDATE), in the same transaction; where the report leaves them out for a
failed check, their list slot goes back the ORM's way
(:func:`app.participants.release_if_left_out`), as a missed attention check under a stop rule
ends the session (:func:`app.voting.screen_out`): they are rare. Whatever else is not the
usual case returns None, before anything is committed, and the caller takes
:func:`app.voting.record_vote` (the reference for every rule): an unknown token, a participant
screened out or released as dropped, a key or trial whose vote the first statement did not
see (a race, or a key reused on another trial).
"""

from __future__ import annotations

from functools import cache
from typing import Any, Literal, NamedTuple

import sqlalchemy as sa
from flask import current_app
from sqlalchemy.dialects import postgresql, sqlite

from app import driver
from app.enrolment import progress_counts, upcoming
from app.extensions import db
from app.limits import fits
from app.models import Participant, Study, StudyList, Trial, Vote, utcnow
from app.participants import failed_catch, left_out, may_be_left_out, release_if_left_out
from app.studies import participation
from app.voting import VoteRejected, check_open, screen_out, trial_id_of, vote_fields

P, S, T, V, L = (
    m.__table__  # type: ignore[attr-defined]
    for m in (Participant, Study, Trial, Vote, StudyList)
)
#: The vote's columns written from the request (every one but the id).
VOTE_COLUMNS = tuple(c.name for c in V.columns if c.name != "id")


class StoredVote(NamedTuple):
    """What the acknowledgement repeats of a stored vote."""

    trial_id: int
    choice: str
    plays: int
    response_ms: int | None
    strength: int | None


class CastVote(NamedTuple):
    vote: StoredVote
    #: True when this request stored it; False when it was already stored (a retry).
    created: bool
    answered: int
    total: int
    #: The next pair as the trial page would show it (:func:`app.enrolment.upcoming`'s row),
    #: read in the vote's transaction; None when there is none or it was not read (the
    #: schedule is done, or the participant's session ended): the browser then loads the
    #: trial page, which decides.
    upcoming: Any = None


class _TrialFacts(NamedTuple):
    participant_id: int
    kind: str
    plays: int


@cache
def _facts() -> sa.Select[Any]:
    """Statement 1, built once: the participant, study, trial and stored vote, locked."""
    trial = sa.and_(T.c.id == sa.bindparam("trial_id"), T.c.participant_id == P.c.id)
    return (
        sa.select(
            P.c.id,
            P.c.pilot,
            P.c.screened_out_at,
            P.c.dropped_at,
            P.c.finished_at,
            S.c.status,
            S.c.allow_undecided,
            S.c.replay,
            S.c.max_plays,
            S.c.settings,
            # As stored: what a vote in one statement compares (_at_once).
            sa.cast(S.c.settings, sa.Text).label("settings_text"),
            T.c.id.label("trial_id"),
            T.c.kind,
            T.c.expected,
            T.c.plays,
            V.c.id.label("vote_id"),
            V.c.choice.label("vote_choice"),
            V.c.plays.label("vote_plays"),
            V.c.response_ms.label("vote_response_ms"),
            V.c.strength.label("vote_strength"),
        )
        .select_from(
            P.join(S, S.c.id == P.c.study_id)
            .outerjoin(T, trial)
            .outerjoin(V, V.c.trial_id == T.c.id)
        )
        .where(P.c.token == sa.bindparam("token"))
        .with_for_update(of=P)
    )


def _vote_values() -> dict[str, Any]:
    return {name: sa.bindparam(name, type_=V.c[name].type) for name in VOTE_COLUMNS}


def _counts(inserted: Any = None) -> tuple[Any, Any]:
    """(answered, total) over the participant's trials; ``inserted`` adds a CTE's rows (its
    statement's snapshot does not hold them)."""
    answered: Any
    answered, total = progress_counts()
    if inserted is not None:
        answered = answered + sa.select(sa.func.count()).select_from(inserted).scalar_subquery()
    return answered.label("answered"), total.label("total")


@cache
def _store_postgresql() -> sa.Select[Any]:
    """Statement 2 on PostgreSQL: insert, mark seen, count and read the next pair in one
    round trip."""
    seen = (
        sa.update(P)
        .where(P.c.id == sa.bindparam("participant_id"))
        .values(last_seen_at=sa.bindparam("now"))
        .returning(P.c.id)
        .cte("seen")
    )
    inserted = (
        postgresql.insert(V)
        .values(_vote_values())
        .on_conflict_do_nothing()
        .returning(V.c.id)
        .cte("inserted")
    )
    # The next pair besides the trial voted on (this statement's snapshot lacks its vote), on
    # the one row whether there is one or not.
    following = upcoming(besides=True).subquery("following")
    return sa.select(
        sa.select(inserted.c.id).scalar_subquery().label("vote_id"),
        sa.select(sa.func.count()).select_from(seen).scalar_subquery().label("seen"),
        *_counts(inserted),
        *(c.label(f"next_{c.name}") for c in following.c),
    ).select_from(sa.select(sa.literal(1)).subquery("one").outerjoin(following, sa.true()))


class Upcoming(NamedTuple):
    """:func:`app.enrolment.upcoming`'s row, from statement 2's ``next_`` columns."""

    trial_id: int
    plays: int
    kind: str
    expected: str | None
    instruction: str
    following: int | None


def _upcoming_of(stored: Any) -> Upcoming | None:
    if stored.next_trial_id is None:
        return None
    return Upcoming(*(getattr(stored, f"next_{name}") for name in Upcoming._fields))


@cache
def _store_sqlite() -> tuple[Any, Any, Any]:
    """Statement 2 on SQLite (no data-modifying CTEs): three statements, all in process."""
    seen = (
        sa.update(P)
        .where(P.c.id == sa.bindparam("participant_id"))
        .values(last_seen_at=sa.bindparam("now"))
    )
    inserted = sqlite.insert(V).values(_vote_values()).on_conflict_do_nothing().returning(V.c.id)
    return seen, inserted, sa.select(*_counts())


def _store(conn: sa.Connection, values: dict[str, Any]) -> tuple[int | None, int, int, Any]:
    """Insert the vote unless its key or trial has one; (new vote id or None, answered,
    total, the next pair or None)."""
    if conn.dialect.name == "postgresql":
        row = conn.execute(_store_postgresql(), values).one()
        return row.vote_id, int(row.answered), int(row.total), _upcoming_of(row)
    seen, inserted, counts = _store_sqlite()
    conn.execute(seen, values)
    vote_id = conn.execute(inserted, values).scalar()
    row = conn.execute(counts, values).one()
    following = conn.execute(upcoming(), values).one_or_none()
    return vote_id, int(row.answered), int(row.total), following


def _checked(
    facts: Any, trial_id: int, payload: dict[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The vote's fields checked against statement 1's row (raises
    :class:`~app.voting.VoteRejected` as the ORM path does), and statement 2's values."""
    check_open(facts, pilot=facts.pilot)
    trial = None
    if facts.trial_id is not None:
        trial = _TrialFacts(facts.id, facts.kind, facts.plays)
    fields = vote_fields(facts, trial, facts.id, payload)
    now = utcnow()
    values = dict.fromkeys(VOTE_COLUMNS)
    values.update(fields, participant_id=facts.id, trial_id=trial_id, voted_at=now, now=now)
    return fields, values


def _acknowledged(
    facts: Any, trial_id: int, fields: dict[str, Any], *, inserted: bool
) -> StoredVote | None:
    """What the answer repeats: the vote just inserted, else the trial's stored vote (a
    resent or double-clicked one); None when neither (the key is another trial's, or a
    concurrent request stored it first)."""
    if inserted:
        return StoredVote(
            trial_id, fields["choice"], fields["plays"], fields["response_ms"], fields["strength"]
        )
    if facts.vote_id is not None:
        return StoredVote(
            trial_id,
            facts.vote_choice,
            facts.vote_plays,
            facts.vote_response_ms,
            facts.vote_strength,
        )
    return None


def cast(payload: dict[str, Any]) -> CastVote | None:
    """Store the vote in ``payload`` (a JSON object) if it is the usual case; None otherwise,
    with nothing written (the caller rolls back and takes :func:`app.voting.record_vote`).

    Raises :class:`app.voting.VoteRejected` for a request that is not a valid vote of this
    participant, as :func:`~app.voting.record_vote` does; the caller commits.
    """
    token = payload.get("token")
    if not isinstance(token, str) or not fits(Participant.token, token):
        return None
    try:
        trial_id = trial_id_of(payload)
    except VoteRejected:
        return None  # refused by the ORM path, after the checks that come first there
    if driver.available():
        done = _cast_on_driver(token, trial_id, payload)
        if isinstance(done, CastVote):
            return done
        if done == "orm":
            return None  # the session's path would read the same row and say the same
    conn = db.session.connection()
    facts = conn.execute(_facts(), {"token": token, "trial_id": trial_id}).one_or_none()
    if facts is None or facts.screened_out_at is not None or facts.dropped_at is not None:
        return None  # unknown (403), screened out, or dropped (it may rejoin): the ORM path
    fields, values = _checked(facts, trial_id, payload)
    now = values["now"]
    vote_id, answered, total, following = _store(conn, values)
    vote = _acknowledged(facts, trial_id, fields, inserted=vote_id is not None)
    if vote is None:
        return None  # the key is another trial's, or a concurrent request stored it first
    participant = None
    screened = False
    missed = vote_id is not None and facts.kind == "catch" and fields["choice"] != facts.expected
    if missed and participation(facts).max_failed:
        # A missed attention check under a stop rule may end the session (the ORM's way).
        participant = db.session.get(Participant, facts.id)
        screened = screen_out(participant)  # type: ignore[arg-type]
    if answered >= total and facts.finished_at is None and not screened:
        if left_out(facts, facts.id, pilot=facts.pilot):
            # Finished, but left out of the report: the list slot goes back (the ORM's way).
            participant = participant or db.session.get(Participant, facts.id)
            assert participant is not None  # locked by statement 1
            participant.finished_at = now
            release_if_left_out(participant)
        else:
            conn.execute(_finished(), {"participant_id": facts.id, "now": now})
    if answered >= total or screened:
        following = None  # the trial page decides what comes next
    return CastVote(vote, vote_id is not None, answered, total, following)


@cache
def _finished() -> sa.Update:
    return (
        sa.update(P)
        .where(P.c.id == sa.bindparam("participant_id"))
        .values(finished_at=sa.bindparam("now"))
    )


@cache
def _finished_left_out() -> sa.Update:
    """Finished, and left out of the report for a failed check: the participant gives the list
    slot back, once (:func:`app.participants.release_if_left_out`, in one statement)."""
    released = (
        sa.update(P)
        .where(P.c.id == sa.bindparam("participant_id"), P.c.dropped_at.is_(None))
        .values(finished_at=sa.bindparam("now"), dropped_at=sa.bindparam("now"))
        .returning(P.c.list_id)
        .cte("released")
    )
    return (
        sa.update(L)
        .where(L.c.id.in_(sa.select(released.c.list_id)))
        .values(n_assigned=L.c.n_assigned - 1)
    )


def _cast_on_driver(
    token: str, trial_id: int, payload: dict[str, Any]
) -> CastVote | Literal["session", "orm"]:
    """The usual vote on PostgreSQL, on a pooled driver connection (:mod:`app.driver`): in one
    statement in autocommit where the rules of this application's last such vote give the
    vote (:func:`_cast_at_once`), else in a transaction of its own, committed and returned,
    or rolled back and the path that decides instead: "orm" for an unknown token or a
    participant screened out or dropped, "session" for the rest (:func:`cast` below the
    driver's call)."""
    done = _cast_at_once(token, trial_id, payload)
    if done is not None:
        return done
    with driver.transaction() as tx:
        facts = tx.run(_facts(), {"token": token, "trial_id": trial_id})
        if facts is None or facts.screened_out_at is not None or facts.dropped_at is not None:
            return "orm"
        fields, values = _checked(facts, trial_id, payload)
        missed = facts.kind == "catch" and fields["choice"] != facts.expected
        if missed and facts.vote_id is None and participation(facts).max_failed:
            return "session"  # it may end the session: screened out there
        stored = tx.run(_store_postgresql(), values)
        answered, total = int(stored.answered), int(stored.total)
        vote = _acknowledged(facts, trial_id, fields, inserted=stored.vote_id is not None)
        if vote is None:
            return "session"  # the key is another trial's, or a concurrent request stored it
        if answered >= total and facts.finished_at is None:
            finished = {"participant_id": facts.id, "now": values["now"]}
            if may_be_left_out(facts, pilot=facts.pilot) and tx.run(
                failed_catch(), {"participant_id": facts.id}
            ):
                tx.run(_finished_left_out(), finished)  # the list slot goes back
            else:
                tx.run(_finished(), finished)
        tx.commit()
        _remember_rules(facts)
        following = _upcoming_of(stored) if answered < total else None
        return CastVote(vote, stored.vote_id is not None, answered, total, following)


class StudyRules(NamedTuple):
    """What :func:`app.voting.check_open` and :func:`app.voting.vote_fields` read of a study:
    the whole study as a vote in one statement sees it before the statement (a column they
    came to read besides these would fail there, not be guessed), and compares with the
    study's row in it."""

    status: str
    allow_undecided: bool
    replay: str
    max_plays: int | None
    settings: Any
    #: ``settings`` as stored, the text the statement compares.
    settings_text: str


#: Where an application keeps the rules of the study of its last vote on the driver.
_LAST_RULES = "facepair.vote_rules"
#: The trial a vote in one statement is checked against before the statement: the
#: participant's (0 stands for their id), not the practice, with no play counted, so the
#: page's count is taken (the statement checks that the server's count is none or the same).
_ANY_TRIAL = _TrialFacts(0, "trial", 0)


#: The study's columns a vote in one statement compares with its rules (:class:`StudyRules`;
#: ``settings`` as its text).
_COMPARED = ("status", "allow_undecided", "replay", "max_plays", "settings_text")


def _remember_rules(facts: Any) -> None:
    """Keep the rules of ``facts``'s study for the next vote, unless they hold a stop rule for
    attention checks (a missed one may end the session, which the transaction decides)."""
    if participation(facts).max_failed:
        current_app.extensions.pop(_LAST_RULES, None)
    else:
        current_app.extensions[_LAST_RULES] = StudyRules(
            *(getattr(facts, f) for f in StudyRules._fields)
        )


def _cast_at_once(
    token: str, trial_id: int, payload: dict[str, Any]
) -> CastVote | Literal["orm"] | None:
    """The usual vote in one statement, in autocommit (:func:`_at_once`), where the rules of
    the study of this application's last vote on the driver (a server usually runs one study
    at a time) accept it: its fields come from the same functions as on the other paths
    (:func:`app.voting.check_open`, :func:`app.voting.vote_fields`) on those rules, and the
    statement stores it only where the facts it reads are the facts those functions were given
    (:func:`_at_once` lists them), which makes the stored vote the one the other paths would
    store. None where there are no such rules (none are kept for a study with a stop rule for
    attention checks: :func:`_remember_rules`), they refuse the vote, or the statement stored
    nothing for a reason the transaction's path settles; "orm" for an unknown token or a
    participant screened out or dropped."""
    rules = current_app.extensions.get(_LAST_RULES)
    if rules is None:
        return None
    try:
        check_open(rules, pilot=False)
        guessed = vote_fields(rules, _ANY_TRIAL, 0, payload)
    except VoteRejected:
        return None  # the study's own rules decide, in the transaction's path
    now = utcnow()
    values = dict.fromkeys(VOTE_COLUMNS)
    values.update(guessed, token=token, trial_id=trial_id, voted_at=now, now=now)
    values.update({f"rule_{name}": getattr(rules, name) for name in _COMPARED})
    facts = driver.autocommitted(_at_once(), values)
    if facts is None or facts.screened_out_at is not None or facts.dropped_at is not None:
        return "orm"
    if not facts.accepted:
        return None
    vote = _acknowledged(facts, trial_id, guessed, inserted=facts.inserted_id is not None)
    if vote is None:
        return None  # the key is another trial's, or a concurrent request stored the vote
    answered, total = int(facts.answered), int(facts.total)
    return CastVote(vote, facts.inserted_id is not None, answered, total, _upcoming_of(facts))


@cache
def _at_once() -> sa.Select[Any]:
    """The usual vote's one statement on PostgreSQL: statement 1's row (the participant
    locked), and, only where the vote is accepted (``accepted``), the vote inserted with the
    bound fields (``inserted_id``; none where the trial has a vote or the key is taken), the
    participant marked seen, the progress counted and the next pair read, as statement 2 does.

    Accepted where the facts are those the fields were checked against before the statement
    (:func:`_cast_at_once`):

    - the study's status and rules are the bound ``rule_`` values (:data:`_COMPARED`);
    - the participant is neither screened out, dropped nor finished, and the trial is theirs
      and not the practice;
    - the trial's play count is none or the page's (``plays``), so the vote's is the page's,
      as :func:`app.voting.vote_fields` counts it;
    - the vote is not the participant's last (finishing them is the transaction's path);
    - no vote of the participant's committed while the statement waited for their row: the
      row as locked is the row in the statement's snapshot (``xmin``). Every transaction that
      stores a vote of a participant not dropped marks them seen, so changes that row (the
      transaction's path, this statement, :func:`app.enrolment.touch` on the ORM's path);
      only one of a dropped participant may not, and a dropped participant is not accepted
      here. Otherwise the counts and the next pair, read in that snapshot, would miss it.
    """
    # In the snapshot, without this vote; on the participant alone (the trial is in the row).
    before, total = (count.correlate(P) for count in progress_counts(P.c.id))
    facts = (
        _facts()
        .add_columns(
            sa.literal_column("participant.xmin::text").label("locked"),
            before.label("answered_before"),
            total.label("total"),
        )
        .cte("facts")
    )
    snap = P.alias("snap")
    snapshot = (
        sa.select(sa.literal_column("snap.xmin::text"))
        .where(snap.c.id == facts.c.id)
        .scalar_subquery()
    )
    plays = sa.bindparam("plays", type_=V.c.plays.type)
    rules = [
        getattr(facts.c, name).is_not_distinct_from(
            sa.bindparam(f"rule_{name}", type_=getattr(facts.c, name).type)
        )
        for name in _COMPARED
    ]
    accepted = (
        sa.select(facts.c.id, facts.c.trial_id)
        .where(
            *rules,
            facts.c.screened_out_at.is_(None),
            facts.c.dropped_at.is_(None),
            facts.c.finished_at.is_(None),
            facts.c.trial_id.is_not(None),
            facts.c.kind != "practice",
            sa.func.coalesce(sa.func.nullif(facts.c.plays, 0), plays) == plays,
            facts.c.answered_before + 1 < facts.c.total,
            facts.c.locked == snapshot,
        )
        .cte("accepted")
    )
    row = {**_vote_values(), "participant_id": accepted.c.id, "trial_id": accepted.c.trial_id}
    inserted = (
        postgresql.insert(V)
        .from_select(list(VOTE_COLUMNS), sa.select(*(row[name] for name in VOTE_COLUMNS)))
        .on_conflict_do_nothing()
        .returning(V.c.id)
        .cte("inserted")
    )
    who = sa.select(accepted.c.id).scalar_subquery()
    seen = (
        sa.update(P)
        .where(P.c.id == who)
        .values(last_seen_at=sa.bindparam("now"))
        .returning(P.c.id)
        .cte("seen")
    )
    following = upcoming(besides=True, participant=who).subquery("following")
    added = sa.select(sa.func.count()).select_from(inserted).scalar_subquery()
    return sa.select(
        *facts.c,
        sa.exists(sa.select(accepted.c.id)).label("accepted"),
        sa.select(inserted.c.id).scalar_subquery().label("inserted_id"),
        sa.select(sa.func.count()).select_from(seen).scalar_subquery().label("seen"),
        (facts.c.answered_before + added).label("answered"),
        *(c.label(f"next_{c.name}") for c in following.c),
    ).select_from(facts.outerjoin(following, sa.true()))
