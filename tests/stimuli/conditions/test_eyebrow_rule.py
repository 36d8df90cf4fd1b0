import numpy as np

from app.stimuli.conditions.eyebrow_rule import (
    eyebrow_contour,
    eyebrow_raise_events,
    eyebrow_raise_sizes,
    rising_crossings,
)
from tests.support.speech_contours import known_contours

FPS = 30.0


def test_raises_start_at_the_crossings_and_release_on_the_drop():
    f0, intensity = known_contours()
    assert rising_crossings(f0, 207.0).tolist() == [10, 60, 100]
    events = eyebrow_raise_events(f0, intensity, FPS)
    assert events == [(10, 30), (60, 80), (100, 109)]
    for start, release in events:
        assert (release - start) / FPS >= 0.3 - 1e-12  # held at least 300 ms


def test_contour_holds_then_ramps_down_in_three_frames():
    f0, intensity = known_contours()
    events = eyebrow_raise_events(f0, intensity, FPS)
    peaks = eyebrow_raise_sizes(f0, events, FPS)
    assert peaks.tolist() == [f0[18], 230.0, 220.0]  # highest F0 during the 9-frame hold
    y = eyebrow_contour(150, events, 0.5 * peaks)
    assert np.all(y[:10] == 0) and np.all(y[10:30] == 0.5 * f0[18])
    np.testing.assert_allclose(y[30:34], 0.5 * f0[18] * np.array([0.75, 0.5, 0.25, 0]))
    assert np.all(y[60:80] == 115) and y[83] == 0
    assert np.all(y[100:109] == 110) and y[109] == 82.5 and np.all(y[112:] == 0)


def test_thresholds_are_parameters():
    f0, intensity = known_contours()
    assert eyebrow_raise_events(f0, intensity, FPS, f0_threshold=300.0) == []
    # every frame below the intensity threshold: no frame may start a raise
    assert eyebrow_raise_events(f0, intensity, FPS, intensity_threshold=70.0) == []
    # loud only around the crossings, quiet after: the minimum hold alone sets the release
    loud_at_onsets = np.where(np.isin(np.arange(150), [9, 10, 59, 60, 99, 100]), 75.0, 60.0)
    quiet = eyebrow_raise_events(f0, loud_at_onsets, FPS, intensity_threshold=70.0)
    assert quiet == [(10, 19), (60, 69), (100, 109)]
    # a 1-s hold: raise 1 lasts to 40, is loud there until 80; the crossings at 60 and 100
    # fall inside it and extend it to 100 + 30 frames, where it is quiet
    assert eyebrow_raise_events(f0, intensity, FPS, min_hold_s=1.0) == [(10, 130)]


def test_a_new_crossing_during_a_raise_extends_it():
    f0 = np.full(60, 150.0)
    f0[5:8] = 250.0
    f0[12:14] = 250.0  # second crossing at 12, while raise 1 is held
    intensity = np.full(60, 40.0)  # quiet but at the crossings: only minimum holds apply
    intensity[[4, 5, 11, 12]] = 60.0
    assert eyebrow_raise_events(f0, intensity, FPS) == [(5, 21)]


def test_edge_cases():
    f0 = np.full(20, 250.0)  # above the threshold from the start: no rising edge
    assert eyebrow_raise_events(f0, np.full(20, 60.0), FPS) == []
    f0[:3] = 100
    assert eyebrow_raise_events(f0, np.full(20, 60.0), FPS) == [(3, 20)]  # held to the end
    assert eyebrow_contour(20, [(3, 20)], np.array([7.0]))[-1] == 7.0


def test_no_raise_starts_on_unvoiced_or_quiet_frames():
    """The spline through a pause crosses the threshold; the speaker's pitch does not."""
    f0 = np.r_[np.full(10, 150.0), np.zeros(20), np.full(10, 250.0), np.full(20, 150.0)]
    f0c = np.r_[np.full(10, 150.0), np.linspace(150, 250, 20), np.full(10, 250.0), f0[40:]]
    intensity = np.r_[np.full(10, 60.0), np.full(20, 20.0), np.full(30, 60.0)]
    assert rising_crossings(f0c, 207.0).tolist() == [21]  # inside the pause
    voiced = f0 > 0
    # speech resumes above the threshold after a pause that began below it: a raise there
    assert eyebrow_raise_events(f0c, intensity, FPS, voiced=voiced) == [(30, 60)]
    # the crossing frame is loud but unvoiced: it waits for the next voiced frame
    loud = np.full(60, 60.0)
    assert eyebrow_raise_events(f0c, loud, FPS, voiced=voiced) == [(30, 60)]
    assert eyebrow_raise_events(f0c, loud, FPS) == [(21, 60)]  # every frame counted voiced
    # a pause that ends below the threshold, after a spline hump above it: no raise at all
    hump = np.r_[np.full(10, 150.0), 150 + 100 * np.sin(np.linspace(0, np.pi, 20)), f0[30:]]
    hump[30:40] = 150.0
    assert eyebrow_raise_events(hump, intensity, FPS, voiced=voiced) == []
