"""Held-out evaluation of the conditions: how speech-like, how close to the truth, how jittery.

Checking a speech-driven model against the data it was fitted on, or against the synthetic
reference speaker whose structure it shares, says little. :func:`evaluate_conditions` fits
every condition that learns on explicit *training* takes and measures it on separate *test*
takes only (Le, Ma & Deng 2012 sec. 8 evaluate on held-out speech the same way):

- **speech coupling**: the first canonical correlation between the head angles (FAP 48-50)
  and the speech pair (conditioned F0, intensity), and the same for the eyebrows (31-34);
- **truth**: Pearson correlation of each channel with the held-out ground truth;
- **kinematics** per channel: mean, sd, mean absolute speed (FAPU/s) and the share of the
  signal's power above 4 Hz (Welch's periodogram of the mean-removed signal), which exposes
  jitter: natural head motion has little power there;
- **null baselines**, each with its spread over draws: the ground truth shifted in time
  (circularly, by at least 2 s; what a coupling measure gives a motion of the right kind that
  is unrelated to this speech) and RANDOM over 20 seeds.

The result is JSON-able; :func:`plot_evaluation` draws it. Example::

    report = evaluate_conditions(train=[("a.wav", "a.fap")], test=[("b.wav", "b.fap")])
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from app.errors import InputError
from app.stimuli.conditions import make_condition
from app.stimuli.generate import parse_conditions
from app.stimuli.io import load_track
from app.stimuli.measures import canonical_correlations, pearson
from app.stimuli.progress import Progress, progress_steps
from app.stimuli.speech import SpeechFeatures, extract_features
from app.stimuli.track import MotionTrack, align_to_features

#: Channels evaluated: the head angles and the inner and middle eyebrows.
EVALUATED: tuple[int, ...] = (48, 49, 50, 31, 33)
GROUPS: dict[str, tuple[int, ...]] = {"head": (48, 49, 50), "eyebrows": (31, 32, 33, 34)}
#: Frequency above which power counts as jitter, Hz.
JITTER_HZ = 4.0
#: Smallest circular shift of the ground-truth baseline, seconds.
MIN_SHIFT_S = 2.0
N_SHIFTS = 20
N_RANDOM_SEEDS = 20

Take = tuple[SpeechFeatures, MotionTrack]


def power_above(x: np.ndarray, fps: float, cutoff: float = JITTER_HZ) -> float | None:
    """Share of the mean-removed signal's power above ``cutoff`` Hz (Welch, 2-s segments).

    >>> t = np.arange(600) / 30
    >>> round(power_above(np.sin(2 * np.pi * 1 * t), 30.0), 3)
    0.0
    >>> round(power_above(np.sin(2 * np.pi * 6 * t), 30.0), 3)
    1.0
    """
    x = np.asarray(x, dtype=np.float64)
    if len(x) < 8 or x.std() == 0:
        return None
    freqs, psd = signal.welch(x - x.mean(), fs=fps, nperseg=min(len(x), int(2 * fps)))
    total = psd.sum()
    return float(psd[freqs > cutoff].sum() / total) if total > 0 else None


def coupling(track: MotionTrack, features: SpeechFeatures) -> dict[str, float | None]:
    """First canonical correlation of each channel group with (conditioned F0, intensity)."""
    speech = np.column_stack([features.f0_conditioned, features.intensity])
    out: dict[str, float | None] = {}
    for label, group in GROUPS.items():
        cols = [track[c] for c in group if c in track.channels]
        cc = canonical_correlations(np.column_stack(cols), speech) if cols else []
        out[label] = cc[0] if cc else None
    return out


def track_measures(
    track: MotionTrack, features: SpeechFeatures, truth: MotionTrack
) -> dict[str, Any]:
    """Coupling, correlation with the truth and kinematics of one track on one test take."""
    channels = {}
    for c in EVALUATED:
        x = track.get(c)
        channels[str(c)] = {
            "mean": float(x.mean()),
            "sd": float(x.std()),
            "speed": float(np.abs(np.diff(x)).mean() * track.fps) if len(x) > 1 else None,
            "power_above_4hz": power_above(x, track.fps),
            "r_truth": pearson(x, truth.get(c)),
        }
    return {"coupling": coupling(track, features), "channels": channels}


def _mean_sd(values: Iterable[float | None]) -> dict[str, float | None]:
    v = np.array([x for x in values if x is not None], dtype=np.float64)
    if len(v) == 0:
        return {"mean": None, "sd": None, "n": 0}
    return {"mean": float(v.mean()), "sd": float(v.std()), "n": int(len(v))}


def _pool(measures: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Mean and spread over takes or draws of every number in :func:`track_measures`."""
    return {
        "coupling": {g: _mean_sd(m["coupling"][g] for m in measures) for g in GROUPS},
        "channels": {
            c: {
                k: _mean_sd(m["channels"][c][k] for m in measures)
                for k in measures[0]["channels"][c]
            }
            for c in measures[0]["channels"]
        },
    }


def _concatenate(takes: Sequence[Take]) -> Take:
    fps = takes[0][0].fps
    feats = SpeechFeatures(
        fps,
        np.concatenate([f.f0 for f, _ in takes]),
        np.concatenate([f.intensity for f, _ in takes]),
        np.concatenate([f.f0_conditioned for f, _ in takes]),
        dict(takes[0][0].metadata),
    )
    channels = sorted(set().union(*(t.channels for _, t in takes)))
    values = np.vstack([np.column_stack([t.get(c) for c in channels]) for _, t in takes])
    return feats, MotionTrack(fps, values, tuple(channels), source=takes[0][1].source)


