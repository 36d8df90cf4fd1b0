import json

import numpy as np
import pytest
from click.testing import CliRunner

from app.cli import main
from app.errors import InputError
from app.stimuli.fapfile import read_fap
from app.stimuli.generate import generate_conditions
from app.stimuli.io import load_track


def test_demo_generates_four_conditions(repo_root, tmp_path):
    demo = repo_root / "app" / "data" / "demo"
    seen = []
    result = generate_conditions(
        demo / "speech.wav",
        ground_truth=demo / "ground_truth.fap",
        normalize=True,
        seed=1,
        pitch_ceiling=300,
        progress=lambda done, total: seen.append((done, total)),
    )
    # features, four conditions, eyes, normalisation, summary
    assert seen == [(k, 8) for k in range(1, 9)]
    assert set(result.tracks) == {"none", "random", "speech_driven", "ground_truth"}
    assert all(t.n_frames == 120 for t in result.tracks.values())
    assert result.summary["ground_truth"]["synthetic"] is True
    json.dumps(result.summary)


def test_cli_writes_tracks_summary_and_plot(repo_root, tmp_path):
    demo = repo_root / "app" / "data" / "demo"
    out = tmp_path / "out"
    r = CliRunner().invoke(
        main,
        [
            "stimuli",
            "generate",
            "--audio",
            str(demo / "speech.wav"),
            "--out",
            str(out),
            "--no-plot",
        ],
    )
    assert r.exit_code == 0, r.output
    assert {p.name for p in out.iterdir()} == {
        "none.fap",
        "random.fap",
        "speech_driven.fap",
        "summary.json",
    }
    summary = json.loads((out / "summary.json").read_text())
    assert "default head model" in summary["conditions"]["speech_driven"]["head_model"]
    assert summary["eyes"] == "generated" and summary["posture"]["mode"] == "shared"
    args = ["stimuli", "generate", "--audio", str(demo / "speech.wav"), "--no-plot"]
    thesis = CliRunner().invoke(
        main,
        [*args, "--out", str(tmp_path / "t"), "--posture", "per_condition", "--eyes", "still"],
    )
    assert thesis.exit_code == 0, thesis.output
    summary = json.loads((tmp_path / "t" / "summary.json").read_text())
    assert summary["eyes"] == "still" and summary["posture"]["mode"] == "per_condition"
    bad = CliRunner().invoke(
        main,
        [
            "stimuli",
            "generate",
            "--audio",
            str(demo / "speech.wav"),
            "--out",
            str(out),
            "--normalize",
        ],
    )
    assert bad.exit_code == 2 and "needs a reference" in bad.output


def demo_args(repo_root):
    demo = repo_root / "app" / "data" / "demo"
    return demo / "speech.wav", demo / "ground_truth.fap"


def test_a_condition_named_unlike_its_model_keeps_its_settings(repo_root):
    """A study file's ``name = "calm"``, ``model = "random"`` with settings reaches the model."""
    audio, gt = demo_args(repo_root)
    result = generate_conditions(
        audio,
        conditions={
            "calm": {"model": "random", "octaves": 1, "persistence": 0.5},
            "lively": {"model": "random"},
            "none": {},
        },
        ground_truth=gt,
        seed=3,
    )
    assert list(result.tracks) == ["calm", "lively", "none"]
    params = result.summary["conditions"]["calm"]["parameters"]
    assert params["model"] == "random" and params["octaves"] == 1
    assert result.summary["conditions"]["lively"]["parameters"]["octaves"] == 6
    assert not result.tracks["calm"].equals(result.tracks["lively"])


def test_unknown_model_and_misplaced_model_file_are_one_line_errors(repo_root, tmp_path):
    audio, _ = demo_args(repo_root)
    with pytest.raises(InputError, match="unknown condition 'brownian'"):
        generate_conditions(audio, conditions={"calm": {"model": "brownian"}})
    with pytest.raises(InputError, match="'random' \\(random\\) takes no model file"):
        generate_conditions(audio, conditions="random", models={"random": tmp_path / "m"})
    with pytest.raises(InputError, match="not among the conditions"):
        generate_conditions(audio, conditions="none", models={"speech_driven": "m.json"})


