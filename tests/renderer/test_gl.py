import numpy as np
import pytest

import renderer.gl as gl
from renderer import GLUnavailable
from renderer.deform import Rig
from renderer.headmodel import builtin_face


def test_no_context_gives_one_line_saying_what_to_install(monkeypatch):
    import moderngl

    def fail(**kwargs):
        raise Exception("eglGetDisplay failed\nmore detail")

    monkeypatch.setattr(moderngl, "create_standalone_context", fail)
    monkeypatch.setattr(gl, "_CONTEXTS", {})
    with pytest.raises(GLUnavailable) as info:
        gl.context()
    msg = str(info.value)
    assert "\n" not in msg and "apt-get install libegl1" in msg and "eglGetDisplay" in msg


@pytest.mark.gl
@pytest.mark.parametrize("antialias", gl.ANTIALIAS_MODES)
def test_canvas_draws_faces_on_a_neutral_background(antialias):
    rig = Rig(builtin_face())
    canvas = gl.FaceCanvas(rig, 128, 2, antialias=antialias, samples=4, background=(0.5, 0.5, 0.5))
    try:
        frame = rig.deform(np.zeros(68))
        img = canvas.draw([frame, frame]).copy()
    finally:
        canvas.release()
    assert img.shape == (128, 256, 3)
    assert np.abs(img[2, 2].astype(int) - 128).max() <= 2  # background corner
    assert np.array_equal(img[:, :128], img[:, 128:])
    centre = img[40:90, 40:90].astype(int)
    assert (np.abs(centre - 128).sum(axis=2) > 30).mean() > 0.8  # the face covers the middle


def _outline_frames(rig, mode, frames, size=160):
    canvas = gl.FaceCanvas(rig, size, 1, antialias=mode, background=(0.5, 0.5, 0.5))
    try:
        images = [canvas.draw([f]).astype(int) for f in frames]
        return images, canvas.last_edges[0]
    finally:
        canvas.release()


@pytest.mark.gl
def test_edge_overdraw_stops_the_outline_popping_and_stays_on_it():
    from scipy import ndimage

    rig = Rig(builtin_face())
    frames = []
    for k in range(12):  # the head turns by 0.0004 rad a frame: the outline creeps sub-pixel
        faps = np.zeros(68)
        faps[49 - 1] = 15000.0 + 40.0 * k
        frames.append(rig.deform(faps))
    plain, _ = _outline_frames(rig, "none", frames)
    smooth, n_edges = _outline_frames(rig, "edges", frames)
    assert n_edges > 50
    background = np.abs(plain[0] - 128).max(axis=2) <= 2
    square = np.ones((3, 3), bool)
    outline = ndimage.binary_dilation(background, square, iterations=2) & ndimage.binary_dilation(
        ~background, square, iterations=2
    )

    def worst_jump(images):
        return max(
            np.abs(a - b).max(axis=2)[outline].max()
            for a, b in zip(images, images[1:], strict=False)
        )

    # aliased, outline pixels flip between face and background; overdrawn, they fade
    assert worst_jump(plain) > 35
    assert worst_jump(smooth) < 0.6 * worst_jump(plain)
    # multisampling (the GPU choice) blends both sides of the outline, the overdraw the outside
    multisampled, _ = _outline_frames(rig, "msaa", frames)
    outside = background & ndimage.binary_dilation(~background, square)
    inside = ~background & ndimage.binary_dilation(background, square)
    for images, lo_out, lo_in in ((multisampled, 0.15, 0.15), (smooth, 0.5, 0.0)):
        changed = np.abs(images[0] - plain[0]).max(axis=2) > 3
        assert changed[outside].mean() > lo_out and changed[inside].mean() >= lo_in
    # nothing spills more than two pixels beyond the aliased outline (surfaces just outside
    # the frame may reach into its border) and no face pixel turns into background
    near = ndimage.binary_dilation(~background, square, iterations=2)
    near[[0, -1]] = True
    near[:, [0, -1]] = True
    assert np.array_equal(smooth[0][~near], plain[0][~near])
    assert not (np.abs(smooth[0] - 128).max(axis=2) <= 2)[~background].any()


def test_software_rasterisers_are_told_from_gpus():
    assert gl.is_software("llvmpipe (LLVM 15.0.6, 256 bits)")
    assert not gl.is_software("NVIDIA H200/PCIe/SSE2")


@pytest.mark.gl
def test_the_device_is_named():
    assert gl.device_name().strip()


@pytest.mark.gpu
def test_multisampling_on_a_gpu_smooths_the_outline():
    rig = Rig(builtin_face())
    faps = np.zeros(68)
    faps[49 - 1] = 15000.0
    frame = rig.deform(faps)
    images = {}
    for mode, samples in (("none", 0), ("msaa", 8)):
        canvas = gl.FaceCanvas(
            rig, 256, 1, antialias=mode, samples=samples, background=(0.5, 0.5, 0.5)
        )
        try:
            images[mode] = canvas.draw([frame]).astype(int)
        finally:
            canvas.release()
    outline = np.abs(images["none"] - 128).max(axis=2) > 2
    from scipy import ndimage

    edge = outline ^ ndimage.binary_erosion(outline)
    changed = np.abs(images["msaa"] - images["none"]).max(axis=2) > 3
    assert changed[edge].mean() > 0.3
