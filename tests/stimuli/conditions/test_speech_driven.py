import numpy as np
import pytest

from app.errors import InputError
from app.stimuli.conditions import make_condition
from app.stimuli.conditions.head_arx import DEFAULT_MODEL_PATH
from app.stimuli.conditions.speech_driven import resolve_threshold
from app.stimuli.reference_speaker import synthesize_reference
from app.stimuli.speech import SpeechFeatures, features_from_samples
from tests.support.speech_contours import known_contours


def known_features():
    f0, intensity = known_contours()
    return SpeechFeatures(30.0, f0, intensity, f0.copy())


THESIS = {"f0_threshold": 207, "intensity_threshold": 45}


def test_rule_eyebrows_and_default_head_model_without_ground_truth():
    feats = known_features()
    cond = make_condition("speech_driven", **THESIS)
    track = cond.generate(feats)
    assert track.name == "SPEECH_DRIVEN"
    info = track.metadata["eyebrows"]
    assert info["raises"] == [[10, 30], [60, 80], [100, 109]]
    size = 35 + 0.2 * (feats.f0_conditioned[18] - 207)  # 35 units at 207 Hz, 0.2 per Hz
    np.testing.assert_allclose(track[31][13:30], size)
    np.testing.assert_allclose(track[31][10:13], size * np.array([0.25, 0.5, 0.75]))
    np.testing.assert_allclose(track[31][30:34], size * np.array([0.75, 0.5, 0.25, 0]))
    np.testing.assert_allclose(track[33][63:80], 35 + 0.2 * 23)
    for c in (32, 33, 34):  # inner = middle, left = right (Table 8's equal columns)
        np.testing.assert_array_equal(track[c], track[31])
    assert np.all(track[35] == 0) and np.all(track[36] == 0)  # no outer-eyebrow markers
    assert "default head model" in track.metadata["head_model"]
    assert DEFAULT_MODEL_PATH.name in cond.describe()["head_model"]
    assert np.isfinite(track[48]).all() and track[48].std() > 0


def test_raise_sizes_stay_in_the_thesis_range_even_for_pitch_errors():
    f0 = np.full(60, 120.0)
    f0[10:20] = 520.0  # an octave error of a 260 Hz voice: the raise is capped
    feats = SpeechFeatures(30.0, f0, np.full(60, 70.0), f0.copy())
    track = make_condition("speech_driven", f0_threshold=207).generate(feats)
    assert track[31].max() == 80.0


def test_no_raise_warns():
    feats = known_features()
    track = make_condition("speech_driven", f0_threshold=400).generate(feats)
    assert track.metadata["eyebrows"]["n_raises"] == 0
    assert "never rises across 400 Hz" in track.metadata["eyebrows"]["warning"]


def test_a_long_hold_warns():
    f0 = np.full(300, 120.0)
    f0[10:20] = 250.0
    feats = SpeechFeatures(30.0, f0, np.full(300, 70.0), f0.copy())  # never quiet: 9.7 s hold
    track = make_condition("speech_driven", **THESIS).generate(feats)
    assert track.metadata["eyebrows"]["raises"] == [[10, 300]]
    assert "held longer than 4 s (0.3-10.0 s)" in track.metadata["eyebrows"]["warning"]


def test_auto_thresholds():
    feats = known_features()
    assert resolve_threshold("p75", "f0", feats) == np.percentile(feats.f0, 75)
    assert resolve_threshold("auto", "f0", feats) is None  # calibrated by the condition
    voiced_db = feats.intensity[feats.voiced]
    assert resolve_threshold("auto", "intensity", feats) == np.percentile(voiced_db, 30)
    louder = SpeechFeatures(30.0, feats.f0, np.linspace(50, 80, feats.n_frames), feats.f0)
    assert resolve_threshold("auto", "intensity", louder) == pytest.approx(59.0)  # 30 % up
    assert resolve_threshold("210", "f0", feats) == 210.0
    with pytest.raises(InputError, match="number, 'auto' or a percentile"):
        resolve_threshold("high", "f0", feats)