def test_model_files_go_to_their_own_condition(repo_root, tmp_path):
    audio, gt = demo_args(repo_root)
    from app.stimuli.conditions.head_arx import DEFAULT_MODEL_PATH

    model = tmp_path / "head.json"
    model.write_bytes(DEFAULT_MODEL_PATH.read_bytes())
    result = generate_conditions(
        audio, conditions="speech_driven,none", ground_truth=gt, models={"speech_driven": model}
    )
    assert "read from head.json" in result.summary["conditions"]["speech_driven"]["head_model"]


@pytest.mark.parametrize("eyes", ["still", "ground_truth", "generated"])
def test_eyes_are_the_same_in_every_condition(repo_root, eyes):
    audio, gt = demo_args(repo_root)
    result = generate_conditions(
        audio,
        conditions="none,random,speech_driven,ground_truth",
        ground_truth=gt,
        eyes=eyes,
        seed=2,
    )
    tracks = list(result.tracks.values())
    for c in range(19, 27):
        for t in tracks[1:]:
            np.testing.assert_array_equal(t[c], tracks[0][c])
    moving = np.ptp(tracks[0].values[:, [tracks[0].channels.index(c) for c in (19, 23)]])
    assert (moving == 0) == (eyes == "still")
    if eyes == "ground_truth":
        truth = load_track(gt)
        np.testing.assert_allclose(tracks[0][23], truth[23][:120])
        assert set(tracks[0].channels) >= {19, 20, 21, 22, 23, 24, 25, 26}
    assert result.summary["eyes"] == eyes


def test_generated_eyes_replace_the_live_models_own_in_every_condition(repo_root):
    audio, gt = demo_args(repo_root)
    result = generate_conditions(audio, conditions="live_gmm,none", eyes="still", ground_truth=gt)
    assert np.all(result.tracks["live_gmm"][23] == 0)  # no eye confound with NO_PROSODY
    assert result.tracks["live_gmm"][48].std() > 0


def test_normalize_scales_every_conditions_head_and_reports_the_factors(repo_root):
    """Thesis sec. 5.3: head angles to the ground truth's mean and sd, eyebrows untouched."""
    audio, gt = demo_args(repo_root)
    plain = generate_conditions(audio, ground_truth=gt, seed=1)
    norm = generate_conditions(audio, ground_truth=gt, seed=1, normalize=True)
    ref = norm.tracks["ground_truth"]
    for name in ("random", "speech_driven"):
        for c in (48, 49, 50):
            np.testing.assert_allclose(norm.tracks[name][c].std(), ref[c].std(), rtol=1e-9)
            np.testing.assert_allclose(norm.tracks[name][c].mean(), ref[c].mean(), atol=1e-6)
        np.testing.assert_array_equal(norm.tracks[name][31], plain.tracks[name][31])
        factors = norm.summary["normalization"][name]
        assert set(factors) == {"48", "49", "50"} and factors["49"]["scale"] > 0
    # experiment 1 (no normalisation): RANDOM keeps the Perlin amplitudes of Table 8
    assert plain.tracks["random"][49].std() > plain.tracks["ground_truth"][49].std()


def _greta_ground_truth(path, n_frames=120, fps=30, seed=3):
    """Write a .fap as Greta writes it; return {FAP: values} of the low-level FAPs in it.

    69-value masks: FAP i at position i, then one extra entry; one integer per masked
    position, the viseme (position 1) and the extra (position 69) included.
    """
    positions = (1, 3, 4, 19, 48, 49, 50, 51, 68, 69)
    rng = np.random.default_rng(seed)
    values = rng.integers(-3000, 3000, (n_frames, len(positions)))
    bits = ["1" if p in positions else "0" for p in range(1, 70)]
    lines = [f"2.1 {path.name} {fps} {n_frames}"]
    for i in range(n_frames):
        lines += [" ".join(bits) + " ", " ".join(map(str, [i, *values[i]])) + " "]
    path.write_text("\n".join(lines) + "\n")
    return {p: values[:, k] for k, p in enumerate(positions) if 3 <= p <= 68}


