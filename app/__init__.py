"""facepair: perceptual paired-comparison studies of talking-face animation.

The package root holds the version and nothing that imports Flask: the pure packages
(``app.stimuli``, ``app.trials``, ``app.analysis``) and the renderer import it without loading
the web stack, which lives in ``app.web`` (``create_app``).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    # The one place the version is written is pyproject.toml.
    __version__ = version("facepair")
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"
