"""A season's manifest: everything that must not change while the season runs, by SHA-256.

The manifest (:func:`build_manifest`) pins the season (:mod:`app.leaderboard.season`): the
SHA-256 of the file, of every segment's audio, transcript and ground truth, of the render and
test settings and of the avatar; the manifest's own SHA-256 names the season's frozen state.
Rounds refuse to start when a pinned file no longer matches (``app.web.board``).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Final

from app.leaderboard.season import SeasonSpec

SEASON_FORMAT: Final = "facepair-season/1"
"""The manifest's ``format``."""


def canonical_json(value: Any) -> bytes:
    """The one byte form of a JSON value that its SHA-256 is taken of (sorted keys, no spaces).

    >>> canonical_json({"b": 1, "a": [1.5, "x"]})
    b'{"a":[1.5,"x"],"b":1}'
    """
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode()


def sha256_hex(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        while block := handle.read(1 << 20):
            digest.update(block)
    return digest.hexdigest()


def build_manifest(
    spec: SeasonSpec,
    *,
    season_file: str,
    durations: Mapping[str, float],
    draw_commitment: str,
    software: Mapping[str, str | None],
) -> dict[str, Any]:
    """The season's manifest: everything that must not change while it runs, by SHA-256.

    ``durations`` are the segments' speech lengths in seconds (what submissions are checked
    against); ``draw_commitment`` the SHA-256 of the secret that draws stochastic systems'
    samples (revealed when the season closes, so the draws can be checked then and not gamed
    before). ``manifest_sha256(manifest)`` names the frozen state.
    """
    face = spec.face()
    render = {k: v for k, v in spec.render.items() if k != "face"}
    if face is not None:
        render["face"] = {"name": face.name, "sha256": file_sha256(face)}
    test = json.loads(canonical_json(dict(spec.test)))
    rounds, submissions, publish = spec.rounds, spec.submissions, spec.publish
    return {
        "format": SEASON_FORMAT,
        "name": spec.name,
        "title": spec.title,
        "licence": spec.licence,
        "season_file_sha256": sha256_hex(season_file.encode("utf-8")),
        "draw_commitment": draw_commitment,
        "segments": [
            {
                "name": s.name,
                "transcript": s.transcript,
                "duration_s": round(float(durations[s.name]), 6),
                "audio_sha256": file_sha256(s.audio),
                "ground_truth_sha256": file_sha256(s.ground_truth),
            }
            for s in spec.segments
        ],
        "render": render,
        "render_sha256": sha256_hex(canonical_json(render)),
        "test": test,
        "test_sha256": sha256_hex(canonical_json(test)),
        "rounds": {
            "anchors": list(rounds.anchors),
            "top": rounds.top,
            "segments": rounds.segments,
            "pairs": rounds.pairs,
            "participants": rounds.participants,
        },
        "submissions": {
            "frame_rates": list(submissions.frame_rates),
            "samples": submissions.samples,
            "require": list(submissions.require),
            "max_file_mb": submissions.max_file_mb,
            "pad": submissions.pad,
        },
        "publish": {
            "min_votes": publish.min_votes,
            "bootstrap": publish.bootstrap,
            "confidence": publish.confidence,
            "drift_alpha": publish.drift_alpha,
        },
        "software": dict(software),
    }


def manifest_sha256(manifest: Mapping[str, Any]) -> str:
    """The SHA-256 naming a manifest (of its canonical JSON)."""
    return sha256_hex(canonical_json(dict(manifest)))
