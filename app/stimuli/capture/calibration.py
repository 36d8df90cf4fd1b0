"""Calibrating the marker capture's constants on a head of known pose, as the thesis did.

Thesis sec. 3.2.2: the pitch constant ``kp`` (0.15) was measured by leaning a styrofoam head
wearing the frame 17 degrees forward and back, and ``ky`` (0.05) by turning it 8 degrees.
Those numbers belong to that camera, frame and head: the ratio change a lean gives grows with
the frame's height and shrinks with the camera's distance. :func:`calibrate` measures them
on any capture of a neutral face whose head angles are known (a dummy head on a protractor,
or a rendered clip), by least squares over all frames rather than at two poses:

* ``HRatio - HRatio_0`` and ``VRatio - VRatio_0`` are fitted as ``a * pitch + b * yaw``
  (the two are coupled, sec. 3.2.2); ``kp = a_pitch * theta_p``, ``ky = b_yaw * theta_y``:
  the ratio change at the largest angle, the thesis' definition;
* the eyebrow raises the face does not make (the post-corrected distances of
  :func:`~app.stimuli.capture.marker_faps.brow_distances`) are fitted against pitch alike,
  giving ``brow_pitch_inner`` and ``brow_pitch_middle`` (ENS units per radian), which the
  capture then subtracts: the nose bridge is not in the eyebrows' plane, so leaning changes
  the distances (the reason sec. 3.2.4 gives for the lips' correction failing on eyebrows).

Example
-------
>>> c = calibrate(tracks, truth)                              # doctest: +SKIP
>>> c.to_json("constants.json")                               # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from app.errors import InputError
from app.stimuli.capture.labelling import MarkerTracks
from app.stimuli.capture.marker_faps import (
    DEFAULT_CONSTANTS,
    MarkerConstants,
    brow_distances,
    post_geometry,
)
from app.stimuli.fap import AU_RADIANS, HEAD_PITCH, HEAD_YAW
from app.stimuli.track import MotionTrack


def calibrate(
    tracks: MarkerTracks, truth: MotionTrack, base: MarkerConstants = DEFAULT_CONSTANTS
) -> MarkerConstants:
    """``base`` with ``kp``, ``ky`` and the eyebrows' pitch couplings measured on ``tracks``,
    a capture of a neutral face whose head pitch and yaw are ``truth``'s FAPs 48 and 49
    (sampled at the capture's time stamps)."""
    times = tracks.times - tracks.times[0]
    pitch = np.interp(times, truth.times, truth.get(HEAD_PITCH)) * AU_RADIANS
    yaw = np.interp(times, truth.times, truth.get(HEAD_YAW)) * AU_RADIANS
    design = np.column_stack([pitch - pitch[0], yaw - yaw[0]])
    if np.ptp(design[:, 0]) < np.radians(1.0) or np.ptp(design[:, 1]) < np.radians(1.0):
        raise InputError(
            "the calibration needs the head to pitch and to yaw by a few "
            "degrees at least (FAPs 48 and 49 of the known motion)"
        )
    geometry = post_geometry(tracks)
    brows = brow_distances(tracks, geometry, base)
    measured = np.column_stack(
        [
            geometry["hratio"] - geometry["hratio"][0],
            geometry["vratio"] - geometry["vratio"][0],
            brows["inner"],
            brows["middle"],
        ]
    )
    coef = np.linalg.lstsq(design, measured, rcond=None)[0]  # (2, 4): pitch, yaw rows
    return replace(
        base,
        kp=float(coef[0, 0] * np.radians(base.pitch_max_deg)),
        ky=float(coef[1, 1] * np.radians(base.yaw_max_deg)),
        brow_pitch_inner=float(coef[0, 2]),
        brow_pitch_middle=float(coef[0, 3]),
    )
