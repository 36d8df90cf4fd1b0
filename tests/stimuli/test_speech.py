import struct

import numpy as np
import parselmouth
import pytest

from app.errors import InputError
from app.stimuli.speech import (
    condition_f0,
    extract_features,
    features_from_samples,
    load_audio,
    loudness_sones,
    mean_filter,
    smooth_1s,
)
from tests.stimuli.conftest import harmonic_glide, write_wav


def test_f0_follows_a_known_glide_within_2_hz(tmp_path):
    x, f0_of = harmonic_glide(120.0, 220.0, 3.0)
    write_wav(tmp_path / "glide.wav", x)
    feats = extract_features(tmp_path / "glide.wav", fps=30)
    assert feats.n_frames == 90
    inner = slice(3, -3)  # the analysis window straddles the ends
    truth = f0_of(np.arange(90) / 30)[inner]
    assert feats.voiced[inner].all()
    assert np.max(np.abs(feats.f0[inner] - truth)) < 2.0


def test_intensity_of_a_known_sine():
    sr = 16000
    t = np.arange(2 * sr) / sr
    feats = features_from_samples(0.2 * np.sin(2 * np.pi * 200 * t), sr, fps=25)
    expected = 20 * np.log10(0.2 / np.sqrt(2) / 2e-5)  # dB re 2e-5 Pa, samples as pascals
    np.testing.assert_allclose(feats.intensity[3:-3], expected, atol=0.3)


@pytest.mark.parametrize("fps,seconds,frames", [(30, 2.5, 75), (25, 1.0, 25), (24, 1.5, 36)])
def test_exactly_round_duration_times_fps_frames(fps, seconds, frames):
    x, _ = harmonic_glide(150, 160, seconds)
    feats = features_from_samples(x, 16000, fps=fps)
    assert feats.n_frames == frames == round(seconds * fps)
    assert len(feats.intensity) == len(feats.f0_conditioned) == frames


def test_conditioning_reproduces_a_cubic_through_gaps():
    frames = np.arange(40, dtype=float)
    cubic = 150 + 2 * frames - 0.1 * frames**2 + 0.002 * frames**3
    f0 = cubic.copy()
    f0[[5, 6, 7, 20, 21, 30]] = 0  # unvoiced gaps inside the voiced span
    out = condition_f0(f0)
    inner = slice(0, 40)
    np.testing.assert_allclose(out[inner], np.minimum(cubic, f0.max())[inner], atol=1e-9)


def test_conditioning_clips_to_zero_and_max_and_holds_edges():
    f0 = np.array([0, 0, 100, 200, 0, 0, 0, 0, 200, 100, 0, 0.0])
    out = condition_f0(f0)
    assert out.max() <= 200 and out.min() >= 0
    assert out[4:8].max() == 200  # the spline overshoots between the two peaks: clipped
    assert out[0] == out[1] == 100 and out[-1] == out[-2] == 100
    assert np.all(condition_f0(np.zeros(5)) == 0)
    assert np.all(condition_f0(np.array([0, 130.0, 0])) == 130)


def test_mean_filters():
    x = np.zeros(10)
    x[5] = 3.0
    np.testing.assert_allclose(mean_filter(x, 3)[4:7], 1.0)
    assert mean_filter(x, 3)[[3, 7]].tolist() == [0, 0]
    causal = mean_filter(x, 3, causal=True)
    np.testing.assert_allclose(causal[5:8], 1.0)
    assert causal[4] == 0 and causal[8] == 0
    ramp = np.arange(100.0)
    np.testing.assert_allclose(smooth_1s(ramp, 30)[20:80], ramp[20:80] - 0.5)
    assert loudness_sones(np.array([60.0]))[0] == 4.0


def test_load_audio_mixes_stereo_to_mono(tmp_path):
    sr = 16000
    left = 0.4 * np.sin(2 * np.pi * 200 * np.arange(sr) / sr)
    write_wav(tmp_path / "st.wav", np.stack([left, np.zeros(sr)], axis=1), sr, channels=2)
    samples, rate = load_audio(tmp_path / "st.wav")
    assert rate == sr and samples.ndim == 1 and len(samples) == sr
    np.testing.assert_allclose(samples, left / 2, atol=1e-4)
    feats = extract_features(tmp_path / "st.wav")
    assert feats.metadata["mixed_to_mono"] is True and feats.metadata["channels"] == 2


def test_flac_is_read(tmp_path):
    x, _ = harmonic_glide(150, 150, 1.0)
    parselmouth.Sound(x, 16000.0).save(str(tmp_path / "a.flac"), "FLAC")
    samples, rate = load_audio(tmp_path / "a.flac")
    assert rate == 16000 and len(samples) == 16000
    np.testing.assert_allclose(samples, x, atol=1e-4)


