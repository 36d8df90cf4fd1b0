"""What the faces of a clip share (app.stimuli.shared), walked through the whole generation
with every kind of condition: the built-in models, live_gmm, and a track from each importer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.fapfile import write_fap
from app.stimuli.generate import generate_conditions
from app.stimuli.shared import (
    EYE_GROUP,
    FACE_GROUP,
    TESTED,
    differing_channels,
    face_channels,
    lips_for,
    moves,
    share_channels,
)
from app.stimuli.track import MotionTrack
from app.stimuli.trackcsv import write_track_csv
from tests.stimuli.capture.files import (
    write_a2f3d_csv,
    write_a2f_json,
    write_bvh,
    write_live_link,
    write_openface,
    write_openfacefx,
)

FPS = 30.0
SECONDS = 4.0  # the demo speech
N = int(SECONDS * FPS)


def test_the_groups_cover_every_fap_once():
    groups = [set(TESTED), set(EYE_GROUP), set(FACE_GROUP)]
    assert set().union(*groups) == set(range(1, 69))
    assert sum(map(len, groups)) == 68
    assert {3, 4, 51, 41, 44, 61, 65} <= set(FACE_GROUP)  # jaw, lips, cheek, tongue, nose, ear


def test_lips_follow_the_mosaic_unless_the_study_says():
    assert lips_for(None, None) == lips_for(None, 24) == "shared"
    assert lips_for(None, 0) == "own"
    assert lips_for("shared", 0) == "shared" and lips_for("own", 24) == "own"
    with pytest.raises(InputError, match="lips must be one of shared, own"):
        lips_for("mine", 24)


def test_face_channels_come_from_the_ground_truth_else_the_first_that_moves_them():
    still = MotionTrack.from_channels(FPS, {48: np.ones(3), 3: np.zeros(3)})
    talk = MotionTrack.from_channels(FPS, {48: np.zeros(3), 3: np.array([0.0, 5.0, 0.0])})
    truth = MotionTrack.from_channels(FPS, {4: np.full(3, 7.0)})
    assert not moves(still, FACE_GROUP) and moves(talk, FACE_GROUP)
    cols, source = face_channels("shared", {"still": still, "talk": talk})
    assert source == "condition talk" and cols[3].tolist() == [0.0, 5.0, 0.0]
    cols, source = face_channels("shared", {"still": still, "talk": talk}, truth)
    assert source == "the ground truth" and sorted(cols) == [4]
    assert face_channels("shared", {"still": still}) == ({}, "none moves them (neutral)")
    assert face_channels("own", {"talk": talk})[0] is None
    # shared: a channel only one track had is 0 in every track, the tested head untouched
    out = share_channels({"still": still, "talk": talk}, cols)
    assert differing_channels(out) == []
    assert out["talk"][3].tolist() == [0.0, 0.0, 0.0] and out["still"][48].tolist() == [1, 1, 1]
    assert differing_channels({"still": still, "talk": talk}) == [3]


@settings(max_examples=60, deadline=None)
@given(
    data=st.data(),
    n_tracks=st.integers(1, 4),
    n_frames=st.integers(1, 20),
)
def test_any_tracks_share_every_channel_outside_the_tested(data, n_tracks, n_frames):
    """Whatever channels each track carries, after the eyes and the rest of the face are
    shared the tracks differ at most in the tested channels, which are untouched."""
    values = st.floats(-3000, 3000, allow_nan=False)
    tracks = {}
    for k in range(n_tracks):
        chans = data.draw(st.sets(st.integers(1, 68), max_size=12))
        cols = {
            c: np.array(data.draw(st.lists(values, min_size=n_frames, max_size=n_frames)))
            for c in chans
        }
        tracks[f"c{k}"] = (
            MotionTrack.from_channels(FPS, cols) if cols else MotionTrack.zeros(FPS, n_frames, ())
        )
    eyes = {c: np.full(n_frames, 5.0) for c in (19, 23)}
    cols, _ = face_channels(data.draw(st.sampled_from(["shared", "own"])), tracks)
    out = share_channels(share_channels(tracks, eyes, EYE_GROUP), cols or {})
    if cols is not None:
        assert differing_channels(out) == []
    else:
        assert not set(differing_channels(out)) & set(EYE_GROUP)
    for name, track in tracks.items():
        assert np.array_equal(
            out[name].dense()[:, np.array(TESTED) - 1], track.dense()[:, np.array(TESTED) - 1]
        )


# -- every kind of condition, walked through generate --------------------------------------------


def _head_and_mouth(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A nod and a jaw opening of the system's own, different per importer."""
    t = np.arange(N) / FPS
    nod = 0.08 * np.sin(2 * np.pi * (0.4 + 0.05 * seed) * t)
    jaw = 0.3 + 0.25 * np.sin(2 * np.pi * (3.0 + seed) * t) ** 2
    return nod, jaw