def test_auto_f0_threshold_holds_the_brows_up_the_tables_share_of_the_time():
    """Accents of rising height: a fixed threshold fires on the few highest (or none); the
    calibrated one is the level at which the raises take 30 % of the time, Table 8's."""
    fps, n = 30.0, 900
    t = np.arange(n) / fps
    accent = np.zeros(n)
    for k, start in enumerate(np.arange(0.5, 29.0, 1.5)):  # 19 accents, peaks 123..204 Hz
        on = (t >= start) & (t < start + 0.5)
        accent[on] = 4.5 * k
    f0 = 120.0 + accent + 3 * np.sin(2 * np.pi * 3 * t)
    intensity = np.where((t % 1.5) < 1.0, 60.0, 30.0)  # a pause after every accent
    feats = SpeechFeatures(fps, f0, intensity, f0.copy())
    share = {}
    for threshold in ("auto", "p75", 207.0):
        cond = make_condition("speech_driven", f0_threshold=threshold)
        info = cond.eyebrows(feats)[1]
        share[threshold] = sum(r - s for s, r in info["raises"]) / n
    assert share[207.0] == 0.0  # no accent reaches the thesis' level
    assert abs(share["auto"] - 0.30) < 0.05 < abs(share["p75"] - 0.30)
    lower = make_condition("speech_driven", brow_share=0.15).eyebrows(feats)[1]["raises"]
    assert sum(r - s for s, r in lower) / n < share["auto"]


def test_auto_release_does_not_depend_on_recording_gain():
    """The same speech recorded 20 dB louder raises and releases the brows on the same frames;
    the thesis' absolute 45 dB would not."""
    f0, intensity = known_contours()
    quiet = SpeechFeatures(30.0, f0, intensity, f0.copy())
    loud = SpeechFeatures(30.0, f0, intensity + 20.0, f0.copy())
    auto = [
        make_condition("speech_driven", f0_threshold=207).generate(f).metadata["eyebrows"]["raises"]
        for f in (quiet, loud)
    ]
    assert auto[0] == auto[1]
    fixed = [
        make_condition("speech_driven", **THESIS).generate(f).metadata["eyebrows"]["raises"]
        for f in (quiet, loud)
    ]
    assert fixed[0] != fixed[1]


def phrase_features(seconds=120.0, fps=30.0):
    rng = np.random.default_rng(0)
    n = round(seconds * fps)
    t = np.arange(n) / fps
    talking = (t % 4.0) < 3.0
    intensity = np.where(talking, 62 + 8 * np.sin(2 * np.pi * 3.5 * t), 38.0)
    intensity += rng.normal(0, 1, n)
    f0c = 170 + 50 * np.sin(2 * np.pi * 0.6 * t) ** 8 + 10 * np.sin(2 * np.pi * 0.21 * t)
    return SpeechFeatures(fps, np.where(talking, f0c, 0.0), intensity, f0c)


def test_fitted_on_reference_speaker_learns_speech_structure():
    """Fitted on the synthetic speaker, the model beats its own seed-shuffled baseline."""
    feats = phrase_features()
    gt = synthesize_reference(feats, seed=3)
    half = feats.n_frames // 2
    train, test = feats.slice(0, half), feats.slice(half, feats.n_frames)
    cond = make_condition("speech_driven").fit(train, gt.fit_length(half))
    assert "fitted on the ground truth" in cond.describe()["head_model"]
    pred = cond.generate(test)
    truth = gt.replace(values=gt.values[half:])
    # the synthetic head pitch has a speech-driven part, so held-out prediction correlates
    r = np.corrcoef(pred[48], truth[48])[0, 1]
    assert r > 0.3, r


