"""Checking a submission at upload: one track per segment, each problem one line naming the file.

A submitted system sends one file per benchmark segment, named after the segment
(``s01.fap``, ``s01.csv``, ``s01.bvh``), or, for a stochastic system, several samples per
segment (``s01_sample1.fap``, ``s01_sample2.fap``, ...), of which one is drawn
(:func:`draw_sample`). Every file is read by the one import function of the stimuli,
:func:`app.stimuli.io.load_track`, so every format facepair imports is accepted, and a format
added there (vertex sequences, say) is accepted here without a change. Then, per file:

- the frame rate: one of the season's ``[submissions] frame_rates``, or within
  :data:`app.leaderboard.season.FRAME_RATE_RANGE`;
- the length against the segment's speech (:func:`app.stimuli.lengths.length_note`: up to
  0.2 s is padded or cut with a note, beyond it refused unless the season pads);
- every value a number (no NaN or infinity);
- every value in range (:func:`plausible_limit`: a head turned past 90 degrees, an eye past 60,
  a lip or brow moved further than four FAPU is not a face);
- which channel groups move (head, eyebrows, eyes, eyelids, jaw and lips): a track that moves
  nothing is refused, a group the season requires must move in every track.

Every segment must have a file, no file may name something else, and a segment has at most
``[submissions] samples`` samples. Nothing raises: :func:`check_submission` returns the
problems (empty when the submission passes) with what each file carries.
"""

from __future__ import annotations

import re
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.leaderboard.season import CHANNEL_GROUPS, FRAME_RATE_RANGE, SubmissionRules
from app.stimuli.fap import FAPS, HEAD
from app.stimuli.lengths import length_note
from app.stimuli.track import MotionTrack

#: The largest rotation a face's head makes (1e-5 rad: 90 degrees), and an eye's (60 degrees).
HEAD_LIMIT_AU = 157_080.0
EYE_LIMIT_AU = 104_720.0
#: The largest displacement of a lip, brow, lid or cheek point, in its FAPU (1024 = one FAPU,
#: e.g. the whole mouth-nose separation): four FAPU.
DISPLACEMENT_LIMIT = 4096.0
#: A channel moves when its values span more than this (in its own unit): a constant or
#: rounding-noise column is "not carried".
MOVES = 1.0
#: Problems listed per file at most; the rest are counted.
MAX_LINES_PER_FILE = 4
_SAMPLE = re.compile(r"^(?P<segment>.+?)[._-]sample(?P<k>\d{1,3})$")


@dataclass(frozen=True, slots=True)
class SegmentTarget:
    """A segment as submissions are checked against it: its name and its speech's length."""

    name: str
    duration_s: float


@dataclass(frozen=True, slots=True)
class FileReport:
    """What one file turned out to be."""

    file: str
    segment: str
    sample: int
    format: str = ""
    fps: float | None = None
    duration_s: float | None = None
    moves: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class SubmissionCheck:
    """The outcome: the problems (one line each, naming the file), each file's report, the
    drawn file of every segment and, per channel group, in how many segments it moves."""

    problems: tuple[str, ...]
    files: tuple[FileReport, ...] = ()
    drawn: Mapping[str, str] = field(default_factory=dict)
    moves: Mapping[str, int] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.problems

    def as_dict(self) -> dict[str, Any]:
        """JSON for the submission's row and its preview page."""
        return {
            "ok": self.ok,
            "problems": list(self.problems),
            "files": [
                {
                    "file": f.file,
                    "segment": f.segment,
                    "sample": f.sample,
                    "format": f.format,
                    "fps": f.fps,
                    "duration_s": f.duration_s,
                    "moves": list(f.moves),
                    "notes": list(f.notes),
                }
                for f in self.files
            ],
            "drawn": dict(self.drawn),
            "moves": dict(self.moves),
        }


def segment_of(name: str, segments: Sequence[str]) -> tuple[str, int] | None:
    """(segment, sample number) a file's name gives, or None: ``s01.fap`` is sample 0 of s01,
    ``s01_sample3.bvh`` its sample 3.

    >>> segment_of("s01.fap", ["s01", "s02"]), segment_of("s02_sample3.csv", ["s01", "s02"])
    (('s01', 0), ('s02', 3))
    >>> segment_of("s03.fap", ["s01", "s02"]) is None
    True
    """
    stem = Path(name).stem
    if stem in segments:
        return stem, 0
    found = _SAMPLE.match(stem)
    if found and found.group("segment") in segments and int(found.group("k")) > 0:
        return found.group("segment"), int(found.group("k"))
    return None


