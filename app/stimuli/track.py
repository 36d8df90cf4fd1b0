"""The motion track: MPEG-4 FAP channels sampled at a frame rate.

A track holds the FAPs it has (any subset of 1..68) as float64 columns in FAPU (thesis sec. 3.2:
captured marker motion is expressed as FAPs normalised by the speaker's FAPU). A FAP absent from
a track is neutral (0), the MPEG-4 meaning of an unanimated parameter.

Example
-------
>>> import numpy as np
>>> t = MotionTrack.zeros(fps=30, n_frames=4, channels=(48, 49))
>>> t = t.with_channels({48: np.array([0.0, 100.0, 200.0, 300.0])})
>>> t[48].tolist(), t.get(50).tolist()
([0.0, 100.0, 200.0, 300.0], [0.0, 0.0, 0.0, 0.0])
>>> t.resample(60).n_frames
8
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from app.stimuli.fap import N_FAPS, check_fap

if TYPE_CHECKING:
    from app.stimuli.speech import SpeechFeatures


@dataclass(eq=False)
class MotionTrack:
    """FAP channels over time.

    Attributes
    ----------
    fps : frames per second (> 0).
    values : float64 array (n_frames, len(channels)), in each FAP's FAPU.
    channels : FAP numbers of the columns, ascending and unique.
    name, source, speaker : free text; ``source`` says where the motion came from
        (``"capture"``, ``"synthetic reference speaker"``, a condition name, a file path).
    metadata : anything else worth keeping with the track (JSON-serialisable).
    """

    fps: float
    values: np.ndarray
    channels: tuple[int, ...]
    name: str = ""
    source: str = ""
    speaker: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not np.isfinite(self.fps) or self.fps <= 0:
            raise ValueError(f"fps must be a positive number, got {self.fps!r}")
        self.fps = float(self.fps)
        self.channels = tuple(check_fap(c) for c in self.channels)
        if list(self.channels) != sorted(set(self.channels)):
            raise ValueError(f"channels must be ascending and unique, got {self.channels}")
        values = np.asarray(self.values, dtype=np.float64)
        if values.ndim == 1 and len(self.channels) == 1:
            values = values[:, None]
        if values.ndim != 2 or values.shape[1] != len(self.channels):
            raise ValueError(
                f"values must have shape (n_frames, {len(self.channels)}), got {values.shape}"
            )
        self.values = values

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def zeros(
        cls, fps: float, n_frames: int, channels: Iterable[int] = (), **meta: Any
    ) -> MotionTrack:
        """A neutral track of ``n_frames`` frames with the given channels at 0."""
        chans = tuple(sorted(set(int(c) for c in channels)))
        return cls(fps, np.zeros((int(n_frames), len(chans))), chans, **meta)

    @classmethod
    def from_channels(
        cls, fps: float, columns: Mapping[int, np.ndarray], **meta: Any
    ) -> MotionTrack:
        """A track from ``{fap: column}``; all columns must have the same length."""
        chans = tuple(sorted(int(c) for c in columns))
        lengths = {len(np.asarray(columns[c])) for c in chans}
        if len(lengths) > 1:
            raise ValueError(f"channel columns differ in length: {sorted(lengths)}")
        n = lengths.pop() if lengths else 0
        values = np.empty((n, len(chans)))
        for j, c in enumerate(chans):
            values[:, j] = columns[c]
        return cls(fps, values, chans, **meta)

    # -- access -------------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return int(self.values.shape[0])

    @property
    def duration(self) -> float:
        """Length in seconds (n_frames / fps)."""
        return self.n_frames / self.fps

    @property
    def times(self) -> np.ndarray:
        """Frame times in seconds, frame i at i / fps."""
        return np.arange(self.n_frames) / self.fps

    def __contains__(self, fap: object) -> bool:
        return fap in self.channels

    def __getitem__(self, fap: int) -> np.ndarray:
        """The column of ``fap`` (a view); ``KeyError`` if the track lacks it."""
        try:
            return self.values[:, self.channels.index(fap)]
        except ValueError:
            raise KeyError(f"track has no FAP {fap}") from None

    def get(self, fap: int) -> np.ndarray:
        """The column of ``fap``, or zeros (neutral) if the track lacks it."""
        return self[fap].copy() if fap in self.channels else np.zeros(self.n_frames)

    def dense(self) -> np.ndarray:
        """All 68 FAPs as an (n_frames, 68) array, absent ones 0; column k is FAP k+1."""
        out = np.zeros((self.n_frames, N_FAPS))
        if self.channels:
            out[:, np.array(self.channels) - 1] = self.values
        return out

    # -- derivation (tracks are treated as values: these return new tracks) ------------------
    def replace(self, **changes: Any) -> MotionTrack:
        """A copy with some attributes changed (values and metadata are copied)."""
        kw: dict[str, Any] = dict(
            fps=self.fps,
            values=self.values.copy(),
            channels=self.channels,
            name=self.name,
            source=self.source,
            speaker=self.speaker,
            metadata=dict(self.metadata),
        )
        kw.update(changes)
        return MotionTrack(**kw)

    def with_channels(self, columns: Mapping[int, np.ndarray]) -> MotionTrack:
        """A copy with the given channels set (added or overwritten)."""
        merged = {c: self.values[:, j] for j, c in enumerate(self.channels)}
        for c, col in columns.items():
            col = np.asarray(col, dtype=np.float64)
            if col.shape != (self.n_frames,):
                raise ValueError(f"FAP {c}: expected {self.n_frames} values, got {col.shape}")
            merged[check_fap(c)] = col
        return MotionTrack.from_channels(
            self.fps,
            merged,
            name=self.name,
            source=self.source,
            speaker=self.speaker,
            metadata=dict(self.metadata),
        )

    def select(self, faps: Iterable[int]) -> MotionTrack:
        """A copy with only the given channels (those the track has)."""
        keep = sorted(set(faps) & set(self.channels))
        idx = [self.channels.index(c) for c in keep]
        return self.replace(values=self.values[:, idx].copy(), channels=tuple(keep))

    def drop(self, faps: Iterable[int]) -> MotionTrack:
        """A copy without the given channels."""
        return self.select(set(self.channels) - set(faps))

    def fit_length(self, n_frames: int) -> MotionTrack:
        """Trim to, or pad to, ``n_frames`` frames; padding holds the last frame (or 0)."""
        n = self.n_frames
        if n_frames <= n:
            return self.replace(values=self.values[:n_frames].copy())
        last = self.values[-1:] if n else np.zeros((1, len(self.channels)))
        pad = np.repeat(last, n_frames - n, axis=0)
        return self.replace(values=np.vstack([self.values, pad]))

    def resample(self, fps: float, n_frames: int | None = None) -> MotionTrack:
        """The track at another frame rate (e.g. 120 Hz capture -> 30 fps; 24 <-> 25 <-> 30).

        Downsampling first low-passes each channel below the new Nyquist frequency (zero-phase
        4th-order Butterworth at 0.45 x the new rate) so capture jitter does not alias into the
        slower track; then a cubic spline through the frames is read at ``i / fps``. Times past
        the last frame hold its value. ``n_frames`` defaults to ``round(duration * fps)``.
        """
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        n_new = round(self.n_frames * fps / self.fps) if n_frames is None else int(n_frames)
        from scipy import interpolate, signal  # here: importing scipy costs about a second

        src = self.values
        if self.n_frames == 0 or not self.channels:
            return self.replace(fps=fps, values=np.zeros((n_new, len(self.channels))))
        if fps == self.fps:
            return self.replace(fps=fps).fit_length(n_new)
        if fps < self.fps and self.n_frames > 27:
            sos = signal.butter(4, 0.45 * fps, fs=self.fps, output="sos")
            src = signal.sosfiltfilt(sos, src, axis=0)
        t_new = np.minimum(np.arange(n_new) / fps, (self.n_frames - 1) / self.fps)
        if self.n_frames >= 4:
            spline = interpolate.make_interp_spline(self.times, src, k=3, axis=0)
            out = spline(t_new)
        elif self.n_frames >= 2:
            out = interpolate.interp1d(self.times, src, axis=0)(t_new)
        else:
            out = np.repeat(src, n_new, axis=0)
        return self.replace(fps=fps, values=np.asarray(out, dtype=np.float64))

    def equals(self, other: MotionTrack) -> bool:
        """Exact equality of rate, channels and values (metadata aside)."""
        return (
            self.fps == other.fps
            and self.channels == other.channels
            and self.values.shape == other.values.shape
            and bool(np.array_equal(self.values, other.values))
        )


def align_to_features(
    track: MotionTrack, features: SpeechFeatures, offset: float = 0.0
) -> MotionTrack:
    """``track`` at the features' frame rate and frame count, shifted by ``offset`` seconds:
    a ground truth aligned to the speech it goes with (thesis sec. 4.3.2).

    The capture is resampled to the video frame rate of the features (low-passed first when
    downsampling) and cut or padded to the audio's frame count; a positive ``offset`` means the
    capture started ``offset`` seconds after the audio. Frames before the capture starts hold
    its first frame; frames after it ends hold its last. Aligning an aligned track (offset 0)
    returns the same values.
    """
    r = track.resample(features.fps)
    shift = round(offset * features.fps)
    if shift > 0:
        r = r.replace(values=np.vstack([np.repeat(r.values[:1], shift, axis=0), r.values]))
    elif shift < 0:
        r = r.replace(values=r.values[-shift:].copy())
    return r.fit_length(features.n_frames)
