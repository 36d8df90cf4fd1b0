"""The names the conditions go by in studies and reports (thesis sec. 4.3).

A condition's registry name (``"speech_driven"``) is what a study file and the command line
say; its display name (``"SPEECH_DRIVEN"``) is what a track, a summary and a report show.

Example
-------
>>> DISPLAY_NAMES["none"]
'NO_PROSODY'
"""

from __future__ import annotations

#: Condition name -> the name shown in studies and reports (thesis sec. 4.3).
DISPLAY_NAMES: dict[str, str] = {
    "none": "NO_PROSODY",
    "random": "RANDOM",
    "speech_driven": "SPEECH_DRIVEN",
    "ground_truth": "GROUND_TRUTH",
    "live_gmm": "LIVE_GMM",
}