def _imported_files(folder: Path) -> dict[str, Path]:
    """One file per importer, each a system whose eye and blink columns are 0 throughout."""
    t = np.arange(N) / FPS
    files: dict[str, Path] = {}
    nod, jaw = _head_and_mouth(0)
    fap = MotionTrack.from_channels(
        FPS, {48: nod * 1e5, 3: jaw * 800, 19: np.zeros(N), 31: 30 * jaw}
    )
    write_fap(fap, folder / "ours.fap")
    files["fap"] = folder / "ours.fap"
    write_track_csv(fap.replace(values=fap.values * 0.5), folder / "ours_faps.csv")
    files["fap_csv"] = folder / "ours_faps.csv"
    nod, jaw = _head_and_mouth(1)
    app_rate = 60
    n_app = int(SECONDS * app_rate)
    up = np.interp(np.arange(n_app) / app_rate, t, jaw)
    pitch = np.interp(np.arange(n_app) / app_rate, t, nod)
    files["live_link"] = write_live_link(
        folder / "nod_arkit.csv", n_app, {"JawOpen": up, "HeadPitch": pitch}, app_fps=app_rate
    )
    nod, jaw = _head_and_mouth(2)
    files["openface"] = write_openface(
        folder / "openface.csv", t, {"pose_Rx": nod, "AU26_r": 3 * jaw, "AU01_r": 2 * jaw}
    )
    nod, jaw = _head_and_mouth(3)
    files["a2f_csv"] = write_a2f3d_csv(
        folder / "a2f.csv", t, {"JawOpen": jaw, "BrowInnerUp": jaw / 2}
    )
    files["a2f_json"] = write_a2f_json(folder / "a2f.json", FPS, {"JawOpen": 1 - jaw}, N)
    keys = {"jawOpen": [(float(x), float(j)) for x, j in zip(t[::6], jaw[::6], strict=True)]}
    files["openfacefx"] = write_openfacefx(folder / "fx.track.json", FPS, keys)
    files["bvh"] = write_bvh(folder / "genea.bvh", {"Head.Xrotation": 6 * np.degrees(nod)}, N)
    return files


@pytest.fixture(scope="module")
def every_kind(tmp_path_factory):
    folder = tmp_path_factory.mktemp("imports")
    files = _imported_files(folder)
    demo = Path(__file__).resolve().parents[2] / "app" / "data" / "demo"
    conditions = {
        **{m: m for m in ("none", "random", "speech_driven", "ground_truth", "live_gmm")},
        **{f"own_{k}": {"track": str(p), "label": p.name} for k, p in files.items()},
    }
    return demo, conditions, files


@pytest.mark.parametrize("eyes", ["generated", "still", "ground_truth"])
def test_every_kind_of_condition_shares_what_is_not_tested(every_kind, eyes):
    """Under the mosaic (lips shared), whatever a condition is made from, its eyes, lower face
    and everything else outside the head and brows are those of every other condition of the
    clip, value for value; its head is its own."""
    demo, conditions, _files = every_kind
    result = generate_conditions(
        demo / "speech.wav",
        conditions=conditions,
        ground_truth=demo / "ground_truth.fap",
        eyes=eyes,
        seed=3,
    )
    tracks = result.tracks
    assert set(tracks) == set(conditions)
    assert {t.n_frames for t in tracks.values()} == {N}
    assert differing_channels(tracks) == []
    # the imported systems keep what is tested: their own head, unlike each other
    heads = {n: tracks[n][48] for n in tracks if n.startswith("own_") and np.ptp(tracks[n][48])}
    assert set(heads) >= {"own_fap", "own_fap_csv", "own_live_link", "own_openface", "own_bvh"}
    assert len({h.round(3).tobytes() for h in heads.values()}) == len(heads)
    if eyes == "generated":  # the shared eyes come from live_gmm and blink in every face
        assert result.summary["eyes_from"] == "condition live_gmm (live_gmm)"
        assert all(t[19].max() > 0 for t in tracks.values())
    assert result.summary["lips"] == {"mode": "shared", "from": "the ground truth"}


def test_lips_own_keeps_each_conditions_mouth_and_says_so(every_kind):
    demo, conditions, _files = every_kind
    chosen = {k: conditions[k] for k in ("none", "own_live_link", "own_openface")}
    result = generate_conditions(demo / "speech.wav", conditions=chosen, lips="own", seed=1)
    differing = differing_channels(result.tracks)
    assert differing and set(differing) <= set(FACE_GROUP)
    assert any("lips = 'own'" in n for n in result.summary["notes"])
    # the eyes stay shared, whatever the lips do
    assert not set(differing) & set(EYE_GROUP)


def test_without_a_ground_truth_the_first_moving_condition_lends_the_lower_face(every_kind):
    demo, conditions, files = every_kind
    chosen = {k: conditions[k] for k in ("none", "random", "own_openface", "own_live_link")}
    result = generate_conditions(demo / "speech.wav", conditions=chosen, seed=1)
    assert differing_channels(result.tracks) == []
    assert result.summary["lips"]["from"] == "condition own_openface"
    assert result.tracks["none"][3].max() > 0  # NO_PROSODY's mouth moves as the others'


