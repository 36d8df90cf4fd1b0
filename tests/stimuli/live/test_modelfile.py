"""The live model file: round trip, corrupt and mismatched files, pickled arrays refused."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.live.modelfile import load_model, save_model
from app.stimuli.live.stream import generate_track


def test_round_trip_gives_identical_frames(live_model, live_training_data, tmp_path):
    path = save_model(live_model, tmp_path / "m.npz")
    back = load_model(path)
    assert back.summary == json.loads(json.dumps(live_model.summary))
    features = live_training_data[0].slice(0, 300)
    a = generate_track(live_model, features, seed=4)
    b = generate_track(back, features, seed=4)
    np.testing.assert_array_equal(a.values, b.values)
    with np.load(path, allow_pickle=False) as npz:  # no object arrays anywhere
        assert all(npz[k].dtype != object for k in npz.files)


def _rewrite(src, dst, change):
    with np.load(src, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    change(arrays)
    np.savez(dst, **arrays)


def _with_meta(arrays, **changes) -> np.ndarray:
    meta = json.loads(arrays["meta"].tobytes().decode())
    meta.update(changes)
    return np.frombuffer(json.dumps(meta).encode(), np.uint8)


def _one_line_error(path) -> str:
    with pytest.raises(InputError) as info:
        load_model(path)
    text = str(info.value)
    assert "\n" not in text and str(path) in text
    return text


def test_corrupt_files_give_one_line(live_model, tmp_path):
    good = save_model(live_model, tmp_path / "good.npz")
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(good.read_bytes()[:500])
    assert "not a live model file" in _one_line_error(truncated)
    text = tmp_path / "text.npz"
    text.write_text("hello")
    _one_line_error(text)
    assert "no such model file" in _one_line_error(tmp_path / "absent.npz")
    single = tmp_path / "single.npz"
    with open(single, "wb") as fh:
        np.save(fh, np.zeros(3))
    assert "not an .npz archive" in _one_line_error(single)


def test_mismatched_files_name_the_field(live_model, tmp_path):
    good = save_model(live_model, tmp_path / "good.npz")
    cases = {
        "shape": (lambda a: a.update(gaze_u=np.zeros((3, 2))), "gaze_u"),
        "missing": (lambda a: a.pop("eyelid_cb"), "eyelid_cb"),
        "nan": (lambda a: a.update(head_kin_std=np.full(5, np.nan)), "head_kin_std"),
        "weights": (
            lambda a: a.update(head_voiced_weights=a["head_voiced_weights"] * 2),
            "head_voiced",
        ),
        "version": (
            lambda a: a.update(
                meta=np.frombuffer(
                    json.dumps({"format": "facepair-live-gmm", "version": 99}).encode(), np.uint8
                )
            ),
            "meta.version",
        ),
        "format": (
            lambda a: a.update(meta=np.frombuffer(b'{"format": "x"}', np.uint8)),
            "meta.format",
        ),
        "json": (lambda a: a.update(meta=np.frombuffer(b"{not json", np.uint8)), "meta"),
        "fixation sd": (
            lambda a: a.update(gaze_fixation_offsets=-a["gaze_fixation_offsets"] - 1.0),
            "gaze_fixation_offsets",
        ),
        "interval sd": (
            lambda a: a.update(gaze_fixation_intervals=np.zeros((2, 2))),
            "gaze_fixation_intervals",
        ),
        "step sd": (lambda a: a.update(head_step_std=np.zeros(3)), "head_step_std"),
        "version 2": (
            lambda a: a.update(meta=_with_meta(a, version=2)),
            "version 2, this program reads version 3",
        ),
        "speech pose": (
            lambda a: a.update(head_expectation=a["head_expectation"][:2]),
            "head_expectation",
        ),
        "explosive variation": (
            lambda a: a.update(
                head_expectation=np.column_stack(
                    [
                        a["head_expectation"][:, :3],
                        np.full((3, 2), [1.5, 0.2]),
                        a["head_expectation"][:, 5],
                    ]
                )
            ),
            "head_expectation",
        ),
        "speaker normalisation": (
            lambda a: a.update(meta=_with_meta(a, speech={"speaker_normalisation_s": -1.0})),
            "meta",
        ),
        "proposal": (
            lambda a: a.update(meta=_with_meta(a, head={"n_iter": 17, "proposal": -1.0})),
            "meta",
        ),
    }
    for name, (change, field) in cases.items():
        bad = tmp_path / f"{name}.npz"
        _rewrite(good, bad, change)
        assert field in _one_line_error(bad), name


def test_pickled_arrays_are_refused(tmp_path):
    path = tmp_path / "pickled.npz"
    buf = io.BytesIO()
    np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("meta.npy", buf.getvalue())
    _one_line_error(path)