def test_eyebrow_gains_fitted_from_ground_truth():
    feats = known_features()
    gt = make_condition("speech_driven", eyebrow_gain=0.2, eyebrow_offset=5, **THESIS).generate(
        feats
    )
    cond = make_condition("speech_driven", fit_eyebrows=True, **THESIS).fit(feats, gt)
    assert cond.brows_fitted
    np.testing.assert_allclose(cond.brow_gain[31], 0.2, atol=1e-9)
    np.testing.assert_allclose(cond.brow_offset[33], 5.0, atol=1e-9)
    assert not make_condition("speech_driven", **THESIS).fit(feats, gt).brows_fitted


def voice_features(gain_db=0.0, f0_scale=1.0, seconds=20.0, fps=30.0):
    """1 s of silence, then phrases: a voice unlike the default model's training voice."""
    feats = phrase_features(seconds, fps)
    lead = round(fps)
    inten = feats.intensity.copy() + gain_db
    inten[:lead] = 38.0 + gain_db
    f0 = feats.f0 * f0_scale
    f0[:lead] = 0.0
    f0c = feats.f0_conditioned * f0_scale
    f0c[:lead] = f0c[lead]
    return SpeechFeatures(fps, f0, inten, f0c)


def test_default_head_model_puts_no_offset_on_another_voice_and_rests_in_silence():
    for gain_db, f0_scale in ((0.0, 1.0), (15.0, 1.8), (-10.0, 0.6)):
        feats = voice_features(gain_db, f0_scale)
        track = make_condition("speech_driven").generate(feats)
        for c in (48, 49, 50):
            assert abs(track[c].mean()) < 1e-6  # neutral: no per-speaker posture
            # still until the 1-s input smoothing first sees the speech (half a window ahead)
            assert np.ptp(track[c][: 30 - 16]) < 1e-6
            assert 0 < track[c].std() < 3 * 1745  # moving, by less than 3 degrees sd


def test_head_mean_is_the_ground_truths():
    feats = phrase_features(30)
    gt = synthesize_reference(feats, seed=3)
    track = make_condition("speech_driven").fit(feats, gt).generate(feats)
    for c in (48, 49, 50):
        np.testing.assert_allclose(track[c].mean(), gt[c].mean(), atol=1e-6)


def test_the_spline_across_digital_silence_raises_no_brow():
    """A falling glide, 1 s of digital silence, the same glide: eq. 35's spline climbs from
    150 to 300 Hz inside the silence and crossed the threshold there (12 frames of raise)."""
    from tests.stimuli.conftest import harmonic_glide

    glide, _ = harmonic_glide(300, 150, 1.0)
    feats = features_from_samples(np.r_[glide, np.zeros(16000), glide], 16000, 30.0)
    track = make_condition("speech_driven").generate(feats)
    info = track.metadata["eyebrows"]
    silent = ~feats.voiced & (feats.intensity < info["intensity_threshold_db"])
    assert silent[35:55].all()
    assert np.all(track[31][31:60] == 0)
    for start, _ in info["raises"]:
        assert feats.voiced[start]
        assert feats.intensity[start] >= info["intensity_threshold_db"]
    assert 60 <= info["raises"][-1][0] <= 65  # speech resumes at 295 Hz, after 152 Hz


def test_raises_are_apart_by_the_minimum_gap():
    f0 = np.full(90, 150.0)
    for k in (10, 25, 40, 64):
        f0[k : k + 3] = 250.0
    intensity = np.where(np.isin(np.arange(90), [9, 10, 24, 25, 39, 40, 63, 64]), 70.0, 40.0)
    feats = SpeechFeatures(30.0, f0, intensity, f0.copy())
    thesis = make_condition("speech_driven", min_gap_s=0, **THESIS).generate(feats)
    assert thesis.metadata["eyebrows"]["raises"] == [[10, 19], [25, 34], [40, 49], [64, 73]]
    gapped = make_condition("speech_driven", **THESIS).generate(feats)  # 0.5 s = 15 frames
    assert gapped.metadata["eyebrows"]["raises"] == [[10, 19], [40, 49], [64, 73]]
    with pytest.raises(InputError, match="min_gap_s"):
        make_condition("speech_driven", min_gap_s=-1)
