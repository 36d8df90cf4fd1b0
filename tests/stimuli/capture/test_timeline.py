import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.capture.timeline import capture_rate, to_track


def test_capture_rate_from_rounded_stamps_with_drops():
    t = np.round(np.delete(np.arange(900) / 29.97, [10, 11, 400]), 3)
    assert capture_rate(t) == 29.97
    assert capture_rate(np.arange(100) / 47.0) == pytest.approx(47.0)


def test_duplicates_gaps_and_backwards_time():
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.5, 0.6])
    track, report = to_track(
        t, {48: np.array([0, 1, 9, 2, 5, 6.0])}, np.ones(6, bool), fps=10.0, source="x"
    )
    assert report["duplicates"] == 1 and report["filled_frames"] == 2
    np.testing.assert_allclose(track[48], [0, 9, 2, 3, 4, 5, 6])  # the later duplicate wins
    with pytest.raises(InputError, match="row 4: time goes backwards"):
        to_track(
            np.array([0.0, 0.1, 0.05]),
            {48: np.zeros(3)},
            np.ones(3, bool),
            fps=10.0,
            source="x",
            rows=np.array([2, 3, 4]),
        )
    with pytest.raises(InputError, match="fewer than 2 usable frames"):
        to_track(
            np.array([0.0, 0.1]), {48: np.zeros(2)}, np.array([True, False]), fps=10.0, source="x"
        )


def test_time_stamps_that_are_not_seconds_are_refused_before_allocating():
    with pytest.raises(InputError, match=r"give 1e-10 frames a second; expected 1-2000"):
        to_track(np.array([0.0, 1e10]), {48: np.zeros(2)}, np.ones(2, bool), fps=30.0, source="x")
    with pytest.raises(InputError, match=r"lasts 1e\+05 s, more than 4 hours"):
        t = np.r_[np.arange(10) / 30.0, 1e5 + np.arange(10) / 30.0]
        to_track(t, {48: np.zeros(20)}, np.ones(20, bool), fps=30.0, source="x", max_gap_s=1e9)