def plausible_limit(fap: int) -> float:
    """The largest magnitude FAP ``fap`` takes on a real face, in its unit.

    >>> plausible_limit(48), plausible_limit(23), plausible_limit(3)
    (157080.0, 104720.0, 4096.0)
    """
    if fap in HEAD:
        return HEAD_LIMIT_AU
    if FAPS[fap].unit == "AU":
        return EYE_LIMIT_AU if fap in (23, 24, 25, 26) else HEAD_LIMIT_AU
    return DISPLACEMENT_LIMIT


def draw_sample(draw_seed: int, system: str, segment: str, n_samples: int) -> int:
    """Which of ``n_samples`` samples (by position in sample order) represents ``system`` on
    ``segment``: drawn from the season's secret draw seed, the system and the segment, so
    nobody picks it and anyone can check it once the seed is revealed.

    >>> draw_sample(7, "sys", "s01", 1)
    0
    >>> draw_sample(7, "sys", "s01", 5) == draw_sample(7, "sys", "s01", 5)
    True
    """
    if n_samples <= 1:
        return 0
    keys = [int(draw_seed) % 2**63, zlib.crc32(system.encode()), zlib.crc32(segment.encode())]
    return int(np.random.default_rng(keys).integers(n_samples))


def carried(track: MotionTrack) -> tuple[str, ...]:
    """The channel groups that move in ``track`` (:data:`CHANNEL_GROUPS`)."""
    out = []
    for group, faps in CHANNEL_GROUPS.items():
        cols = [track[c] for c in faps if c in track.channels]
        if cols and any(np.ptp(c[np.isfinite(c)]) > MOVES for c in cols if np.isfinite(c).any()):
            out.append(group)
    return tuple(out)


def _range_problems(track: MotionTrack, name: str) -> list[str]:
    lines = []
    for j, fap in enumerate(track.channels):
        column = track.values[:, j]
        finite = np.isfinite(column)
        if not finite.any():
            continue
        limit = plausible_limit(fap)
        low = -limit if FAPS[fap].bidirectional else -limit / 4.0
        bad = finite & ((column > limit) | (column < low))
        if bad.any():
            frame = int(np.flatnonzero(bad)[0])
            unit = FAPS[fap].unit
            lines.append(
                f"{name}: FAP {fap} ({FAPS[fap].name}) is {column[frame]:.6g} {unit} at frame "
                f"{frame}, outside the plausible {low:g}..{limit:g}"
            )
    return lines


def check_file(
    path: Path,
    name: str,
    target: SegmentTarget,
    sample: int,
    rules: SubmissionRules,
    load: Any,
) -> tuple[FileReport, list[str], MotionTrack | None]:
    """One file: its report, its problems (one line each, naming ``name``) and the track."""
    report = FileReport(name, target.name, sample, format=Path(name).suffix.lower().lstrip("."))
    try:
        size = path.stat().st_size
    except OSError as exc:
        return report, [f"{name}: cannot be read ({exc.strerror})"], None
    if size > rules.max_file_mb * 1024 * 1024:
        return report, [f"{name}: {size / 2**20:.1f} MB, at most {rules.max_file_mb} MB"], None
    try:
        track = load(path)
    except InputError as exc:
        return (
            report,
            [str(InputError(exc.message, path=name, line=exc.line, field=exc.field))],
            None,
        )
    except Exception as exc:  # noqa: BLE001 - any file must end in one line, never a crash
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return report, [f"{name}: cannot be read as a motion track ({first[:200]})"], None
    problems: list[str] = []
    fps = float(track.fps)
    if rules.frame_rates:
        if not any(abs(fps - r) <= 1e-6 * r for r in rules.frame_rates):
            allowed = ", ".join(f"{r:g}" for r in rules.frame_rates)
            problems.append(f"{name}: {fps:g} frames per second; this season takes {allowed}")
    elif not FRAME_RATE_RANGE[0] <= fps <= FRAME_RATE_RANGE[1]:
        low, high = FRAME_RATE_RANGE
        problems.append(f"{name}: {fps:g} frames per second, expected {low:g} to {high:g}")
    notes: list[str] = []
    if track.n_frames == 0:
        problems.append(f"{name}: no frames")
    else:
        frames = max(1, round(target.duration_s * fps))
        try:
            note = length_note(
                track, frames, fps, what=f"segment {target.name}", path=name, pad=rules.pad
            )
        except InputError as exc:
            problems.append(str(exc))
        else:
            if note:
                notes.append(note)
    bad = ~np.isfinite(track.values)
    if bad.any():
        frame, column = (int(v[0]) for v in np.nonzero(bad))
        problems.append(
            f"{name}: {int(bad.sum())} values are not numbers (NaN or infinite), the first "
            f"at frame {frame}, FAP {track.channels[column]}"
        )
    problems += _range_problems(track, name)
    moves = carried(track)
    if not moves:
        problems.append(f"{name}: moves nothing (no head, brow, eye, lid, jaw or lip motion)")
    for group in rules.require:
        if group not in moves and moves:
            faps = CHANNEL_GROUPS[group]
            problems.append(
                f"{name}: carries no {group} motion (FAP {faps[0]}-{faps[-1]}), which this "
                "season requires"
            )
    if len(problems) > MAX_LINES_PER_FILE:
        more = len(problems) - MAX_LINES_PER_FILE + 1
        problems = problems[: MAX_LINES_PER_FILE - 1] + [f"{name}: and {more} more problems"]
    report = FileReport(
        name,
        target.name,
        sample,
        format=_format(path, name),
        fps=fps,
        duration_s=round(track.duration, 4),
        moves=moves,
        notes=tuple(notes),
    )
    return report, problems, track


