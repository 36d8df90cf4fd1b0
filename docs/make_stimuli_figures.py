"""The stimuli's figures and their comparison with the thesis' Table 8.

    python docs/make_stimuli_figures.py

Generates the four conditions of the thesis on the demo speech with its (synthetic) ground
truth, prints a Table-8-style table (sd and mean of the inner and middle eyebrows in ENS and
of head pitch, yaw and roll in AU) next to the thesis' rows for S2 and S7, for experiment 1
(each condition's own amplitudes) and experiment 2 (--normalize: head angles scaled to the
ground truth), and writes docs/img/brow-raise.png: NO_PROSODY (left) and SPEECH_DRIVEN (right)
on the frame where the speech-driven raise is highest.

It also prints the share of time SPEECH_DRIVEN's brows are raised on the demo speech and the
three test voices (tests/stimuli/data/), next to the share Table 8 implies, and the live
model's variance above 4 Hz against the reference speaker's (docs/reference/live.md, "Figures").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.stimuli.generate import generate_conditions
from renderer import RenderSettings, render_still

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "img"
DEMO = ROOT / "app" / "data" / "demo"
#: Thesis Table 8 (experiment 1): (sd, mean) of inner eyebrow, middle eyebrow, pitch, yaw, roll.
TABLE_8 = {
    ("S2", "GROUND_TRUTH"): (
        (5.54, -2.38),
        (2.75, -0.96),
        (2803.69, -916.94),
        (3482.31, 5061.64),
        (1743.25, -1741.52),
    ),
    ("S2", "RANDOM"): (
        (11.60, 5.32),
        (11.60, 5.32),
        (3644.63, -961.85),
        (4431.30, -2260.03),
        (3052.26, -814.10),
    ),
    ("S2", "SPEECH_DRIVEN"): (
        (21.78, 15.10),
        (21.78, 15.10),
        (1441.66, -1544.10),
        (1573.01, 4613.23),
        (1039.17, -2722.44),
    ),
    ("S7", "GROUND_TRUTH"): (
        (17.05, 15.45),
        (6.51, 2.82),
        (1563.21, 491.78),
        (1560.67, -1843.58),
        (1589.00, -865.86),
    ),
    ("S7", "RANDOM"): (
        (13.47, 6.75),
        (13.47, 6.75),
        (3534.11, -1648.90),
        (4276.10, -1524.91),
        (3047.89, -92.81),
    ),
    ("S7", "SPEECH_DRIVEN"): (
        (17.18, 10.70),
        (17.18, 10.70),
        (666.93, 2034.31),
        (1049.36, -1823.35),
        (665.11, -1281.07),
    ),
}
CHANNELS = (31, 33, 48, 49, 50)


def _row(label: str, stats: tuple[tuple[float, float], ...]) -> str:
    return f"| {label} | " + " | ".join(f"{sd:.1f} / {mean:.1f}" for sd, mean in stats) + " |"


def table() -> str:
    """Markdown: the thesis' rows, then facepair's on the demo for experiments 1 and 2."""
    lines = [
        "| condition | inner eyebrow | middle eyebrow | head pitch | head yaw | head roll |",
        "|---|---|---|---|---|---|",
    ]
    for (subject, name), stats in TABLE_8.items():
        lines.append(_row(f"thesis {subject} {name}", stats))
    for normalize in (False, True):
        result = generate_conditions(
            DEMO / "speech.wav",
            ground_truth=DEMO / "ground_truth.fap",
            conditions=("random", "speech_driven", "ground_truth"),
            normalize=normalize,
            seed=1,
        )
        for track in result.tracks.values():
            stats = tuple((float(track[c].std()), float(track[c].mean())) for c in CHANNELS)
            label = f"facepair demo {track.name}" + (" (--normalize)" if normalize else "")
            lines.append(_row(label, stats))
    return "\n".join(lines)


VOICES = {
    "demo (126 Hz)": DEMO / "speech.wav",
    "low male (76 Hz)": ROOT / "tests" / "stimuli" / "data" / "low_male.wav",
    "high female (242 Hz)": ROOT / "tests" / "stimuli" / "data" / "high_female.wav",
    "fast (99 Hz, x1.6)": ROOT / "tests" / "stimuli" / "data" / "fast.wav",
}


def implied_share(sd: float, mean: float) -> float:
    """Share p of the time a pose is held, from its sd and mean: sd / mean = sqrt((1-p)/p)."""
    return 1.0 / (1.0 + (sd / mean) ** 2) if mean > 0 else 0.0


def raise_share_table() -> str:
    """Markdown: SPEECH_DRIVEN inner eyebrow on each voice against Table 8."""
    from app.stimuli.conditions import make_condition
    from app.stimuli.speech import extract_features

    lines = [
        "| voice | raises | sd / mean | share implied by sd / mean | frames raised |",
        "|---|---|---|---|---|",
    ]
    for subject in ("S2", "S7"):
        sd, mean = TABLE_8[(subject, "SPEECH_DRIVEN")][0]
        lines.append(
            f"| thesis {subject} (Table 8) | | {sd:.1f} / {mean:.1f} | "
            f"{implied_share(sd, mean):.2f} | |"
        )
    for label, path in VOICES.items():
        track = make_condition("speech_driven").generate(extract_features(path, 30.0))
        brow = track[31]
        sd, mean = float(brow.std()), float(brow.mean())
        lines.append(
            f"| {label} | {track.metadata['eyebrows']['n_raises']} | {sd:.1f} / {mean:.1f} | "
            f"{implied_share(sd, mean):.2f} | {np.mean(brow > 0):.2f} |"
        )
    return "\n".join(lines)


def live_jitter_table(repeat: int = 30, seeds: int = 3) -> str:
    """Markdown: the default live model on the demo sentence played ``repeat`` times, against
    the reference speaker (seed 123): sd and the share of variance above 4 Hz per channel."""
    from app.stimuli.live.condition import DEFAULT_MODEL_PATH
    from app.stimuli.live.evaluation import CHANNELS, high_frequency_fraction, motion_channels
    from app.stimuli.live.modelfile import load_model
    from app.stimuli.live.stream import generate_track
    from app.stimuli.reference_speaker import synthesize_reference
    from app.stimuli.speech import SpeechFeatures, extract_features

    f = extract_features(DEMO / "speech.wav", 30.0)
    feats = SpeechFeatures(
        f.fps,
        np.tile(f.f0, repeat),
        np.tile(f.intensity, repeat),
        np.tile(f.f0_conditioned, repeat),
    )
    ref = motion_channels(synthesize_reference(feats, seed=123))
    model = load_model(DEFAULT_MODEL_PATH)
    gens = [motion_channels(generate_track(model, feats, seed=s)) for s in range(seeds)]
    lines = [
        "| channel | sd (deg) | reference | > 4 Hz | reference | ratio |",
        "|---|---|---|---|---|---|",
    ]
    for i, name in enumerate(CHANNELS):
        hf = float(np.mean([high_frequency_fraction(g[:, i], 30.0) for g in gens]))
        hf_ref = high_frequency_fraction(ref[:, i], 30.0)
        sd = float(np.mean([g[:, i].std() for g in gens]))
        lines.append(
            f"| {name} | {sd:.2f} | {ref[:, i].std():.2f} | {hf:.3f} | {hf_ref:.3f} | "
            f"{hf / hf_ref:.2f} |"
        )
    return "\n".join(lines)


def brow_raise_still() -> Path:
    result = generate_conditions(DEMO / "speech.wav", conditions=("none", "speech_driven"))
    frame = int(np.argmax(result.tracks["speech_driven"][31]))
    return render_still(
        result.tracks["none"],
        frame,
        OUT / "brow-raise.png",
        right=result.tracks["speech_driven"],
        settings=RenderSettings(),
    )


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    print("sd / mean: eyebrows in ENS units, head in AU (1e-5 rad)")
    print(table())
    print("\nSPEECH_DRIVEN inner eyebrow, raise-time share")
    print(raise_share_table())
    print("\nlive_gmm (default model) against the reference speaker, demo x 30, 3 seeds")
    print(live_jitter_table())
    print(brow_raise_still())


if __name__ == "__main__":
    main()
