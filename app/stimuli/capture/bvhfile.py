"""BVH (Biovision hierarchy) files: a small strict parser of the skeleton and its motion.

Gesture data sets and the systems trained on them (the GENEA challenges, Talking With Hands,
BEAT) give motion as BVH: a ``HIERARCHY`` of joints, each with an ``OFFSET`` from its parent
and ``CHANNELS`` (positions and Euler rotations in degrees, in the order the line lists them),
then ``MOTION``, ``Frames: N``, ``Frame Time: dt`` and one line of channel values per frame.
:mod:`app.stimuli.capture.bvh` reads the head from the parsed skeleton.

The reader is a small strict parser of its own (no BVH package reads arbitrary files without
raising its own assortment of errors): anything malformed is one :class:`~app.errors.InputError`
naming the file and the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.errors import InputError

MAX_FRAMES = 1_000_000
MAX_JOINTS = 2000
_CHANNEL = re.compile(r"^([xyz])(position|rotation)$", re.IGNORECASE)


@dataclass
class Joint:
    """One joint: its name, parent (-1 for the root), rest offset, channels and where its
    channels start on a frame's line."""

    name: str
    parent: int
    line: int
    offset: np.ndarray | None = None
    channels: list[str] = field(default_factory=list)
    first: int = 0
    end_site: np.ndarray | None = None


@dataclass
class Skeleton:
    """A parsed BVH file: joints in file order, seconds per frame, the motion (frames x
    channels) and the file line of each frame."""

    joints: list[Joint]
    frame_time: float
    motion: np.ndarray
    lines: np.ndarray


def _tokens(lines: list[str]):
    for number, text in enumerate(lines, start=1):
        for tok in text.replace("{", " { ").replace("}", " } ").split():
            yield tok, number


def _number(tok: str, path: str, line: int, what: str) -> float:
    try:
        value = float(tok)
    except ValueError:
        raise InputError(f"{what}: {tok[:40]!r} is not a number", path=path, line=line) from None
    if not np.isfinite(value):
        raise InputError(f"{what}: {tok[:40]!r} is not a finite number", path=path, line=line)
    return value


def _hierarchy(lines: list[str], path: str) -> tuple[list[Joint], int]:
    """The joints, and the index of the line after ``MOTION``."""
    tokens = _tokens(lines)
    last = 0

    def take(what: str) -> tuple[str, int]:
        nonlocal last
        for tok, line in tokens:
            last = line
            return tok, line
        raise InputError(f"the file ends inside the hierarchy: expected {what}", path=path)

    tok, line = take("HIERARCHY")
    if tok.upper() != "HIERARCHY":
        raise InputError(f"expected HIERARCHY, got {tok[:40]!r}", path=path, line=line)
    joints: list[Joint] = []
    stack: list[int] = []
    started = False
    while True:
        tok, line = take("a joint, OFFSET, CHANNELS or '}'")
        word = tok.upper()
        if word in ("ROOT", "JOINT"):
            if (word == "ROOT") == started or (word == "JOINT" and not stack):
                raise InputError(f"unexpected {tok}: one ROOT comes first", path=path, line=line)
            if len(joints) >= MAX_JOINTS:
                raise InputError(f"more than {MAX_JOINTS} joints", path=path, line=line)
            name, _ = take("the joint's name")
            brace, at = take("'{'")
            if brace != "{":
                raise InputError(f"expected '{{' after {name[:40]}", path=path, line=at)
            joints.append(Joint(name, stack[-1] if stack else -1, line))
            stack.append(len(joints) - 1)
            started = True
        elif word == "END":
            site, at = take("Site")
            brace, at2 = take("'{'")
            if site.upper() != "SITE" or brace != "{" or not stack:
                raise InputError("expected 'End Site {' inside a joint", path=path, line=at)
            key, at3 = take("OFFSET")
            if key.upper() != "OFFSET":
                raise InputError("expected OFFSET in an End Site", path=path, line=at3)
            joints[stack[-1]].end_site = np.array(
                [_number(take("a number")[0], path, at3, "End Site OFFSET") for _ in range(3)]
            )
            close, at4 = take("'}'")
            if close != "}":
                raise InputError("expected '}' closing the End Site", path=path, line=at4)
        elif word == "OFFSET":
            joint = joints[stack[-1]] if stack else None
            if joint is None or joint.offset is not None:
                raise InputError("OFFSET outside a joint, or twice", path=path, line=line)
            joint.offset = np.array(
                [_number(take("a number")[0], path, line, "OFFSET") for _ in range(3)]
            )
        elif word == "CHANNELS":
            joint = joints[stack[-1]] if stack else None
            count, _ = take("the channel count")
            if joint is None or joint.channels or not _small_int(count, 6):
                raise InputError(
                    "CHANNELS: expected a count 0-6 inside a joint, once", path=path, line=line
                )
            names = [take("a channel name")[0] for _ in range(int(count))]
            if not all(_CHANNEL.match(n) for n in names) or len({n.lower() for n in names}) < len(
                names
            ):
                got = " ".join(names)[:60]
                raise InputError(
                    f"CHANNELS: expected distinct X/Y/Z position/rotation, got {got}",
                    path=path,
                    line=line,
                )
            joint.channels = names
        elif tok == "}":
            if not stack:
                raise InputError("'}' closes no joint", path=path, line=line)
            joint = joints[stack.pop()]
            if joint.offset is None:
                raise InputError(f"joint {joint.name[:40]} has no OFFSET", path=path, line=line)
            if not stack:
                break
        else:
            raise InputError(f"unexpected {tok[:40]!r} in the hierarchy", path=path, line=line)
    tok, line = take("MOTION")
    if tok.upper() != "MOTION":
        raise InputError(
            f"expected MOTION after the hierarchy, got {tok[:40]!r}", path=path, line=line
        )
    return joints, last


