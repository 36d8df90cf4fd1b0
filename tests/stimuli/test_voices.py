"""The eyebrow rule on varied voices: the share of time the brows are raised is thesis-like.

The voices (tests/stimuli/data/, made by ``make_voices.sh`` with espeak-ng and sox): a low male
(median F0 about 76 Hz), a high female (about 240 Hz) and a fast mid-pitched voice (about 1.6
times the normal rate), 6 s each, plus the demo speech. Thesis Table 8 gives SPEECH_DRIVEN's
inner eyebrows mean 15.10 / sd 21.78 (S2) and 10.70 / 17.18 (S7); a pose held a share p of the
time has sd / mean = sqrt((1 - p) / p), so the thesis' brows were raised p = 0.32 and 0.28 of
the time. The same estimate is taken from each generated track.
"""

from pathlib import Path

import numpy as np
import pytest

from app.stimuli.conditions import make_condition
from app.stimuli.speech import extract_features

DATA = Path(__file__).parent / "data"
VOICES = ("low_male", "high_female", "fast")
#: Table 8, SPEECH_DRIVEN inner eyebrow (mean, sd) of S2 and S7.
TABLE_8 = {"S2": (15.10, 21.78), "S7": (10.70, 17.18)}


def implied_share(mean: float, sd: float) -> float:
    """Share of time a held pose is present, from its mean and sd: 1 / (1 + (sd / mean)^2)."""
    return 1.0 / (1.0 + (sd / mean) ** 2) if mean > 0 else 0.0


def test_table_8_implies_28_to_33_percent():
    shares = [implied_share(*TABLE_8[s]) for s in ("S2", "S7")]
    assert [round(x, 2) for x in shares] == [0.32, 0.28]


@pytest.mark.parametrize("voice", VOICES)
def test_voices_are_what_their_names_say(voice):
    feats = extract_features(DATA / f"{voice}.wav", 30.0)
    median = float(np.median(feats.f0[feats.voiced]))
    assert {"low_male": 65 < median < 90, "high_female": 200 < median < 300}.get(voice, True)
    assert feats.metadata["duration"] == pytest.approx(6.0)


@pytest.mark.parametrize("voice", [*VOICES, "demo"])
def test_brows_are_raised_a_thesis_like_share_of_the_time(voice, demo_wav):
    path = demo_wav if voice == "demo" else DATA / f"{voice}.wav"
    feats = extract_features(path, 30.0)
    brow = make_condition("speech_driven").generate(feats)[31]
    share = implied_share(float(brow.mean()), float(brow.std()))
    assert 0.25 <= share <= 0.36, share  # Table 8: 0.28-0.33
    assert 0.25 <= float(np.mean(brow > 0)) <= 0.40  # frames with any raise, ramps included
    assert 6 <= brow.mean() <= 16 and 12 <= brow.std() <= 22  # Table 8: 10.7-15.1, 17.2-21.8


def test_a_fixed_pitch_range_that_misses_the_speaker_gives_way_to_the_speakers():
    """A 75 Hz voice analysed with a fixed 75-600 Hz range: short voiced stretches between
    pauses read at 4-5 times the voice's F0, which fired extra, oversized raises. The range
    now follows the speaker (a quarter of the voice lies below 75 Hz), and says so."""
    path = DATA / "low_male.wav"
    fixed = extract_features(path, 30.0, pitch_floor=75.0, pitch_ceiling=600.0)
    estimated = extract_features(path, 30.0)
    voiced = fixed.f0[fixed.voiced]
    assert fixed.metadata["pitch_range"].startswith(
        "two-pass estimate: the given 75-600 Hz does not hold this speaker (median 7"
    )
    assert voiced.max() < 2**0.6 * np.median(voiced)
    # a range that holds the speaker is kept as given
    kept = extract_features(path, 30.0, pitch_floor=50.0, pitch_ceiling=300.0)
    assert kept.metadata["pitch_range"] == "given"
    rule = make_condition("speech_driven")
    raises = [rule.generate(f).metadata["eyebrows"] for f in (fixed, estimated)]
    assert raises[0]["n_raises"] == raises[1]["n_raises"]
    assert max(raises[0]["raise_sizes"]) < 45


# -- ten voices the rule never saw, 20 s and more (tests/stimuli/voices.py) ----------------------


@pytest.fixture(scope="module")
def unseen(tmp_path_factory):
    from tests.stimuli.voices import VOICES, require_voices, synthesize

    require_voices()
    folder = tmp_path_factory.mktemp("voices")
    return {name: extract_features(synthesize(name, folder), 30.0) for name in VOICES}


def test_the_unseen_voices_differ_in_pitch_rate_and_length(unseen):
    assert len(unseen) >= 8
    medians = {n: float(np.median(f.f0[f.voiced])) for n, f in unseen.items()}
    assert medians["bass"] < 70 and medians["high_female"] > 200 and medians["festival_hts"] > 140
    assert all(f.metadata["duration"] >= 20.0 for f in unseen.values())


@pytest.mark.parametrize(
    "voice",
    [
        "bass",
        "low_male",
        "high_female",
        "fast",
        "slow",
        "french",
        "german",
        "spanish",
        "festival_hts",
        "festival_diphone",
    ],
)
def test_brows_are_raised_a_thesis_like_share_on_every_unseen_voice(unseen, voice):
    """With a fixed 75th percentile threshold, five of these voices held the brows up less
    than a fifth of the time (slow speech 0.13); calibrated to Table 8's share, all are within
    0.20-0.40."""
    brow = make_condition("speech_driven").generate(unseen[voice])[31]
    assert 0.20 <= implied_share(float(brow.mean()), float(brow.std())) <= 0.40
    assert 0.20 <= float(np.mean(brow > 0)) <= 0.40


def test_the_thesis_literal_rule_fires_no_raise_on_most_voices(unseen):
    """207 Hz and 45 dB: no raise on 7 of the 10, high voices included (their F0 stays above
    207 Hz, so it never rises across it), as docs/reference/stimuli.md says."""
    literal = {"f0_threshold": 207, "intensity_threshold": 45, "min_gap_s": 0}
    silent = [
        n
        for n, f in unseen.items()
        if make_condition("speech_driven", **literal).eyebrows(f)[1]["n_raises"] == 0
    ]
    assert len(silent) >= 6 and "high_female" in silent


def test_a_bass_voice_keeps_its_pitch_in_a_range_that_does_not_hold_it(unseen, tmp_path):
    """A 60 Hz bass analysed over the thesis' 75-600 Hz read as 370-540 Hz in places and fired
    raises at 207 Hz; the range now follows the speaker and says so."""
    from tests.stimuli.voices import synthesize

    path = synthesize("bass", tmp_path)
    feats = extract_features(path, 30.0, pitch_floor=75.0, pitch_ceiling=600.0)
    assert feats.metadata["pitch_range"].startswith(
        "two-pass estimate: the given 75-600 Hz does not hold this speaker"
    )
    assert feats.f0[feats.voiced].max() < 120.0
    info = make_condition("speech_driven", f0_threshold=207).eyebrows(feats)[1]
    assert info["n_raises"] == 0