def _wav_with_width(path, bits, align):
    data = b"\x00\x01" * 4000
    fmt = struct.pack("<IHHIIHH", 16, 1, 1, 16000, 16000 * align, align, bits)
    path.write_bytes(
        b"RIFF"
        + struct.pack("<I", 36 + len(data))
        + b"WAVEfmt "
        + fmt
        + b"data"
        + struct.pack("<I", len(data))
        + data
    )


@pytest.mark.parametrize(
    "case,expected",
    [
        ("text", "not a recognised audio file"),
        ("empty", "empty file"),
        ("silence", "all silence"),
        ("long", "limit is 1 s"),
        ("short", "at least 100 ms"),
        ("width40", "unsupported WAV sample width: 40 bits"),
        ("width0", "unsupported WAV sample width: 0 bits"),
        ("truncated", "WAV"),
        ("missing", "no such audio file"),
    ],
)
def test_bad_audio_gives_one_line_naming_the_file(tmp_path, case, expected):
    path = tmp_path / f"{case}.wav"
    if case == "text":
        path.write_text("this is not audio\n" * 50)
    elif case == "empty":
        path.write_bytes(b"")
    elif case == "silence":
        write_wav(path, np.zeros(16000))
    elif case in ("long", "short"):
        x, _ = harmonic_glide(150, 150, 2.0 if case == "long" else 0.05)
        write_wav(path, x)
    elif case == "width40":
        _wav_with_width(path, 40, 5)
    elif case == "width0":
        _wav_with_width(path, 0, 2)
    elif case == "truncated":
        write_wav(path, harmonic_glide(150, 150, 1.0)[0])
        path.write_bytes(path.read_bytes()[:30])
    with pytest.raises(InputError) as err:
        extract_features(path, max_duration=1.0)
    message = str(err.value)
    assert "\n" not in message and str(path) in message and expected in message


def test_twelve_bit_in_sixteen_bit_container_is_accepted(tmp_path):
    _wav_with_width(tmp_path / "w12.wav", 12, 2)
    samples, _ = load_audio(tmp_path / "w12.wav")
    assert len(samples) == 4000


def test_bad_parameters():
    with pytest.raises(InputError, match="pitch floor"):
        extract_features("x.wav", pitch_floor=300, pitch_ceiling=100)
    with pytest.raises(InputError, match="pitch_ceiling"):
        extract_features("x.wav", pitch_ceiling=-5)


def test_demo_speech_is_real_speech(demo_wav):
    feats = extract_features(demo_wav, pitch_ceiling=300)
    assert feats.n_frames == 120 and 0.3 < feats.voiced.mean() < 0.9
    assert 80 < np.median(feats.f0[feats.voiced]) < 200


def test_two_pass_range_brackets_a_known_voice():
    x, _ = harmonic_glide(110.0, 150.0, 2.0)
    feats = features_from_samples(x, 16000, fps=30)
    q25, q75 = np.percentile(feats.f0[feats.voiced], [25, 75])
    assert feats.metadata["pitch_range"].startswith("two-pass")
    assert abs(feats.metadata["pitch_floor"] - 0.75 * q25) < 3
    assert abs(feats.metadata["pitch_ceiling"] - 1.5 * q75) < 5


def test_demo_speaker_has_no_octave_error_left(demo_wav):
    feats = extract_features(demo_wav)
    voiced = feats.f0[feats.voiced]
    assert voiced.max() < 2 * np.median(voiced)  # the 371 Hz frame of a 126 Hz voice is gone
    assert 80 < feats.metadata["pitch_floor"] < 100 < 180 < feats.metadata["pitch_ceiling"]


@pytest.mark.parametrize(("start", "end"), [(80.0, 400.0), (400.0, 80.0), (60.0, 250.0)])
def test_the_pitch_range_follows_a_glide_to_its_ends(start, end):
    """The quartiles alone (0.75 q25 to 1.5 q75) cut a glide's lowest fifth: its first 1.5 s
    went unvoiced. The range now reaches the first pass's extremes (bounded), and F0 follows
    the glide everywhere with no octave error."""
    from app.stimuli.speech import features_from_samples

    x, truth = harmonic_glide(start, end, 10.0)
    feats = features_from_samples(x, 16000, 30.0)
    t = np.arange(feats.n_frames) / 30.0
    assert feats.voiced.mean() > 0.97
    error = np.abs(np.log2(feats.f0[feats.voiced] / truth(t[feats.voiced])))
    assert np.percentile(error, 99) < 0.05 and error.max() < 0.3