@pytest.mark.parametrize("greta", [False, True])
def test_greta_ground_truth_passes_through_unchanged(repo_root, tmp_path, greta):
    gt_path = tmp_path / "greta_gt.fap"
    expected = _greta_ground_truth(gt_path)
    out = tmp_path / "out"
    args = [
        "stimuli",
        "generate",
        "--audio",
        str(repo_root / "app/data/demo/speech.wav"),
        "--ground-truth",
        str(gt_path),
        "--conditions",
        "ground_truth",
        "--out",
        str(out),
        "--no-plot",
        "--eyes",
        "ground_truth",
    ] + (["--greta"] if greta else [])
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    written = out / "ground_truth.fap"
    track = read_fap(written)
    assert track.n_frames == 120 and track.fps == 30
    assert track.channels == tuple(expected)
    for fap, values in expected.items():
        np.testing.assert_array_equal(track[fap], values)
    body = [line.split() for line in written.read_text().splitlines() if not line.startswith("#")][
        1:
    ]
    # The same positions masked, less Greta's extra entry; with --greta (69 values) the viseme
    # (FAP 1) is written back as it came (app.stimuli.fapfile keeps FAPs 1 and 2).
    kept = set(expected) | ({1} if greta else set())
    bits = ["1" if p in kept else "0" for p in range(1, 70 if greta else 69)]
    assert body[::2] == [bits] * 120


def test_by_default_every_condition_rests_in_the_ground_truths_posture(repo_root):
    """NO_PROSODY and RANDOM faced the camera while the ground truth (and SPEECH_DRIVEN, which
    took its mean) were turned by the capture's posture: participants could judge that."""
    audio, gt = demo_args(repo_root)
    result = generate_conditions(audio, ground_truth=gt, seed=1)
    truth = result.tracks["ground_truth"]
    rest = {c: float(np.median(truth[c])) for c in (48, 49, 50)}
    assert max(abs(v) for v in rest.values()) * 180 / np.pi * 1e-5 > 1  # a posture, not 0
    for name, track in result.tracks.items():
        for c in (48, 49, 50):
            assert np.median(track[c]) == pytest.approx(rest[c], abs=1e-6), (name, c)
    np.testing.assert_array_equal(result.tracks["none"][49], rest[49])
    np.testing.assert_allclose(truth[48], load_track(gt)[48][:120], atol=1e-6)  # unchanged
    posture = result.summary["posture"]
    assert posture["mode"] == "shared" and posture["rest_from"] == "median of the ground truth"
    assert posture["rest_head_au"]["49"] == pytest.approx(rest[49])


def test_per_condition_posture_is_the_thesis_experiment_1(repo_root):
    audio, gt = demo_args(repo_root)
    shared = generate_conditions(audio, ground_truth=gt, seed=1)
    own = generate_conditions(audio, ground_truth=gt, seed=1, posture="per_condition")
    assert np.all(own.tracks["none"][49] == 0)
    assert own.tracks["speech_driven"][49].mean() == pytest.approx(
        own.tracks["ground_truth"][49].mean(), abs=1e-6
    )
    for name in own.tracks:  # the motion itself is the same, only its posture moved
        d = shared.tracks[name][49] - own.tracks[name][49]
        assert np.ptp(d) < 1e-6
        np.testing.assert_array_equal(shared.tracks[name][31], own.tracks[name][31])
    assert own.summary["posture"] == {
        "mode": "per_condition",
        "rest_head_au": None,
        "rest_from": None,
    }
    with pytest.raises(InputError, match="posture must be one of shared, per_condition"):
        generate_conditions(audio, conditions="none", posture="front")


