"""Where a season's own files live: ``MEDIA_ROOT/season-<id>/``.

``segments/<name>/`` holds each benchmark segment's speech and ground truth (the ground truth
never leaves the server while the season runs), ``render/`` the avatar of a season that names
one, and ``systems/<code>/`` every file a submitted system sent (all samples; the drawn one is
recorded on its row). The studies made from them copy what they need into their own folders,
and from there the media backend (local, nginx or S3) serves and distributes them as it does
any study's.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from flask import current_app

from app.web.board.models import Season
from app.web.infra.storage import media_folder, within


def season_dir(season: Season) -> Path:
    return media_folder(f"season-{season.id}")


def season_file(season: Season, rel: str) -> Path:
    """The absolute path of ``rel`` in the season's folder (never outside it)."""
    return within(season_dir(season), rel, "the season's folder")


def keep(season: Season, source: Path, rel: str) -> str:
    """Copy ``source`` into the season's folder as ``rel``; returns ``rel``."""
    target = season_file(season, rel)
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, target)
    return rel


def forget(season: Season) -> None:
    """Remove the season's folder (a season whose creation failed)."""
    shutil.rmtree(Path(current_app.config["MEDIA_ROOT"]) / f"season-{season.id}", True)
