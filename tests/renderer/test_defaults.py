import inspect

from renderer import RenderSettings, defaults
from renderer.gl import FaceCanvas
from renderer.pipeline import render_frames


def test_settings_pipeline_and_canvas_share_the_drawing_defaults():
    settings = RenderSettings()
    assert (
        settings.size,
        settings.mosaic_block,
        settings.mosaic_margin,
        settings.antialias,
        settings.samples,
        settings.background,
    ) == (
        defaults.SIZE,
        defaults.MOSAIC_BLOCK,
        defaults.MOSAIC_MARGIN,
        defaults.ANTIALIAS,
        defaults.SAMPLES,
        defaults.BACKGROUND,
    )
    drawing = settings.drawing()
    for fn in (render_frames, FaceCanvas.__init__):
        params = inspect.signature(fn).parameters
        for name in ("antialias", "samples", "background"):
            assert params[name].default == drawing[name], (fn, name)
    params = inspect.signature(render_frames).parameters
    assert params["mosaic_block"].default == drawing["mosaic_block"]
    assert params["mosaic_margin"].default == drawing["mosaic_margin"]


def test_defaults_are_valid_settings():
    RenderSettings(size=defaults.SIZE, mosaic_block=defaults.MOSAIC_BLOCK)  # no InputError
    assert defaults.SIZE % 16 == 0 and defaults.MOSAIC_BLOCK <= defaults.SIZE // 2