def test_without_a_ground_truth_the_shared_rest_is_neutral(repo_root):
    audio, _ = demo_args(repo_root)
    result = generate_conditions(audio, conditions="none,random,speech_driven", seed=1)
    for track in result.tracks.values():
        for c in (48, 49, 50):
            assert abs(np.median(track[c])) < 1e-6
    assert result.summary["posture"]["rest_from"] == "neutral"


def test_by_default_both_faces_blink_and_look_around_together(repo_root):
    audio, gt = demo_args(repo_root)
    result = generate_conditions(audio, ground_truth=gt, seed=1)
    assert result.summary["eyes"] == "generated"
    tracks = list(result.tracks.values())
    for c in range(19, 27):
        for t in tracks[1:]:
            np.testing.assert_array_equal(t[c], tracks[0][c])
    assert tracks[0][19].max() > 512  # an upper lid more than half closed: a blink
    assert np.ptp(tracks[0][23]) > 0  # the gaze moves


def test_a_live_model_keeps_its_own_eyes_and_shares_them(repo_root):
    """The live model fitted on this recording has its own gaze and blinks; they were
    replaced by the shipped model's, and now every face of the clip gets them."""
    from app.stimuli.eyes import eye_channels
    from app.stimuli.live.condition import LiveGmmCondition
    from app.stimuli.speech import extract_features
    from app.stimuli.track import align_to_features

    audio, gt = demo_args(repo_root)
    result = generate_conditions(
        audio, conditions="live_gmm,none", ground_truth=gt, seed=3, eyes="generated"
    )
    feats = extract_features(audio)
    truth = load_track(gt)
    own = LiveGmmCondition().fit(feats, align_to_features(truth, feats)).generate(feats, seed=3)
    shipped = eye_channels("generated", feats, seed=3)
    assert any(not np.array_equal(own[c], shipped[c]) for c in range(19, 27))
    for c in range(19, 27):
        np.testing.assert_array_equal(result.tracks["live_gmm"][c], own[c])
        np.testing.assert_array_equal(result.tracks["none"][c], own[c])
    assert result.summary["eyes_from"] == "condition live_gmm (live_gmm)"


def test_cli_imports_a_track_as_a_condition_and_refuses_a_short_one(repo_root, tmp_path):
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack

    demo = repo_root / "app" / "data" / "demo"
    for seconds in (4.0, 2.0):
        n = int(seconds * 30)
        write_fap(
            MotionTrack.from_channels(30, {48: np.linspace(0, 3000, n), 19: np.zeros(n)}),
            tmp_path / f"mine{seconds:g}.fap",
        )
    args = ["stimuli", "generate", "--audio", str(demo / "speech.wav"), "--no-plot"]
    args += ["--conditions", "none", "--out", str(tmp_path / "out")]
    ok = CliRunner().invoke(main, [*args, "--track", f"mine={tmp_path / 'mine4.fap'}"])
    assert ok.exit_code == 0, ok.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["conditions"]["mine"]["parameters"] == {
        "model": "imported",
        "file": "mine4.fap",
        "offset_s": 0.0,
    }
    mine, none = (load_track(tmp_path / "out" / f"{n}.fap") for n in ("mine", "none"))
    assert np.array_equal(mine.get(19), none.get(19)) and np.array_equal(mine.get(23), none.get(23))
    short = CliRunner().invoke(main, [*args, "--track", f"mine={tmp_path / 'mine2.fap'}"])
    assert short.exit_code == 2
    assert "mine2.fap: condition mine: 2.00 s of motion for 4.00 s of speech" in short.output
    # one line (the progress bar, cleared by carriage returns, shares it on a terminal)
    assert len(short.output.strip().split("\n")) == 1
    padded = CliRunner().invoke(main, [*args, "--pad", "--track", f"m={tmp_path / 'mine2.fap'}"])
    assert padded.exit_code == 0 and "the last 2.00 s hold its last frame" in padded.output
    clash = CliRunner().invoke(main, [*args, "--track", f"none={tmp_path / 'mine4.fap'}"])
    assert clash.exit_code == 2 and "'none' is already a condition" in clash.output
