"""Season files (``app.leaderboard.season``) and the checks a submission
passes at upload (``app.leaderboard.checks``): one line per problem, naming the file or field."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.leaderboard.checks import SegmentTarget, check_submission, draw_sample, segment_of
from app.leaderboard.demo import SEGMENTS, write_benchmark, write_systems
from app.leaderboard.season import SubmissionRules, loads_season
from app.stimuli.io import load_track, save_track


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("bench")
    write_benchmark(folder, organiser="org@example.org")
    return folder


@pytest.fixture(scope="module")
def systems(bench, tmp_path_factory) -> dict[str, list[Path]]:
    return write_systems(bench, tmp_path_factory.mktemp("systems"))


def _edited(bench: Path, old: str, new: str) -> str:
    text = (bench / "season.toml").read_text()
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ('transcript = "forget it."', "", "segments[1].transcript"),
        ('eyes = "generated"', 'eyes = "x"', "test.eyes"),
        ('anchors = ["ground_truth", "none"]', 'anchors = ["none"]', "rounds.anchors"),
        ("bootstrap = 500", "bootstrap = 5", "publish.bootstrap"),
        ("size = 96", 'size = "big"', "render.size"),
        ("[test]\n", '[test]\ndesign = "rating"\n', "test.design"),
        ('require = ["head"]', 'require = ["ears"]', "submissions.require"),
        ('audio = "s01.wav"', 'audio = "missing.wav"', "segments[0].audio"),
    ],
)
def test_a_bad_season_file_fails_in_one_line_naming_its_field(bench, old, new, field) -> None:
    with pytest.raises(InputError) as caught:
        loads_season(_edited(bench, old, new), source="season.toml", base_dir=bench)
    line = str(caught.value)
    assert "\n" not in line
    assert line.startswith("season.toml") and field in line, line


def test_one_segment_is_refused(bench) -> None:
    text = (bench / "season.toml").read_text()
    second = text.index('[[segments]]\nname = "s02"')
    one = text[:second] + text[text.index("[render]") :]
    with pytest.raises(InputError, match="segments: at least two segments"):
        loads_season(one, base_dir=bench)


values = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 10**6) | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=6,
)


TOP_KEYS = ["name", "seed", "title", "organiser", "segments", "rounds", "test", "render"]


@given(key=st.sampled_from([*TOP_KEYS, "publish", "submissions"]), value=values)
@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_any_value_of_a_top_key_is_read_or_refused_in_one_line(bench, key, value) -> None:
    data = tomllib.loads((bench / "season.toml").read_text())
    from app.leaderboard.season import parse_season

    data[key] = value
    try:
        parse_season(data, source="season.toml", base_dir=bench)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("season.toml")


# --- submissions --------------------------------------------------------------------------


def _targets(bench) -> list[SegmentTarget]:
    from app.stimuli.speechaudio import read_speech_audio

    out = []
    for name, *_ in SEGMENTS:
        speech = read_speech_audio(bench / f"{name}.wav")
        out.append(SegmentTarget(name, len(speech.samples) / speech.sample_rate))
    return out


def _check(bench, files: dict[str, Path], **rules):
    return check_submission(
        files, _targets(bench), SubmissionRules(**rules), system="sys01", draw_seed=3
    )


def test_every_demo_format_passes(bench, systems) -> None:
    for name, paths in systems.items():
        result = _check(bench, {p.name: p for p in paths}, samples=3, require=("head",))
        assert result.problems == (), (name, result.problems)
        assert set(result.drawn) == {"s01", "s02"}
        assert result.moves["head"] == 2
    bvh = _check(bench, {p.name: p for p in systems["SkeletonLag"]}, samples=3)
    assert {r.format for r in bvh.files} == {"bvh"}
    assert len(bvh.files) == 6  # three samples per segment, one drawn
    arkit = _check(bench, {p.name: p for p in systems["BlendRandom"]})
    assert {r.format for r in arkit.files} != {"csv"}  # the CSV's tool is named


def test_problems_are_one_line_each_and_name_the_file(bench, systems, tmp_path) -> None:
    good = systems["ProsodyARX"]
    truth = load_track(good[0])
    broken = truth.values.copy()
    broken[3, 0] = np.nan
    save_track(truth.replace(values=broken), tmp_path / "s01.csv")
    (tmp_path / "s07.fap").write_bytes(good[1].read_bytes())
    result = _check(bench, {"s01.csv": tmp_path / "s01.csv", "s07.fap": tmp_path / "s07.fap"})
    lines = list(result.problems)
    assert all("\n" not in line for line in lines)
    assert any(line.startswith("s07.fap: names no segment") for line in lines)
    # the reader refuses the NaN itself, naming the file's line
    assert any(line.startswith("s01.csv:") and "'nan'" in line for line in lines)
    assert any(line.startswith("s02: no track for this segment") for line in lines)


def test_frame_rate_length_and_range_are_checked(bench, systems, tmp_path) -> None:
    track = load_track(systems["ProsodyARX"][0])
    long = track.replace(values=np.vstack([track.values] * 3))
    save_track(long, tmp_path / "s01.fap")
    wild = track.values.copy()
    wild[:, track.channels.index(48)] = 400_000.0
    save_track(track.replace(values=wild), tmp_path / "s02.fap")
    files = {"s01.fap": tmp_path / "s01.fap", "s02.fap": tmp_path / "s02.fap"}
    lines = _check(bench, files, frame_rates=(60.0,)).problems
    assert any(line.startswith("s01.fap:") and "frames per second" in line for line in lines)
    assert any(line.startswith("s01.fap:") and "segment s01" in line for line in lines)
    assert any(line.startswith("s02.fap: FAP 48") and "plausible" in line for line in lines)


def test_a_file_that_is_no_track_fails_in_one_line(bench, tmp_path) -> None:
    (tmp_path / "s01.bvh").write_text("HIERARCHY\nnonsense\n")
    (tmp_path / "s02.csv").write_bytes(b"\x00\xff" * 10)
    files = {"s01.bvh": tmp_path / "s01.bvh", "s02.csv": tmp_path / "s02.csv"}
    lines = _check(bench, files).problems
    assert len(lines) == 2
    assert lines[0].startswith("s01.bvh") and lines[1].startswith("s02.csv")


@given(st.text(max_size=20), st.integers(0, 2**40), st.integers(1, 20))
def test_samples_are_named_and_drawn_deterministically(name, seed, n) -> None:
    found = segment_of(f"{name}.fap", ["s01", "s02"])
    assert found is None or found[0] in ("s01", "s02")
    pick = draw_sample(seed, "sys", "s01", n)
    assert 0 <= pick < n and pick == draw_sample(seed, "sys", "s01", n)