def test_own_eyes_are_refused_for_a_condition_without_eye_motion(every_kind):
    demo, conditions, _files = every_kind
    chosen = {k: conditions[k] for k in ("live_gmm", "own_live_link")}
    with pytest.raises(InputError) as err:
        generate_conditions(demo / "speech.wav", conditions=chosen, eyes="own")
    line = str(err.value)
    assert "condition own_live_link (nod_arkit.csv) carries no eye motion" in line
    assert "\n" not in line
    # every condition with eyes of its own: kept, each its own
    kept = generate_conditions(
        demo / "speech.wav",
        conditions={"a": "live_gmm", "b": {"model": "live_gmm"}},
        eyes="own",
        seed=2,
        condition_params={"b": {}},
    )
    assert kept.summary["eyes_from"] == "each condition's own"


def test_the_uploaded_file_is_named_in_the_notes(every_kind):
    demo, conditions, _files = every_kind
    result = generate_conditions(
        demo / "speech.wav", conditions={"none": "none", "nod": conditions["own_live_link"]}
    )
    said = [n for n in result.summary["notes"] if "imported from" in n]
    assert said and said[0].startswith("condition nod imported from nod_arkit.csv:"), said


# -- lengths ---------------------------------------------------------------------------------------


def _track_file(folder: Path, seconds: float) -> Path:
    n = round(seconds * FPS)
    path = folder / f"mine_{n}.fap"
    write_fap(MotionTrack.from_channels(FPS, {48: np.linspace(0, 5000, n)}), path)
    return path


def test_a_track_off_the_speech_beyond_the_tolerance_is_refused_naming_it(tmp_path, demo_wav):
    short = _track_file(tmp_path, 1.0)
    with pytest.raises(InputError) as err:
        generate_conditions(demo_wav, conditions={"none": "none", "mine": {"track": str(short)}})
    line = str(err.value)
    assert line.startswith("mine_30.fap: condition mine: 1.00 s of motion for 4.00 s of speech")
    assert "3.00 s short" in line and "--pad" in line
    # allowed explicitly: padded by holding the last frame, and said
    padded = generate_conditions(
        demo_wav,
        conditions={"none": "none", "mine": {"track": str(short)}},
        pad=True,
        posture="per_condition",
    )
    assert padded.tracks["mine"][48][-1] == padded.tracks["mine"][48][29] == 5000
    assert any("the last 3.00 s hold its last frame" in n for n in padded.summary["notes"])


def test_a_track_within_the_tolerance_is_aligned_with_a_line(tmp_path, demo_wav):
    near = _track_file(tmp_path, 4.1)
    exact = _track_file(tmp_path, 4.0 + 1 / FPS)
    result = generate_conditions(
        demo_wav,
        conditions={"none": "none", "near": {"track": str(near)}, "exact": {"track": str(exact)}},
    )
    notes = [n for n in result.summary["notes"] if "s of motion" in n]
    said = "4.10 s of motion for 4.00 s of speech: its last 0.10 s are cut"
    assert notes == [f"mine_123.fap: condition near: {said}"]


def test_a_ground_truth_off_the_speech_is_refused_too(tmp_path, demo_wav):
    truth = _track_file(tmp_path, 10.0)
    with pytest.raises(InputError, match=r"^mine_300.fap: ground truth: 10.00 s of motion"):
        generate_conditions(demo_wav, conditions="none", ground_truth=truth)


# -- brows: a study of head and eyes alone ---------------------------------------------------------


@pytest.mark.parametrize("brows", ["none", "rule"])
def test_shared_brows_leave_only_the_head_to_compare(demo_wav, brows):
    """live_gmm moves no eyebrow (Le et al. model none): against RANDOM or SPEECH_DRIVEN its
    pairs differed in brows too. brows = none / rule gives every condition the same."""
    from app.stimuli.fap import HEAD

    conditions = {"live": "live_gmm", "random": "random", "speech_driven": "speech_driven"}
    own = generate_conditions(demo_wav, conditions=conditions, seed=2)
    assert set(differing_channels(own.tracks, tested=HEAD)) & set(range(31, 39))
    assert any("moves no eyebrow" in n for n in own.summary["notes"])
    shared = generate_conditions(demo_wav, conditions=conditions, seed=2, brows=brows)
    assert differing_channels(shared.tracks, tested=HEAD) == []
    brow = shared.tracks["random"].get(31)
    assert (brow.max() > 0) == (brows == "rule")
    if brows == "rule":  # the rule's raises, the same as SPEECH_DRIVEN's own
        assert np.array_equal(brow, own.tracks["speech_driven"][31])
    assert shared.summary["brows"]["mode"] == brows