def load_takes(
    pairs: Sequence[tuple[str | Path, str | Path]],
    fps: float = 30.0,
    pitch_floor: float | None = None,
    pitch_ceiling: float | None = None,
) -> list[Take]:
    """(audio, ground truth) files -> speech features and the truth aligned to them."""
    takes = []
    for audio, truth in pairs:
        feats = extract_features(audio, fps, pitch_floor=pitch_floor, pitch_ceiling=pitch_ceiling)
        takes.append((feats, align_to_features(load_track(truth, fps=fps), feats)))
    return takes


def split_take(take: Take, train_fraction: float) -> tuple[Take, Take]:
    """One recording cut in time: the first ``train_fraction`` trains, the rest tests."""
    if not 0.1 <= train_fraction <= 0.9:
        raise InputError(f"must be between 0.1 and 0.9, got {train_fraction:g}", field="split")
    feats, truth = take
    cut = round(feats.n_frames * train_fraction)
    if min(cut, feats.n_frames - cut) < round(3 * feats.fps):
        raise InputError("each side of the split needs at least 3 s of speech", field="split")

    def part(a: int, b: int) -> Take:
        return feats.slice(a, b), truth.replace(values=truth.values[a:b].copy())

    return part(0, cut), part(cut, feats.n_frames)


def evaluate_conditions(
    train: Sequence[Take],
    test: Sequence[Take],
    *,
    conditions: str | Iterable[str] | Mapping[str, Any] = (
        "none",
        "random",
        "speech_driven",
        "ground_truth",
    ),
    seed: int = 0,
    n_random_seeds: int = N_RANDOM_SEEDS,
    n_shifts: int = N_SHIFTS,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Fit on ``train``, measure on ``test`` (see the module docstring); JSON-able result.

    ``conditions`` as for :func:`app.stimuli.generate.parse_conditions`. Each condition is
    measured on every test take and pooled (mean and sd over takes).
    """
    if not train or not test:
        raise InputError("give at least one training and one test recording", field="train")
    requests = parse_conditions(conditions)
    train_feats, train_truth = _concatenate(train)
    step = progress_steps(progress, len(requests) + 2)

    results: dict[str, Any] = {}
    for name, (model, params) in requests.items():
        cond = make_condition(model, **params).fit(train_feats, train_truth)
        per_take = []
        for feats, truth in test:
            track = (
                truth
                if model == "ground_truth"
                else cond.generate(feats, seed=seed, ground_truth=truth)
            )
            per_take.append(track_measures(track, feats, truth))
        results[name] = {"model": model, **_pool(per_take)}
        step()
    shifted = []
    for feats, truth in test:
        n = feats.n_frames
        lo = round(MIN_SHIFT_S * feats.fps)
        if n - 2 * lo < 1:
            continue
        for k in np.linspace(lo, n - lo, n_shifts).round().astype(int):
            moved = truth.replace(values=np.roll(truth.values, int(k), axis=0))
            shifted.append(track_measures(moved, feats, truth))
    step()
    random_draws = [
        track_measures(make_condition("random").generate(feats, seed=s), feats, truth)
        for s in range(n_random_seeds)
        for feats, truth in test
    ]
    step()
    return {
        "train": {"takes": len(train), "frames": int(train_feats.n_frames)},
        "test": {"takes": len(test), "frames": int(sum(f.n_frames for f, _ in test))},
        "fps": train_feats.fps,
        "jitter_hz": JITTER_HZ,
        "conditions": results,
        "baselines": {
            "ground_truth_shifted": _pool(shifted) if shifted else None,
            f"random_{n_random_seeds}_seeds": _pool(random_draws),
        },
    }


def plot_evaluation(report: Mapping[str, Any], path: str | Path) -> Path:
    """Bars with spread: head coupling with speech, correlation with the truth (head yaw),
    head sd and jitter, per condition and baseline."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = {
        **report["conditions"],
        **{k: v for k, v in report["baselines"].items() if v is not None},
    }
    names = list(rows)
    panels = [
        ("head coupling with speech (CCA)", lambda r: r["coupling"]["head"]),
        ("correlation with held-out truth, yaw", lambda r: r["channels"]["49"]["r_truth"]),
        ("head yaw sd (AU)", lambda r: r["channels"]["49"]["sd"]),
        (
            f"head yaw power above {report['jitter_hz']:g} Hz",
            lambda r: r["channels"]["49"]["power_above_4hz"],
        ),
    ]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6))
    for ax, (title, pick) in zip(axes, panels, strict=True):
        stats = [pick(rows[n]) for n in names]
        means = [s["mean"] if s["mean"] is not None else 0.0 for s in stats]
        sds = [s["sd"] or 0.0 for s in stats]
        ax.barh(range(len(names)), means, xerr=sds, color="tab:blue", alpha=0.8)
        ax.set_yticks(range(len(names)), names, fontsize=8)
        ax.set_title(title, fontsize=9)
        ax.invert_yaxis()
    fig.suptitle(
        f"held-out evaluation: trained on {report['train']['frames']} frames, tested "
        f"on {report['test']['frames']}",
        fontsize=10,
    )
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
