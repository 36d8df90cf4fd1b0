import json

import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.capture.labelling import MarkerTracks
from app.stimuli.capture.marker_faps import (
    MarkerConstants,
    gaussian_squash,
    marker_faps,
    mean_filter,
)
from app.stimuli.capture.markerset import MARKERS

#: A flat marker layout in pixels: posts 200 x 200 apart, the face inside.
LAYOUT = {
    "TL": (100, 100),
    "TR": (300, 100),
    "BL": (100, 300),
    "BR": (300, 300),
    "brow_inner_l": (215, 140),
    "brow_inner_r": (185, 140),
    "brow_middle_l": (240, 135),
    "brow_middle_r": (160, 135),
    "nose_bridge": (200, 165),
    "nose_tip": (200, 200),
    "cheek_l": (250, 195),
    "cheek_r": (150, 195),
    "lip_top": (200, 230),
    "lip_bottom": (200, 250),
    "lip_corner_l": (227, 235),
    "lip_corner_r": (173, 235),
    "chin": (200, 280),
}
# MW0 = 54 px: with the default FAPU (MW0 54 mm) one pixel is one millimetre
FAPU = {"ENS0": 52.0, "MNS0": 20.0, "MW0": 54.0}
LINEAR = MarkerConstants(squash=False, fapu_mm=FAPU)


def tracks_of(frames):
    pos = np.array([[f[n] for n in MARKERS] for f in frames], float)
    return MarkerTracks(pos, np.ones(pos.shape[:2], bool), np.arange(len(frames)) / 30.0)


def with_(**moves):
    out = {k: np.array(v, float) for k, v in LAYOUT.items()}
    for name, delta in moves.items():
        out[name] = out[name] + delta
    return out


def test_gaussian_squash_crosses_the_identity_at_0_3_and_saturates_at_the_apex():
    apex = 50.0
    x = np.linspace(0.5, 200, 400)
    g = gaussian_squash(x, apex)
    assert gaussian_squash(np.array([0.3 * apex]), apex)[0] == pytest.approx(0.3 * apex)
    assert np.all(g[x < 0.3 * apex - 0.5] < x[x < 0.3 * apex - 0.5])  # jitter attenuated
    mid = (x > 0.3 * apex + 0.5) & (x < 0.95 * apex)  # amplified up to the apex zone
    assert np.all(g[mid] > x[mid]) and g.max() <= apex and g[x >= apex].min() > 0.98 * apex
    np.testing.assert_allclose(gaussian_squash(-x, apex), -g)


def test_roll_is_the_posts_angle_and_ratios_give_pitch_and_yaw():
    c = LINEAR
    angle = np.radians(5.0)
    rot = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    centre = np.array([200.0, 200.0])
    # top leaning to the image's left (the face's right): positive roll
    rolled = {k: centre + rot @ (np.array(v, float) - centre) for k, v in LAYOUT.items()}
    assert rolled["TL"][0] < rolled["BL"][0]
    s = 0.5 * c.kp  # half the calibrated ratio change
    wide_top = with_(TL=(-100 * s, 0), TR=(100 * s, 0))  # top distance * (1 + s)
    long_left = with_(TL=(0, -100 * 0.5 * c.ky), BL=(0, 100 * 0.5 * c.ky))
    beyond = with_(TL=(-100 * 2 * c.kp, 0), TR=(100 * 2 * c.kp, 0))
    faps = marker_faps(tracks_of([LAYOUT, rolled, wide_top, long_left, beyond]), c)
    np.testing.assert_allclose(faps[50] * 1e-5, [0, angle, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(faps[48] * 1e-5, np.radians([0, 0, 0.5 * 17, 0, 17]), atol=1e-12)
    np.testing.assert_allclose(faps[49] * 1e-5, np.radians([0, 0, 0, 0.5 * 8, 0]), atol=1e-12)


def test_lips_open_and_stretch_in_fapu_with_the_thesis_weights():
    # opened by 10 px = 10 mm = half of MNS0: 512 MNS units; corners 4 mm further apart
    opened = with_(lip_top=(0, -1), lip_bottom=(0, 9), lip_corner_l=(2, 0), lip_corner_r=(-2, 0))
    faps = marker_faps(tracks_of([LAYOUT, opened]), LINEAR)
    assert faps[52][1] == pytest.approx(-0.9 * 512) and faps[51][1] == pytest.approx(-0.1 * 512)
    assert faps[59][1] == faps[60][1] == pytest.approx(-0.4 * 512)
    assert faps[53][1] == faps[54][1] == pytest.approx(2.0 / 54 * 1024)
    for outer in (51, 52, 53, 54, 59, 60):
        np.testing.assert_array_equal(faps[outer - 47], faps[outer])
    squashed = marker_faps(tracks_of([LAYOUT, opened]), MarkerConstants(fapu_mm=FAPU))
    assert squashed[52][1] == pytest.approx(-0.9 * 200, rel=1e-3)  # 512 is past the apex


def test_eyebrows_in_ens_units_corrected_by_the_posts():
    up = 52.0 / 1024 * 40  # 40 ENS units, in px (= mm here)
    raised = with_(
        brow_inner_l=(0, -up),
        brow_inner_r=(0, -up),
        brow_middle_l=(0, -2 * up),
        brow_middle_r=(0, -2 * up),
    )
    # the same raised face 10 % larger (nearer the camera): the post average undoes it
    nearer = {k: 1.1 * (v - 200.0) + 200.0 for k, v in raised.items()}
    faps = marker_faps(tracks_of([LAYOUT, raised, nearer]), LINEAR)
    np.testing.assert_allclose(faps[31], [0, 40, 40], atol=1e-9)
    np.testing.assert_allclose(faps[33], [0, 80, 80], atol=1e-9)
    np.testing.assert_array_equal(faps[32], faps[31])
    squashed = marker_faps(tracks_of([LAYOUT, raised]), MarkerConstants(fapu_mm=FAPU))
    assert squashed[31][1] == pytest.approx(gaussian_squash(np.array([40.0]), 50.0)[0])
    assert squashed[33][1] == pytest.approx(gaussian_squash(np.array([80.0]), 100.0)[0])


def test_five_frame_non_causal_mean():
    x = np.zeros(11)
    x[5] = 5.0
    np.testing.assert_allclose(mean_filter(x, 5 / 30, 30.0), [0, 0, 0, 1, 1, 1, 1, 1, 0, 0, 0])
    np.testing.assert_allclose(mean_filter(x, 5 / 30, 60.0)[5], 5.0 / 9)  # 167 ms at 60 fps


def test_constants_file_round_trip_and_bad_keys(tmp_path):
    c = MarkerConstants(kp=0.07, brow_pitch_inner=-12.5, fapu_mm={**FAPU, "ENS0": 49.0})
    c.to_json(tmp_path / "c.json")
    assert MarkerConstants.from_json(tmp_path / "c.json") == c
    for body, match in (
        ({"kq": 1}, "kq: unknown constant"),
        ({"kp": -1}, "kp: bad value"),
        ({"fapu_mm": {"ES0": 60}}, "fapu_mm: bad value"),
        ({"squash": 1}, "squash: bad value"),
        ([1], "expected a JSON object"),
    ):
        (tmp_path / "bad.json").write_text(json.dumps(body))
        with pytest.raises(InputError, match=match):
            MarkerConstants.from_json(tmp_path / "bad.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(InputError, match="not a readable JSON file"):
        MarkerConstants.from_json(tmp_path / "bad.json")