def _format(path: Path, name: str) -> str:
    """What kind of file it was: its extension, or the tool a CSV's header names."""
    suffix = Path(name).suffix.lower().lstrip(".")
    if suffix == "csv":
        from app.stimuli.capture import sniff_csv

        return sniff_csv(path) or "fap-csv"
    return suffix


def check_submission(
    files: Mapping[str, Path],
    segments: Sequence[SegmentTarget],
    rules: SubmissionRules,
    *,
    system: str,
    draw_seed: int,
    load: Any = None,
) -> SubmissionCheck:
    """Check every file of a submission (``files``: the name it was uploaded as -> where it
    is). ``load`` reads one file (default :func:`app.stimuli.io.load_track`). Problems come in
    a fixed order: names that fit no segment, then each segment's files, then missing ones."""
    if load is None:
        from app.stimuli.io import load_track as load
    names = [s.name for s in segments]
    targets = {s.name: s for s in segments}
    problems: list[str] = []
    by_segment: dict[str, list[tuple[int, str]]] = {n: [] for n in names}
    for name in sorted(files):
        found = segment_of(name, names)
        if found is None:
            problems.append(
                f"{name}: names no segment of this season (expected {_examples(names)})"
            )
            continue
        segment, sample = found
        taken = [n for k, n in by_segment[segment] if k == sample]
        if taken:
            problems.append(
                f"{name}: a second file for segment {segment} beside {taken[0]}; name samples "
                f"{segment}_sample1{Path(name).suffix}, {segment}_sample2{Path(name).suffix}, ..."
            )
            continue
        by_segment[segment].append((sample, name))
    reports: list[FileReport] = []
    drawn: dict[str, str] = {}
    moves: dict[str, int] = {g: 0 for g in CHANNEL_GROUPS}
    for segment in names:
        entries = sorted(by_segment[segment])
        if not entries:
            problems.append(
                f"{segment}: no track for this segment (every segment needs one, e.g. "
                f"{segment}.fap)"
            )
            continue
        if len(entries) > rules.samples:
            problems.append(
                f"{segment}: {len(entries)} samples, at most {rules.samples} per segment"
            )
        if len(entries) > 1 and entries[0][0] == 0:
            problems.append(
                f"{entries[0][1]}: with several samples of segment {segment}, name each "
                f"{segment}_sampleN"
            )
        for sample, name in entries:
            report, lines, _ = check_file(files[name], name, targets[segment], sample, rules, load)
            reports.append(report)
            problems += lines
        pick = draw_sample(draw_seed, system, segment, len(entries))
        drawn[segment] = entries[pick][1]
        chosen = next(r for r in reports if r.file == entries[pick][1])
        for group in chosen.moves:
            moves[group] += 1
    return SubmissionCheck(tuple(problems), tuple(reports), drawn, moves)


def _examples(names: Sequence[str]) -> str:
    shown = ", ".join(f"{n}.fap" for n in names[:3])
    return shown + (", ..." if len(names) > 3 else "")
