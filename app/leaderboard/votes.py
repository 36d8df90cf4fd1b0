"""The leaderboard's votes: every round's analysed votes in one frame, and the count arrays the
scores are fitted to.

A round's votes are its study's export (``votes.csv``, :mod:`app.analysis.votes`) with the
round's number added; participants are named ``r<round>/<label>`` so that people of different
rounds never merge. :func:`pooled_frame` keeps what the round's report analysed (no attention
check, no participant the export marks ``excluded``).

Two tests live in these votes:

- **naturalness**: the pairs of two different systems (kind ``trial``), on HEMVIP2's five
  levels; the model uses the direction and counts "cannot decide" as a tie;
- **coherence**: the mismatched-speech pairs (kind ``mismatch``): one system's motion for
  this segment against its own motion for another segment, under this segment's speech; a
  vote for the matched face is a hit.

>>> rows = pd.DataFrame({"round": [1, 1], "participant": ["a", "a"], "clip": ["s1", "s1"],
...                      "left": ["x", "y"], "right": ["y", "y"], "choice": ["left", "right"],
...                      "kind": ["trial", "mismatch"], "mismatched": ["", "left"],
...                      "excluded": ["", ""]})
>>> t, people = naturalness_counts(pooled_frame(rows), ["x", "y"])
>>> t.shape, people, int(t[0, 0, 1, 0])
((1, 2, 2, 3), ['r1/a'], 1)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from app.trials.rules import CHOICES

#: Columns a pooled frame has (the export's, plus ``round``).
COLUMNS = (
    "round",
    "participant",
    "clip",
    "left",
    "right",
    "choice",
    "kind",
    "mismatched",
    "excluded",
)


def pooled_frame(frame: pd.DataFrame) -> pd.DataFrame:
    """The analysed votes of ``frame`` (rows of one or more rounds) as plain strings, with
    participants named by round. Catch trials and excluded participants are left out, as the
    round's report leaves them out."""
    out = pd.DataFrame({c: frame[c] if c in frame else "" for c in COLUMNS})
    for column in COLUMNS[1:]:
        out[column] = out[column].astype(object).where(out[column].notna(), "").astype(str)
        out[column] = out[column].str.strip()
    out["round"] = out["round"].astype(int)
    prefix = "r" + out["round"].astype(str) + "/"
    already = [p.startswith(x) for p, x in zip(out["participant"], prefix, strict=True)]
    out["participant"] = out["participant"].where(already, prefix + out["participant"])
    keep = out["kind"].isin(("", "trial", "mismatch")) & (out["excluded"] == "")
    return out[keep].reset_index(drop=True)


def is_mismatch(frame: pd.DataFrame) -> pd.Series:
    """Rows of the coherence test (a mismatched side named)."""
    return frame["mismatched"].isin(("left", "right"))


def naturalness_counts(
    frame: pd.DataFrame, systems: Sequence[str], clips: Sequence[str] | None = None
) -> tuple[np.ndarray, list[str]]:
    """(P, n, n, 3) counts of the naturalness votes: participant p's votes with system i on the
    left and j on the right, answered left / right / undecided; with ``clips`` a
    (P, K, n, n, 3) array by segment (the mixed model's). Systems outside ``systems`` and
    same-system pairs are left out. Returns the array and the participants in its order."""
    index = {s: k for k, s in enumerate(systems)}
    rows = frame[
        ~is_mismatch(frame)
        & frame["left"].isin(index)
        & frame["right"].isin(index)
        & (frame["left"] != frame["right"])
        & frame["choice"].isin(CHOICES)
    ]
    people = sorted(rows["participant"].unique().tolist())
    who = {p: k for k, p in enumerate(people)}
    p = rows["participant"].map(who).to_numpy(dtype=int)
    i = rows["left"].map(index).to_numpy(dtype=int)
    j = rows["right"].map(index).to_numpy(dtype=int)
    c = rows["choice"].map({ch: k for k, ch in enumerate(CHOICES)}).to_numpy(dtype=int)
    n = len(systems)
    if clips is None:
        counts = np.zeros((len(people), n, n, 3))
        np.add.at(counts, (p, i, j, c), 1.0)
        return counts, people
    by_clip = {k: q for q, k in enumerate(clips)}
    k = rows["clip"].map(by_clip)
    keep = k.notna().to_numpy()
    full = np.zeros((len(people), len(clips), n, n, 3))
    np.add.at(full, (p[keep], k[keep].to_numpy(dtype=int), i[keep], j[keep], c[keep]), 1.0)
    return full, people


def coherence_counts(frame: pd.DataFrame, systems: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """(P, n, 2): per participant and system, the mismatched-speech votes for the matched face
    and the decided ones (undecided votes are reported apart, not counted)."""
    index = {s: k for k, s in enumerate(systems)}
    rows = frame[is_mismatch(frame) & frame["left"].isin(index)]
    people = sorted(rows["participant"].unique().tolist())
    who = {p: k for k, p in enumerate(people)}
    decided = rows["choice"].isin(("left", "right")).to_numpy()
    hit = decided & (rows["choice"] != rows["mismatched"]).to_numpy()
    p = rows["participant"].map(who).to_numpy(dtype=int)
    s = rows["left"].map(index).to_numpy(dtype=int)
    counts = np.zeros((len(people), len(systems), 2))
    np.add.at(counts, (p, s, 0), hit.astype(float))
    np.add.at(counts, (p, s, 1), decided.astype(float))
    return counts, people
