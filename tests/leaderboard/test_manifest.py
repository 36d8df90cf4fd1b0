"""A season's manifest (``app.leaderboard.manifest``): every pinned file and setting by
SHA-256, and the SHA-256 naming the frozen state."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.leaderboard.demo import write_benchmark
from app.leaderboard.manifest import build_manifest, manifest_sha256
from app.leaderboard.season import load_season_file
from app.stimuli.io import load_track, save_track


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("bench")
    write_benchmark(folder, organiser="org@example.org")
    return folder


def _manifest(spec, text: str) -> dict:
    durations = {s.name: 1.0 for s in spec.segments}
    return build_manifest(
        spec, season_file=text, durations=durations, draw_commitment="0" * 64, software={}
    )


def test_the_demo_season_reads_and_pins_every_file(bench) -> None:
    spec = load_season_file(bench / "season.toml")
    assert spec.segment_names == ["s01", "s02"]
    assert spec.rounds.anchors == ("ground_truth", "none")
    text = (bench / "season.toml").read_text()
    manifest = _manifest(spec, text)
    assert manifest["format"] == "facepair-season/1"
    assert all(len(s["audio_sha256"]) == 64 for s in manifest["segments"])
    first = manifest_sha256(manifest)
    assert manifest_sha256(_manifest(spec, text)) == first  # canonical: stable
    # changing the ground truth of a segment changes the pinned state
    truth = bench / "s02_gt.fap"
    kept = truth.read_bytes()
    try:
        track = load_track(truth)
        save_track(track.replace(values=track.values * 0.5), truth)
        assert manifest_sha256(_manifest(spec, text)) != first
    finally:
        truth.write_bytes(kept)
