"""The speaker's F0 range: two passes from known quartiles, octave errors unvoiced."""

import numpy as np

from app.stimuli.pitchrange import remove_octave_jumps, speaker_pitch_range
from app.stimuli.speech import condition_f0


def test_speaker_pitch_range_from_known_quartiles():
    f0 = np.r_[np.zeros(20), np.linspace(100.0, 140.0, 41)]  # q25 = 110, q75 = 130
    assert speaker_pitch_range(f0) == (82.5, 195.0, "two-pass estimate (De Looze & Hirst 2008)")
    assert speaker_pitch_range(f0, floor=70.0)[:2] == (70.0, 195.0)
    assert speaker_pitch_range(f0, 60.0, 300.0) == (60.0, 300.0, "given")
    lo, hi, how = speaker_pitch_range(np.full(5, 120.0))  # too little voicing
    assert (lo, hi) == (60.0, 750.0) and "first-pass" in how


def test_octave_jumps_are_unvoiced_and_accents_kept():
    fps = 30.0
    f0 = np.full(60, 126.0)
    f0[20:26] = [140.0, 160.0, 180.0, 200.0, 190.0, 170.0]  # a genuine accent, 0.2 s rise
    f0[40] = 371.0  # the demo speaker's octave error
    f0[50] = 63.0  # and a halving
    clean, removed = remove_octave_jumps(f0, fps)
    assert removed == 2 and clean[40] == 0 and clean[50] == 0
    np.testing.assert_array_equal(clean[20:26], f0[20:26])
    cond = condition_f0(clean)
    assert cond.max() == 200.0  # the spline bridges the errors: no 371 Hz raise trigger


def test_an_octave_error_between_pauses_is_unvoiced():
    """A short voiced stretch alone between two pauses: its neighbours are across the pauses."""
    f0 = np.r_[np.full(8, 80.0), np.zeros(5), np.full(3, 360.0), np.zeros(5), np.full(8, 82.0)]
    clean, removed = remove_octave_jumps(f0, 30.0)
    assert removed == 3 and np.all(clean[13:16] == 0)
    np.testing.assert_array_equal(clean[:8], f0[:8])
    np.testing.assert_array_equal(clean[-8:], f0[-8:])
    alone = np.r_[np.zeros(5), np.full(3, 360.0), np.zeros(5)]  # nothing to compare with
    assert remove_octave_jumps(alone, 30.0)[1] == 0
