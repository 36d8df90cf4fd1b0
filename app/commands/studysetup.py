"""A study set up from the shell, as ``facepair study create`` and ``facepair demo`` both do:
made from its file for an experimenter (:func:`create_from_file`), its jobs run in this process
with a progress bar each (:func:`run_jobs_here`). Both run inside the command's application
context (:func:`app.commands.webapp.app_context`).
"""

from __future__ import annotations

from pathlib import Path

import click

from app.errors import InputError


def run_jobs_here(study_id: int, kinds: tuple[str, ...]) -> None:
    """Run jobs in this process with a progress bar each (on stderr); a failed job is an
    error."""
    from tqdm import tqdm

    from app.web.extensions import db, transaction
    from app.web.jobs.bodies import run_job
    from app.web.models import Job

    for kind in kinds:
        with transaction() as session:
            job = Job(study_id=study_id, kind=kind)
            session.add(job)
        with tqdm(desc=kind, unit="step", file=None, leave=True) as bar:

            def echo(done: int, total: int, bar: tqdm = bar) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            status = run_job(job.id, echo=echo)
        job = db.session.get(Job, job.id)
        if status != "done":
            raise click.ClickException(f"{kind} failed: {job.message}")  # type: ignore[union-attr]


def create_from_file(path: Path, owner_email: str) -> int:
    """Create the study of the study file at ``path`` for the experimenter ``owner_email``,
    committed; returns its id."""
    import sqlalchemy as sa

    from app.trials.studyfile import load_study_file
    from app.web.extensions import db
    from app.web.models import User
    from app.web.study.studies import create_study

    owner = db.session.scalar(sa.select(User).where(User.email == owner_email.lower()))
    if owner is None:
        raise InputError(
            f"no experimenter {owner_email!r} (add one with 'facepair experimenter add')",
            field="--owner",
        )
    spec = load_study_file(path)
    study = create_study(owner, spec, source_toml=path.read_text(encoding="utf-8"))
    db.session.commit()
    return study.id
