"""Eyelids: NNLS recovers a known coupling, blink fitting recovers known log-normals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from app.stimuli.live.eyelids import (
    BLINK_SHAPE,
    BlinkClock,
    EyelidModel,
    blink_closure,
    blink_onsets,
    closure_from_faps,
    default_blink_params,
    fit_eyelid_model,
    fit_interval_params,
)


def test_blink_shape_closes_fully_and_reopens():
    tc, th, to = BLINK_SHAPE
    tau = np.array([-0.01, 0.0, tc / 2, tc, tc + th / 2, tc + th + to / 2, tc + th + to, 1.0])
    np.testing.assert_allclose(blink_closure(tau), [0, 0, 0.5, 1, 1, 0.5, 0, 0], atol=1e-12)


def test_defaults_have_the_documented_mean_intervals():
    mu, sigma = default_blink_params().T
    np.testing.assert_allclose(np.exp(mu + sigma**2 / 2), [60 / 21.1, 60 / 15.4])


def test_nnls_recovers_a_known_non_negative_coupling():
    rng = np.random.default_rng(0)
    n = 2000
    gaze = np.column_stack([rng.normal(0, 5, n), rng.normal(0, 4, n)])  # yaw, pitch-down
    openness = 0.85 + 0.015 * -gaze[:, 1] + 0.004 * np.abs(gaze[:, 0])
    closure = 1 - openness
    lids = np.column_stack([0.7 * closure, 0.7 * closure, 0.3 * closure, 0.3 * closure]) * 1024
    model, summary = fit_eyelid_model(gaze, lids, np.ones(n, bool), 30.0)
    np.testing.assert_allclose(model.cb, [0.015, 0.004, 0.85], atol=1e-9)
    assert model.top_share == pytest.approx(0.7)
    assert summary["blinks"] == 0 and summary["blink_source"] == ["default", "default"]
    back, _ = closure_from_faps(model.faps(model.openness(gaze[0]), 0.0)[None])
    assert back[0] == pytest.approx(closure[0])


def test_lids_follow_gaze_pitch_and_are_symmetric_in_yaw():
    # Eq. 18 with a fitted coupling: looking down (positive FAP pitch) lowers the upper lid,
    # looking up raises it; looking 10 deg left or right does the same to the lids.
    model = EyelidModel(np.array([0.02, 0.003, 0.85]), default_blink_params(), 0.8)
    ahead = model.faps(model.openness(np.array([0.0, 0.0])), 0.0)
    down = model.faps(model.openness(np.array([0.0, 10.0])), 0.0)
    up = model.faps(model.openness(np.array([0.0, -10.0])), 0.0)
    assert down[0] == pytest.approx(ahead[0] + 0.2 * 0.8 * 1024)  # upper lid 19 lower
    assert up[0] == pytest.approx(ahead[0] - 0.2 * 0.8 * 1024)
    for pitch in (-8.0, 0.0, 6.0):
        left = model.openness(np.array([10.0, pitch]))
        right = model.openness(np.array([-10.0, pitch]))
        assert left == right == pytest.approx(0.85 - 0.02 * pitch + 0.03)


def test_a_one_sided_yaw_coupling_is_not_learned_as_open_one_way_close_the_other():
    # Lids that open with |yaw| are recovered; a signed yaw coupling has no |yaw| part.
    rng = np.random.default_rng(4)
    gaze = np.column_stack([rng.normal(0, 6, 1000), np.zeros(1000)])
    lids = np.column_stack([1 - (0.8 + 0.01 * gaze[:, 0])] * 2 + [np.zeros(1000)] * 2) * 1024
    model, _ = fit_eyelid_model(gaze, lids, np.ones(1000, bool), 30.0)
    assert model.cb[1] == pytest.approx(0.0, abs=1e-3)
    assert model.openness(np.array([8.0, 0.0])) == model.openness(np.array([-8.0, 0.0]))


def test_wrong_sign_coupling_is_clipped_to_zero():
    rng = np.random.default_rng(1)
    gaze = np.column_stack([rng.normal(0, 5, 500), rng.normal(0, 4, 500)])
    closure = 0.1 - 0.01 * gaze[:, 1]  # lid rises when looking down: negative coupling
    lids = np.column_stack([closure, closure, 0 * closure, 0 * closure]) * 1024
    model, _ = fit_eyelid_model(gaze, lids, np.ones(500, bool), 30.0)
    assert model.cb[0] == 0.0 and np.all(model.cb >= 0)


def test_blink_parameters_recovered_from_onsets():
    rng = np.random.default_rng(2)
    fps = 100.0
    gaps = np.exp(rng.normal(0.8, 0.3, 400))
    onsets = np.round(np.concatenate([[0.5], 0.5 + np.cumsum(gaps)]) * fps).astype(int)
    talking = np.ones(onsets[-1] + 1, bool)
    params, sources, counts = fit_interval_params(onsets, talking, fps)
    assert sources == ["fitted", "default"] and counts == [400, 0]
    assert params[0, 0] == pytest.approx(0.8, abs=0.04)
    assert params[0, 1] == pytest.approx(0.3, abs=0.03)
    np.testing.assert_allclose(params[1], default_blink_params()[1])


def test_blink_onsets_from_closure():
    times = np.arange(300) / 64.0  # exact in binary
    closure = blink_closure(times - 0.5) + blink_closure(times - 2.0)
    # Half closed 50 ms after the onset: first frames at or after 0.55 s and 2.05 s.
    assert blink_onsets(closure).tolist() == [36, 132]


def test_clock_draws_intervals_from_the_mode_of_each_onset():
    clock = BlinkClock(np.array([[0.5, 0.4], [1.4, 0.3]]), np.random.default_rng(3))
    fps = 30.0
    for i in range(int(2000 * fps)):
        clock.step(i / fps, talking=(i // 300) % 2 == 0)  # 10 s talking, 10 s listening
    log = np.array(clock.log)
    gaps, talk = log[:, 2], log[:, 1].astype(bool)
    for sel, (mu, sigma) in ((talk, (0.5, 0.4)), (~talk, (1.4, 0.3))):
        assert sel.sum() > 150
        assert stats.kstest(gaps[sel], stats.lognorm(s=sigma, scale=np.exp(mu)).cdf).pvalue > 0.01
    np.testing.assert_allclose(np.diff(log[:, 0]), gaps[:-1], rtol=1e-12)


def test_faps_closed_at_full_blink():
    model = EyelidModel(np.array([0.0, 0.0, 0.9]), default_blink_params(), 0.8)
    np.testing.assert_allclose(model.faps(0.9, 1.0), [819.2, 819.2, 204.8, 204.8])
    np.testing.assert_allclose(model.faps(1.0, 0.0), 0.0)
