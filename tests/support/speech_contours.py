"""Speech contours whose eyebrow raises are known, for the tests of the eyebrow rule and of the
speech-driven condition built on it (``tests/stimuli/conditions/``). Nothing here is part of the
application."""

from __future__ import annotations

import numpy as np


def known_contours():
    """F0 rises across 207 Hz at frames 10, 60 and 100; intensity drops at known frames."""
    n = 150
    f0 = np.full(n, 150.0)
    f0[10:25] = np.linspace(210, 260, 15)  # crossing at 10, peak inside the hold
    f0[60:70] = 230.0  # crossing at 60
    f0[100:104] = 220.0  # crossing at 100, brief
    intensity = np.full(n, 60.0)
    intensity[30:35] = 40.0  # first drop below 45 dB after the hold of raise 1: release at 30
    intensity[62:65] = 40.0  # a drop inside raise 2's 300 ms hold: ignored
    intensity[80:90] = 40.0  # raise 2 released at 80
    intensity[105:] = 40.0  # raise 3: quiet from 105, so it ends right after its hold
    return f0, intensity
