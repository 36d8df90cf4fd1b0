"""A study package: one zip a paper's supplementary material or an OSF deposit needs, and
reading it back so ``facepair analyze package.zip`` reproduces the report's numbers.

The zip holds the study file (``study.toml``), the votes the report analysed (``votes.csv``;
``ratings.csv`` for the rating designs),
``participants.csv`` (Prolific IDs pseudonymised), ``answers.csv``, the report (``report.html``,
``report.pdf``) and its every number (``results.json``), and ``manifest.json``: the SHA-256 of
every file in the zip and of every clip, track and rendered video of the study, the seeds, the
software versions and the exact command that reproduces the analysis. The web app writes it
(``app.web.study.package``); this module only reads, so the analysis needs no server.

>>> PACKAGE_FORMAT, MANIFEST
('facepair-study-package/1', 'manifest.json')
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app.errors import InputError

PACKAGE_FORMAT = "facepair-study-package/1"
MANIFEST = "manifest.json"
VOTES = "votes.csv"
#: The rating designs' table, in place of the votes (app.analysis.rating_results).
RATINGS = "ratings.csv"
RESULTS = "results.json"
#: Largest member read back (votes of a very large study are a few tens of MB).
MAX_MEMBER_BYTES = 512 * 1024 * 1024


def sha256_bytes(data: bytes) -> str:
    """The SHA-256 of ``data`` as hex.

    >>> sha256_bytes(b"")[:16]
    'e3b0c44298fc1c14'
    """
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: Path) -> str:
    """The SHA-256 of the file at ``path`` (read in 1 MiB blocks) as hex."""
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        while block := handle.read(1 << 20):
            digest.update(block)
    return digest.hexdigest()


def analysis_command(package_name: str) -> str:
    """The command that reproduces the report from the package named ``package_name``."""
    return (
        f"facepair analyze {package_name} --json results.json --report report.html --pdf report.pdf"
    )


@dataclass(frozen=True)
class StudyPackage:
    """What ``facepair analyze`` takes from a package: the text of the table the report
    analysed (``table_text``, the file ``table``: :data:`VOTES`, or :data:`RATINGS` for a
    rating design) and the analysis options the report used (the manifest's ``analysis``)."""

    table_text: str
    conditions: list[str] | None
    exclude: str | None
    manifest: dict[str, Any]
    table: str = VOTES


def _member(archive: zipfile.ZipFile, name: str, path: Path) -> bytes:
    try:
        info = archive.getinfo(name)
    except KeyError:
        raise InputError(f"not a study package: no {name}", path=path) from None
    if info.file_size > MAX_MEMBER_BYTES:
        raise InputError(f"{name}: larger than {MAX_MEMBER_BYTES >> 20} MB", path=path)
    return archive.read(info)


def read_package(path: str | Path) -> StudyPackage:
    """Read the package at ``path``: its manifest, and its votes checked against the SHA-256
    the manifest holds (a changed file is refused: the numbers would not be the report's).
    Every problem is one :class:`~app.errors.InputError` naming the package."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            raw = _member(archive, MANIFEST, path)
            names = set(archive.namelist())
            table = RATINGS if RATINGS in names and VOTES not in names else VOTES
            votes = _member(archive, table, path)
    except (OSError, zipfile.BadZipFile) as exc:
        raise InputError(f"cannot read the package: {exc}", path=path) from None
    try:
        manifest = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{MANIFEST}: not JSON ({exc})", path=path) from None
    if not isinstance(manifest, dict) or manifest.get("format") != PACKAGE_FORMAT:
        raise InputError(f"{MANIFEST}: not a {PACKAGE_FORMAT} manifest", path=path)
    files = manifest.get("files")
    expected = files.get(table) if isinstance(files, dict) else None
    if expected != sha256_bytes(votes):
        raise InputError(f"{table}: its SHA-256 is not the manifest's (changed?)", path=path)
    analysis = manifest.get("analysis") or {}
    conditions = analysis.get("conditions")
    exclude = analysis.get("exclude")
    if conditions is not None and not (
        isinstance(conditions, list) and all(isinstance(c, str) for c in conditions)
    ):
        raise InputError(f"{MANIFEST}: analysis.conditions is not a list of names", path=path)
    if exclude is not None and not isinstance(exclude, str):
        raise InputError(f"{MANIFEST}: analysis.exclude is not text", path=path)
    try:
        text = votes.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{table}: not UTF-8 text", path=path) from None
    return StudyPackage(text, conditions, exclude or None, manifest, table)
