"""Fixtures of the stimuli tests: synthetic speech (harmonic glides, WAV files), the demo
speech, and the live generator's synthetic speaker with known couplings."""

from __future__ import annotations

from pathlib import Path

import pytest


def harmonic_glide(
    f_start: float,
    f_end: float,
    seconds: float,
    sr: int = 16000,
    amplitude: float = 0.2,
    n_harmonics: int = 5,
):
    """A voiced-like harmonic signal whose F0 glides linearly; returns (samples, f0 of time)."""
    import numpy as np

    t = np.arange(round(seconds * sr)) / sr
    slope = (f_end - f_start) / seconds
    phase = 2 * np.pi * (f_start * t + 0.5 * slope * t * t)
    x = sum(np.sin(k * phase) / k for k in range(1, n_harmonics + 1))
    x = amplitude * x / np.max(np.abs(x))
    return x, (lambda tt: f_start + slope * np.asarray(tt))


def write_wav(path, samples, sr: int = 16000, *, channels: int = 1) -> None:
    """Write float samples in [-1, 1] as 16-bit PCM; ``samples`` may be (n,) or (n, channels)."""
    import wave

    import numpy as np

    data = np.asarray(samples, dtype=np.float64)
    ints = np.round(np.clip(data, -1, 1) * 32767).astype("<i2")
    with wave.open(str(path), "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(2)
        w.setframerate(sr)
        w.writeframes(ints.tobytes())


@pytest.fixture
def demo_wav(repo_root: Path) -> Path:
    return repo_root / "app" / "data" / "demo" / "speech.wav"


# The live head-and-eye generator (app/stimuli/live).


def live_synthetic_speaker(
    n_frames: int = 3000,
    fps: float = 30.0,
    seed: int = 0,
    blink_params: tuple[tuple[float, float], tuple[float, float]] = ((0.6, 0.4), (1.3, 0.3)),
):
    """Synthetic speech features and a ground-truth track with KNOWN couplings, for the live
    model's tests: talk spurts and pauses; head pitch follows F0 and yaw follows loudness
    (smoothed, plus noise); gaze follows head yaw and loudness; the lids follow gaze pitch; blink
    intervals are log-normal with ``blink_params`` (mu, sigma) for (talking, listening)."""
    import numpy as np
    from scipy.ndimage import gaussian_filter1d

    from app.stimuli.live.eyelids import blink_closure
    from app.stimuli.live.inputs import talking_mode
    from app.stimuli.speech import SpeechFeatures
    from app.stimuli.track import MotionTrack

    rng = np.random.default_rng(seed)
    n = n_frames
    talk = np.zeros(n, bool)
    t = 0
    while t < n:  # alternating talk spurts (2-6 s) and pauses (1-3 s)
        spurt = int(rng.uniform(2, 6) * fps)
        talk[t : t + spurt] = True
        t += spurt + int(rng.uniform(1, 3) * fps)
    syll = np.sin(2 * np.pi * np.arange(n) / fps * 4.0 + rng.uniform(0, 6)) > -0.3
    voiced = talk & syll
    contour = 150 * 2 ** (gaussian_filter1d(rng.normal(0, 1, n), 8) * 2.0 / 12 * 3)
    f0 = np.where(voiced, contour, 0.0)
    intensity = np.where(
        talk, 62 + 6 * syll + gaussian_filter1d(rng.normal(0, 3, n), 2), 25 + rng.normal(0, 2, n)
    )
    st = 12 * np.log2(np.maximum(contour, 1) / 150)
    drive_p = gaussian_filter1d(np.where(voiced, st, 0.0), 3)
    drive_l = gaussian_filter1d((intensity - 45) / 20, 5)
    pitch_deg = -1.5 * drive_p + gaussian_filter1d(rng.normal(0, 1.2, n), 6)
    yaw_deg = 6 * drive_l + gaussian_filter1d(rng.normal(0, 1.5, n), 10)
    roll_deg = 0.5 * drive_p + gaussian_filter1d(rng.normal(0, 0.8, n), 8)
    gaze_yaw = -0.6 * yaw_deg + 3 * drive_l + gaussian_filter1d(rng.normal(0, 1.0, n), 3)
    gaze_pitch = 0.4 * pitch_deg + gaussian_filter1d(rng.normal(0, 1.0, n), 3)
    openness = 0.9 - 0.02 * gaze_pitch
    mode = talking_mode(intensity, 42.0, fps)
    closure = np.zeros(n)
    onset = rng.uniform(0, 2.0)
    times = np.arange(n) / fps
    while onset < n / fps:
        closure = np.maximum(closure, blink_closure(times - onset))
        mu, sigma = blink_params[0 if mode[min(int(np.ceil(onset * fps)), n - 1)] else 1]
        onset += float(np.exp(mu + sigma * rng.standard_normal()))
    total = (1 - openness * (1 - closure)) * 1024
    au = np.pi / 180 / 1e-5
    cols = {
        48: pitch_deg * au,
        49: yaw_deg * au,
        50: roll_deg * au,
        23: gaze_yaw * au,
        24: gaze_yaw * au,
        25: gaze_pitch * au,
        26: gaze_pitch * au,
        19: 0.8 * total,
        20: 0.8 * total,
        21: 0.2 * total,
        22: 0.2 * total,
    }
    features = SpeechFeatures(fps, f0, intensity, np.where(voiced, f0, 150.0), {})
    track = MotionTrack.from_channels(fps, cols).replace(name="synthetic", source="synthetic")
    return features, track


@pytest.fixture(scope="session")
def live_training_data():
    """(features, ground truth) of the synthetic live speaker, 100 s at 30 fps."""
    return live_synthetic_speaker(3000, 30.0, seed=1)


@pytest.fixture(scope="session")
def live_held_out_speech():
    """Other speech of the synthetic live speaker (100 s): for held-out tests."""
    return live_synthetic_speaker(3000, 30.0, seed=7)[0]


@pytest.fixture(scope="session")
def live_model(live_training_data):
    """A live model trained on :func:`live_training_data` (session-wide: EM takes seconds)."""
    from app.stimuli.live.model import train_live_model

    return train_live_model(*live_training_data, seed=0)
