"""The audio check's sounds (``app.stimuli.headphones``): the Huggins pitch inverts the phase
between the ears only inside its band; the antiphase test's tones have the levels and
polarities Woods et al. (2017) describe; the WAV files read back."""

from __future__ import annotations

import doctest
import io
import wave

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.stimuli import headphones
from app.stimuli.headphones import (
    HUGGINS_BANDWIDTH,
    HUGGINS_CENTRE_HZ,
    RATE,
    antiphase_interval,
    huggins_interval,
    targets,
    three_intervals,
    wav_bytes,
)


def test_doctests() -> None:
    assert doctest.testmod(headphones).failed == 0


def test_huggins_pitch_inverts_the_phase_between_the_ears_only_inside_its_band() -> None:
    sound = huggins_interval(np.random.default_rng(3), pitch=True)
    left, right = np.fft.rfft(sound[:, 0]), np.fft.rfft(sound[:, 1])
    frequencies = np.fft.rfftfreq(len(sound), 1.0 / RATE)
    half = HUGGINS_CENTRE_HZ * HUGGINS_BANDWIDTH / 2
    inside = np.abs(frequencies - HUGGINS_CENTRE_HZ) <= half
    # Bins at the band's edges are left out: the boundary bin may fall either side.
    outside = np.abs(frequencies - HUGGINS_CENTRE_HZ) > half + 2
    phase = np.angle(right * np.conj(left))  # interaural phase difference per bin
    assert inside.sum() >= 30
    assert np.allclose(np.abs(phase[inside]), np.pi, atol=1e-6)
    assert np.allclose(phase[outside & (np.abs(left) > 1e-9)], 0.0, atol=1e-6)
    # The same noise in both ears (equal magnitudes), at the level the check plays.
    assert np.allclose(np.abs(left), np.abs(right))
    assert np.sqrt(np.mean(sound**2)) == pytest.approx(headphones.LEVEL_RMS)


def test_plain_noise_is_the_same_in_both_ears() -> None:
    sound = huggins_interval(np.random.default_rng(4), pitch=False)
    assert np.array_equal(sound[:, 0], sound[:, 1])


def test_antiphase_tones_have_their_levels_and_polarities() -> None:
    full, quiet = antiphase_interval(), antiphase_interval(quieter=True)
    inverted = antiphase_interval(antiphase=True)
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    assert 20 * np.log10(rms(quiet) / rms(full)) == pytest.approx(-6.0, abs=1e-9)
    assert rms(inverted) == pytest.approx(rms(full))
    assert np.allclose(inverted[:, 0], -inverted[:, 1]) and np.allclose(full[:, 0], full[:, 1])
    # Played through one loudspeaker (the channels summed), the antiphase tone vanishes.
    assert rms(inverted.sum(axis=1)) < 1e-12 < rms(quiet.sum(axis=1))
    spectrum = np.abs(np.fft.rfft(full[:, 0]))
    assert np.fft.rfftfreq(len(full), 1.0 / RATE)[spectrum.argmax()] == pytest.approx(200.0)


@pytest.mark.parametrize("kind", ["huggins", "antiphase"])
@pytest.mark.parametrize("target", [0, 1, 2])
def test_the_target_is_the_interval_to_choose(kind: str, target: int) -> None:
    sound = three_intervals(kind, target=target, rng=np.random.default_rng(target))
    step = int(1.5 * RATE)
    parts = [sound[i * step : i * step + RATE] for i in range(3)]
    # Inside the ramps: the steady part of each interval.
    core = [p[RATE // 10 : -RATE // 10] for p in parts]
    if kind == "huggins":
        different = [not np.allclose(c[:, 0], c[:, 1]) for c in core]
    else:
        level = [np.sqrt(np.mean(c[:, 0] ** 2)) for c in core]
        different = [lv == min(level) for lv in level]
    assert different == [i == target for i in range(3)]
    assert np.abs(sound).max() <= 1.0
    assert np.all(sound[RATE : RATE + RATE // 2] == 0)  # the silence between intervals


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**63 - 1), trials=st.integers(1, 20))
def test_targets_are_balanced_and_reproducible(seed: int, trials: int) -> None:
    drawn = targets(seed, trials)
    assert drawn == targets(seed, trials)
    counts = [drawn.count(i) for i in range(3)]
    assert max(counts) - min(counts) <= 1 and len(drawn) == trials


def test_bad_arguments_say_which() -> None:
    with pytest.raises(ValueError, match="kind: expected one of huggins, antiphase"):
        three_intervals("beep", target=0, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="target: expected 0, 1 or 2"):
        three_intervals("huggins", target=3, rng=np.random.default_rng(0))


def test_the_wav_file_reads_back() -> None:
    sound = three_intervals("antiphase", target=1, rng=np.random.default_rng(0))
    with wave.open(io.BytesIO(wav_bytes(sound))) as wav:
        assert (wav.getnchannels(), wav.getsampwidth(), wav.getframerate()) == (2, 2, RATE)
        frames = np.frombuffer(wav.readframes(wav.getnframes()), "<i2").reshape(-1, 2)
    assert np.allclose(frames / 32767, sound, atol=1 / 32767)
