"""facepair's renderer: MPEG-4 FAP motion tracks -> side-by-side talking-face clips.

A built-in parametric head (or a bring-your-own OBJ + feature-point file) is deformed by the
FAPs of each frame, drawn headless with OpenGL (moderngl, EGL), its mouth hidden by a mosaic,
and encoded as a browser-playable H.264/AAC MP4. No Flask here; see docs/reference/renderer.md.
"""

from renderer.api import (
    RENDERER_VERSION,
    RenderSettings,
    load_face,
    render_pair,
    render_single,
    render_still,
)
from renderer.gl import GLUnavailable

__version__ = RENDERER_VERSION

__all__ = [
    "GLUnavailable",
    "RENDERER_VERSION",
    "RenderSettings",
    "load_face",
    "render_pair",
    "render_single",
    "render_still",
]