def _header_value(text: str, key: str, path: str, line: int) -> str:
    name, _, value = text.partition(":")
    if " ".join(name.split()).lower() != key.lower() or not value.strip():
        got = text.strip()[:40]
        raise InputError(f"expected '{key}: <value>', got {got!r}", path=path, line=line)
    return value.strip()


def parse_bvh(path: str | Path) -> Skeleton:
    """Parse a BVH file (see the module docstring); :class:`InputError` for anything else."""
    p = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("no such file", path=p) from None
    except UnicodeDecodeError:
        raise InputError("not a text BVH file (not UTF-8)", path=p) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror}", path=p) from None
    lines = text.splitlines()
    joints, motion_line = _hierarchy(lines, p)
    rest = [(k + 1, lines[k]) for k in range(motion_line, len(lines)) if lines[k].strip()]
    if len(rest) < 2:
        raise InputError("expected 'Frames:' and 'Frame Time:' after MOTION", path=p)
    (n_line, n_text), (t_line, t_text) = rest[0], rest[1]
    count = _header_value(n_text, "Frames", p, n_line)
    if not _small_int(count, MAX_FRAMES):
        raise InputError(
            f"Frames: expected 0..{MAX_FRAMES}, got {count[:40]!r}", path=p, line=n_line
        )
    n_frames = int(count)
    frame_time = _number(_header_value(t_text, "Frame Time", p, t_line), p, t_line, "Frame Time")
    if not frame_time > 0:
        raise InputError("Frame Time: expected seconds > 0", path=p, line=t_line)
    first = 0
    for joint in joints:
        joint.first = first
        first += len(joint.channels)
    frames = rest[2:]
    if len(frames) != n_frames:
        raise InputError(
            f"Frames says {n_frames}, the file has {len(frames)} frame lines"
            + (" (truncated)" if len(frames) < n_frames else ""),
            path=p,
            line=frames[-1][0] if frames else t_line,
        )
    motion = np.empty((n_frames, first))
    for k, (line, values) in enumerate(frames):
        cells = values.split()
        if len(cells) != first:
            raise InputError(f"{len(cells)} values for {first} channels", path=p, line=line)
        try:
            motion[k] = [float(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not _is_float(c))
            raise InputError(f"{bad[:40]!r} is not a number", path=p, line=line) from None
        if not np.all(np.isfinite(motion[k])):
            raise InputError("a value is not a finite number", path=p, line=line)
    return Skeleton(joints, frame_time, motion, np.array([ln for ln, _ in frames], dtype=np.int64))


def _small_int(text: str, most: int) -> bool:
    return text.isascii() and text.isdigit() and len(text) < 12 and int(text) <= most


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
