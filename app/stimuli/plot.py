"""A picture of the generated conditions: speech on top, then each prosody channel.

Rows: raw and conditioned F0 with intensity on a second axis; head pitch, yaw and roll in
degrees (FAP 48-50); inner eyebrow raise (FAP 31, ENS). One line per condition, the ground
truth drawn thick; the speech-driven eyebrow raises are shaded. Uses matplotlib's Agg backend
(no display needed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.stimuli.conditions import DISPLAY_NAMES
from app.stimuli.fap import DEG_PER_AU
from app.stimuli.summary import GenerationResult

_COLOURS = {
    "ground_truth": "black",
    "none": "0.6",
    "random": "tab:orange",
    "speech_driven": "tab:blue",
    "live_gmm": "tab:green",
}


def plot_conditions(result: GenerationResult, path: str | Path) -> Path:
    """Draw the features and every condition's head and eyebrow channels to a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    feats = result.features
    t = np.arange(feats.n_frames) / feats.fps
    rows = [
        ("head pitch (48), deg, + down", 48, DEG_PER_AU),
        ("head yaw (49), deg, + left", 49, DEG_PER_AU),
        ("head roll (50), deg, + right", 50, DEG_PER_AU),
        ("inner eyebrow raise (31), ENS", 31, 1.0),
    ]
    fig, axes = plt.subplots(
        len(rows) + 1, 1, figsize=(12, 11), sharex=True, constrained_layout=True
    )
    ax = axes[0]
    ax.plot(
        t, np.where(feats.voiced, feats.f0, np.nan), ".", ms=3, color="tab:red", label="F0 (Praat)"
    )
    ax.plot(t, feats.f0_conditioned, color="tab:red", lw=1, alpha=0.6, label="F0 conditioned")
    ax.set_ylabel("F0, Hz")
    ax2 = ax.twinx()
    ax2.plot(t, feats.intensity, color="tab:purple", lw=1, alpha=0.7, label="intensity")
    ax2.set_ylabel("intensity, dB")
    handles = ax.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0]
    ax.legend(handles=handles, loc="upper right", fontsize=8, ncol=3)
    title = f"{Path(str(result.summary.get('audio', ''))).name}: speech and conditions"
    if (result.summary.get("ground_truth") or {}).get("synthetic"):
        title += "  (ground truth: SYNTHETIC reference speaker)"
    if result.summary.get("normalized"):
        title += "  [normalised]"
    ax.set_title(title, fontsize=10)

    raises = []
    sd = result.tracks.get("speech_driven")
    if sd is not None:
        raises = sd.metadata.get("eyebrows", {}).get("raises", [])
    for ax, (label, fap, scale) in zip(axes[1:], rows, strict=True):
        for name, track in result.tracks.items():
            if fap not in track.channels:
                continue
            ax.plot(
                t[: track.n_frames],
                track[fap] * scale,
                color=_COLOURS.get(name),
                lw=2.2 if name == "ground_truth" else 1.1,
                label=DISPLAY_NAMES.get(name, name),
            )
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
        if fap == 31:
            for start, release in raises:
                ax.axvspan(start / feats.fps, release / feats.fps, color="tab:blue", alpha=0.08)
    axes[1].legend(loc="upper right", fontsize=8, ncol=len(result.tracks))
    axes[-1].set_xlabel("time, s")
    out = Path(path)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
