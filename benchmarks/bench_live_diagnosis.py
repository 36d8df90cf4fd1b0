"""Why the live head did not follow the speech: the diagnosis, step by step, with figures.

On the held-out split of ``bench_live_heldout.py`` (3 training takes in the training voices, 4
test takes in others, ``--seconds`` each; the voices mixed within a take) and, for step (b), on
takes of one held-out voice each, for the reference speaker's versions 1 and 2:

- (a) the data: the share of each head angle's variance that the reference speaker's speech
  drives (:func:`app.stimuli.reference_speaker.head_speech_part`); the held-out correlation of
  that part with the truth (the ceiling of any speech-driven model) and its square (the ceiling
  of a generator with the truth's amplitude); the first canonical correlation between the head
  angles and the model's own inputs (standardised pitch, loudness, voicing) with the speech
  leading by 0-30 frames;
- (b) normalisation: the held-out r of a least-squares predictor from the model's inputs with
  the training scale for every speaker against per-take z-scores and the causal per-speaker
  normalisation, on mixed-voice takes and on one-voice takes;
- (c) the GMMs' conditioning: the held-out r of the angle mixtures' conditional expectation with
  the truth and with the reference's speech-driven part;
- (d) the synthesis: r with the truth, r with the mixtures' expectation and the sd ratio of the
  generated head for the Langevin draw (the code before, and without eq. 5's start noise,
  without the speed and acceleration terms), for the paper's climb to the local maximum (17
  backtracking gradient steps from eq. 5's start), and for the expectation synthesis.

    PYTHONPATH=$PWD python benchmarks/bench_live_diagnosis.py [--seconds 120] [--versions 1,2]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
ORDER = ("pitch", "yaw", "roll")


def _r(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([np.corrcoef(a[:, i], b[:, i])[0, 1] for i in range(a.shape[1])])


def _row(label: str, values) -> str:
    return f"  {label:<52} " + " / ".join(f"{v:+.2f}" for v in values)


def _climb(head, start, prev1, prev2, fps, frame, n_iter=17):
    """The paper's search: gradient ascent on J from eq. 5's start, steps preconditioned by
    sigma^2 per axis and backtracked (grown x1.5 after a success, x0.3 after a failure)."""
    m = (head.step_std / fps) ** 2
    theta = start
    f, g = head.objective(theta, prev1, prev2, fps, frame)
    step = 1.0
    for _ in range(n_iter):
        cand = theta + step * m * g
        fc, gc = head.objective(cand, prev1, prev2, fps, frame)
        if fc > f:
            theta, f, g, step = cand, fc, gc, min(step * 1.5, 4.0)
        else:
            step *= 0.3
    return theta


def _sample_path(head, pz, lz, fps, seed, *, start_noise=True, climb=False):
    """(n, 3) yaw, pitch, roll drawn (or climbed) frame by frame as the Langevin generator
    does, without the shown-pose low-pass."""
    rng = np.random.default_rng(seed)
    prev1 = prev2 = head.kin_mean[:3].copy()
    noise = head.step_std / fps
    out = np.empty((len(pz), 3))
    for t in range(len(pz)):
        frame = head.frame_coefficients(pz[t], lz[t])
        start = prev1 + (noise * rng.standard_normal(3) if start_noise else 0.0)
        if climb:
            theta = _climb(head, start, prev1, prev2, fps, frame)
        else:
            theta = head.sample(start, prev1, prev2, fps, frame, rng)
        prev2, prev1 = prev1, theta
        out[t] = theta
    return out


def diagnose(sound, version: int, args: argparse.Namespace) -> None:
    """Print steps (a)-(d) for one version of the reference speaker."""
    from app.stimuli.live.evaluation import head_pose, held_out_split, speaker_split
    from app.stimuli.live.expectation import expectations
    from app.stimuli.live.inputs import SpeechScale, smoothed_inputs, speaker_normalised
    from app.stimuli.live.model import train_live_model
    from app.stimuli.live.stream import generate_track
    from app.stimuli.measures import canonical_correlations
    from app.stimuli.reference_speaker import head_speech_part

    split = held_out_split(sound, seconds=args.seconds, reference_version=version)
    voices = speaker_split(
        sound,
        takes_per_voice=2,
        seconds=60.0,
        train_seconds=args.seconds,
        reference_version=version,
    )
    fps = split.train[0][0].fps
    print(f"\n## reference speaker v{version} (pitch / yaw / roll)")

    def speech_part(feats) -> np.ndarray:
        p = head_speech_part(feats, version=version)
        return np.column_stack([p[48], p[49], p[50]]) * 1e-5 * 180 / np.pi

    # (a) the data
    takes = split.train + split.test
    sd_speech = np.mean([speech_part(f).std(axis=0) for f, _ in takes], axis=0)
    sd_all = np.mean([head_pose(t).std(axis=0) for _, t in takes], axis=0)
    ceiling = np.mean([_r(speech_part(f), head_pose(t)) for f, t in split.test], axis=0)
    print("(a) the training data's own speech-motion relation")
    print(_row("sd of the speech-driven part (deg)", sd_speech))
    print(_row("sd of the whole head (deg)", sd_all))
    print(_row("share of the variance driven by speech", (sd_speech / sd_all) ** 2))
    print(_row("held-out r of the speech-driven part (ceiling)", ceiling))
    print(_row("its square (ceiling at the truth's amplitude)", ceiling**2))
    contours = [smoothed_inputs(f.f0, f.intensity, fps) for f, _ in split.train]
    scale = SpeechScale.fit_contours(
        np.concatenate([p for p, _ in contours]), np.concatenate([lo for _, lo in contours])
    )

    def inputs(feats, norm_s=0.0, per_take=False) -> np.ndarray:
        p, lo = smoothed_inputs(feats.f0, feats.intensity, fps)
        if per_take:
            pz = (p - np.nanmean(p)) / np.nanstd(p)
            lz = (lo - lo.mean()) / lo.std()
        else:
            pz, lz = speaker_normalised(p, lo, scale, fps, norm_s)
        voiced = np.isfinite(pz)
        return np.column_stack([np.where(voiced, pz, 0.0), lz, voiced])

    lags = (0, 5, 10, 20, 30)
    cc = [
        np.mean(
            [
                canonical_correlations(head_pose(t)[k:], inputs(f)[: f.n_frames - k])[0]
                for f, t in split.test
            ]
        )
        for k in lags
    ]
    print(
        "  first canonical correlation, head vs the model's inputs, speech leading by "
        + ", ".join(f"{k}: {c:.2f}" for k, c in zip(lags, cc, strict=True))
        + " frames"
    )

    # (b) normalisation
    def predictor_r(data, make) -> np.ndarray:
        x = np.vstack([make(f) for f, _ in data.train])
        y = np.vstack([head_pose(t) for _, t in data.train])
        design = np.column_stack([x, np.ones(len(x))])
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        return np.mean(
            [
                _r(np.column_stack([make(f), np.ones(f.n_frames)]) @ coef, head_pose(t))
                for f, t in data.test
            ],
            axis=0,
        )

    print("(b) normalisation: held-out r of a least-squares predictor from the inputs")
    for label, data in (("mixed voices", split), ("one held-out voice a take", voices)):
        print(_row(f"{label}: training scale for every speaker", predictor_r(data, inputs)))
        print(
            _row(
                f"{label}: per-take z-scores (not causal)",
                predictor_r(data, lambda f: inputs(f, per_take=True)),
            )
        )
        print(
            _row(
                f"{label}: per-speaker, causal (30 s)",
                predictor_r(data, lambda f: inputs(f, norm_s=30.0)),
            )
        )

    # (c) the GMMs' conditioning
    before = train_live_model(
        [f for f, _ in split.train], [t for _, t in split.train], speaker_norm_s=0
    )
    after = train_live_model([f for f, _ in split.train], [t for _, t in split.train])

    def expect(model, feats) -> np.ndarray:
        p, lo = smoothed_inputs(feats.f0, feats.intensity, fps)
        pz, lz = speaker_normalised(p, lo, model.scale, fps, model.speaker_norm_s)
        return expectations(model.head, pz, lz)[:, [1, 0, 2]]

    print("(c) the angle GMMs' conditional expectation (instantaneous), held out")
    for label, model in (("training scale", before), ("per-speaker", after)):
        e = [expect(model, f) for f, _ in split.test]
        r_t = np.mean(
            [_r(x, head_pose(t)) for x, (_, t) in zip(e, split.test, strict=True)], axis=0
        )
        r_s = np.mean(
            [_r(x, speech_part(f)) for x, (f, _) in zip(e, split.test, strict=True)], axis=0
        )
        print(_row(f"{label}: r with the truth", r_t))
        print(_row(f"{label}: r with the speech-driven part", r_s))

    # (d) the synthesis
    print(
        "(d) the synthesis: r with the truth | r with the GMMs' expectation | sd ratio "
        f"({args.synthesis_takes} test takes, seed 0)"
    )
    test = split.test[: args.synthesis_takes]
    head = before.head

    def show(label: str, paths: list[np.ndarray], model) -> None:
        truths = [head_pose(t) for _, t in test]
        es = [expect(model, f) for f, _ in test]
        r_t = np.mean([_r(p, t) for p, t in zip(paths, truths, strict=True)], axis=0)
        r_e = np.mean([_r(p, e) for p, e in zip(paths, es, strict=True)], axis=0)
        sd = np.mean(
            [p.std(axis=0) / t.std(axis=0) for p, t in zip(paths, truths, strict=True)], axis=0
        )
        cells = " | ".join(" / ".join(f"{v:+.2f}" for v in x) for x in (r_t, r_e, sd))
        print(f"  {label:<52} {cells}")

    def zs(feats):
        p, lo = smoothed_inputs(feats.f0, feats.intensity, fps)
        return before.scale.pitch_z(p), before.scale.loud_z(lo)

    def drawn(h, **kw):
        return [_sample_path(h, *zs(f), fps, 0, **kw)[:, [1, 0, 2]] for f, _ in test]

    show(
        "Langevin draw (before)",
        [head_pose(generate_track(before, f, seed=0, synthesis="langevin")) for f, _ in test],
        before,
    )
    show("Langevin draw, no eq. 5 start noise", drawn(head, start_noise=False), before)
    show(
        "Langevin draw, weights 1, 1, 1, 0, 0",
        drawn(replace(head, weights=np.array([1.0, 1, 1, 0, 0]))),
        before,
    )
    show("climb to the local maximum (the paper)", drawn(head, climb=True), before)
    show(
        "expectation + variation (after)",
        [head_pose(generate_track(after, f, seed=0)) for f, _ in test],
        after,
    )
    show(
        "expectation only (after, variation 0)",
        [head_pose(generate_track(after, f, seed=0, variation=0.0)) for f, _ in test],
        after,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=120.0)
    parser.add_argument("--versions", default="1,2")
    parser.add_argument("--synthesis-takes", type=int, default=2, help="test takes in step (d)")
    args = parser.parse_args()

    from app.stimuli.speech import load_sound

    sound, _ = load_sound(ROOT / "app" / "data" / "demo" / "speech.wav")
    start_all = time.perf_counter()
    for version in (int(v) for v in args.versions.split(",")):
        diagnose(sound, version, args)
    print(f"\ntotal {time.perf_counter() - start_all:.0f} s")


if __name__ == "__main__":
    main()
