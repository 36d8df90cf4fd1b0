"""``facepair study create/list/open/pause/close/reopen/export/renditions``: a study's life
cycle from the shell, with the same rules as the experimenter's pages
(:mod:`app.web.study.studies`)."""

from __future__ import annotations

from pathlib import Path

import click

from app.commands.db import migrated
from app.commands.studysetup import create_from_file, run_jobs_here
from app.commands.webapp import app_context, offline_app
from app.errors import InputError


def _study(study_id: int):  # type: ignore[no-untyped-def]
    from app.web.extensions import db
    from app.web.models import Study

    found = db.session.get(Study, study_id)
    if found is None:
        raise InputError(f"no study {study_id} (see 'facepair study list')", field="STUDY_ID")
    return found


@click.group()
def study() -> None:
    """Create, list, open, close and export studies."""


@study.command("create")
@click.argument("study_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--owner", required=True, help="E-mail of the owning experimenter.")
@click.option("--render", is_flag=True, help="Generate the tracks and render the clips now.")
@click.option("--open", "open_", is_flag=True, help="Open recruitment (implies --render).")
def create(study_file: Path, owner: str, render: bool, open_: bool) -> None:
    """Create a study from STUDY_FILE (TOML) for an experimenter."""
    from flask import url_for

    from app.web.extensions import db
    from app.web.models import Study

    app = offline_app()
    with app_context(app):
        migrated()
        study_id = create_from_file(study_file, owner)
        if render or open_:
            run_jobs_here(study_id, ("generate", "render"))
        if open_:
            db.session.get(Study, study_id).status = "open"  # type: ignore[union-attr]
            db.session.commit()
        slug = db.session.get(Study, study_id).slug  # type: ignore[union-attr]
        with app.test_request_context():
            link = url_for("participant.start", slug=slug)
    click.echo(f"study {study_id} created; participant link: {link}")


@study.command("list")
@click.option("--owner", default=None, help="Only the studies of this experimenter (e-mail).")
def list_studies(owner: str | None) -> None:
    """One line per study: id, status, participants (finished), votes, slug and title."""
    import sqlalchemy as sa

    from app.web.extensions import db
    from app.web.models import Participant, Study, User, Vote

    with app_context(offline_app()):
        migrated()
        people = (
            sa.select(
                Participant.study_id,
                sa.func.count(Participant.id).label("joined"),
                sa.func.count(Participant.finished_at).label("finished"),
            )
            .group_by(Participant.study_id)
            .subquery()
        )
        votes = (
            sa.select(Participant.study_id, sa.func.count(Vote.id).label("votes"))
            .join(Vote, Vote.participant_id == Participant.id)
            .group_by(Participant.study_id)
            .subquery()
        )
        query = (
            sa.select(Study, people.c.joined, people.c.finished, votes.c.votes)
            .outerjoin(people, people.c.study_id == Study.id)
            .outerjoin(votes, votes.c.study_id == Study.id)
            .order_by(Study.id)
        )
        if owner:
            query = query.join(User, User.id == Study.owner_id).where(User.email == owner.lower())
        rows = db.session.execute(query).all()
        if not rows:
            click.echo("no studies")
        for found, joined, finished, count in rows:
            click.echo(
                f"{found.id:>4}  {found.status:<7} {joined or 0:>5} joined "
                f"({finished or 0} finished) {count or 0:>6} votes  {found.slug}  {found.title}"
            )


def _transition(action: str):  # type: ignore[no-untyped-def]
    @click.argument("study_id", type=int)
    def command(study_id: int) -> None:
        from app.web.extensions import db
        from app.web.study.studies import change_status

        with app_context(offline_app()):
            migrated()
            found = _study(study_id)
            try:
                state = change_status(found, action)
            except ValueError as exc:
                raise InputError(str(exc), field="STUDY_ID") from None
            db.session.commit()
        click.echo(f"study {study_id} is {state}")

    command.__doc__ = f"{action.capitalize()} recruitment of study STUDY_ID (as its page does)."
    return study.command(action)(command)


for _action in ("open", "pause", "close", "reopen"):
    _transition(_action)


@study.command("export")
@click.argument("study_id", type=int)
@click.option(
    "--out",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder for votes.csv (ratings.csv for a rating study), participants.csv and "
    "answers.csv, or the package.",
)
@click.option(
    "--pilots",
    is_flag=True,
    help="Also the pilots' votes (marked in votes.csv) and answers (answers-pilot.csv).",
)
@click.option(
    "--package",
    is_flag=True,
    help="Write the study package instead: one zip with the study file, the data, the report "
    "(written first if there is none) and a manifest of SHA-256 sums, seeds and versions.",
)
def export(study_id: int, out: Path, pilots: bool, package: bool) -> None:
    """Write the study's votes, participants (Prolific IDs pseudonymised) and questionnaire
    answers as the experimenter's downloads are, or its package (--package)."""
    from app.trials.design import RATING_DESIGNS
    from app.web.study.exports import ratings_csv, votes_csv
    from app.web.study.privacy import participants_csv
    from app.web.study.questionnaires import answers_csv

    if package and pilots:
        raise InputError("a package holds what the report analysed: no pilots", field="pilots")
    with app_context(offline_app()):
        migrated()
        found = _study(study_id)
        files: dict[str, str | bytes]
        if package:
            name, data = _package(found)
            files = {name: data}
        else:
            pilot = "with" if pilots else "without"
            rated = found.design in RATING_DESIGNS
            files = {
                "ratings.csv" if rated else "votes.csv": (ratings_csv if rated else votes_csv)(
                    found, pilot=pilot
                ),
                "participants.csv": participants_csv(found),
                "answers.csv": answers_csv(found),
            }
            if pilots:
                files["answers-pilot.csv"] = answers_csv(found, pilot=True)
    out.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        if isinstance(content, bytes):
            (out / name).write_bytes(content)
        else:
            (out / name).write_text(content, encoding="utf-8")
    click.echo(f"study {study_id}: {', '.join(files)} written to {out}")


@study.command("renditions")
@click.argument("study_id", type=int)
def renditions(study_id: int) -> None:
    """Make the WebM rendition (VP9 + Opus, for browsers without H.264) of every rendered clip
    of STUDY_ID that has none: clips rendered before renditions existed. Any state of the
    study, open ones included: the WebM shows what the MP4 shows, and the MP4 stays as it is."""
    from tqdm import tqdm

    from app.web.jobs.renditions import add_missing_webm

    with app_context(offline_app()):
        migrated()
        found = _study(study_id)
        with tqdm(desc="WebM renditions", unit="clip", leave=True) as bar:

            def echo(done: int, total: int) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            made = add_missing_webm(found, echo)
    click.echo(f"study {study_id}: {made} WebM rendition{'' if made == 1 else 's'} made")


def _package(found) -> tuple[str, bytes]:  # type: ignore[no-untyped-def]
    """The study's package (name, zip bytes), writing its report first when it has none."""
    from app.web.study.package import build_package, package_name

    try:
        return package_name(found), build_package(found)
    except InputError:
        run_jobs_here(found.id, ("report",))
        return package_name(found), build_package(found)


def register(main: click.Group) -> None:
    from app.commands.db import db

    for command in (db, study):
        main.add_command(command)
