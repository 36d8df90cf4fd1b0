"""How a face is drawn unless told otherwise: the one place for the renderer's defaults.

:class:`renderer.api.RenderSettings`, :func:`renderer.pipeline.render_frames` and
:class:`renderer.gl.FaceCanvas` all take their defaults from here.

Example
-------
>>> SIZE % 16, ANTIALIAS
(0, 'edges')
"""

from __future__ import annotations

#: Pixels per face, square, a multiple of 16.
SIZE = 368
#: Mouth mosaic cell in pixels: about 3-4 cells across the lips at 368 px, coarse enough to
#: hide lip shape; 0 turns the mosaic off.
MOSAIC_BLOCK = 24
#: The mouth box grows by this fraction of its larger side on every side.
MOSAIC_MARGIN = 0.15
#: Discontinuity edge overdraw (Sander et al. 2001): cheap on a CPU rasteriser.
ANTIALIAS = "edges"
#: Multisampling samples, for ``antialias="msaa"``.
SAMPLES = 4
#: A neutral grey, RGB in 0..1.
BACKGROUND: tuple[float, float, float] = (0.55, 0.56, 0.58)
