"""The EGL device choice: a GPU before Mesa's software device, overrides, the real list."""

import logging

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.errors import InputError
from app.stimuli.track import MotionTrack
from renderer import RenderSettings, gl, render_pair
from renderer import egldevice as ed

SOFTWARE = ed.EglDevice(0, frozenset({"EGL_MESA_device_software", "EGL_EXT_device_drm"}))
NVIDIA = ed.EglDevice(
    1,
    frozenset({"EGL_NV_device_cuda", "EGL_EXT_device_drm", "EGL_EXT_device_query_name"}),
    vendor="NVIDIA",
    renderer="NVIDIA H200",
    drm_file="/dev/dri/card1",
)
SECOND_GPU = ed.EglDevice(2, frozenset({"EGL_NV_device_cuda"}))


def test_a_gpu_is_taken_before_the_software_device_listed_first():
    assert ed.choose_device([SOFTWARE, NVIDIA, SECOND_GPU]) == 1
    assert ed.choose_device([NVIDIA, SOFTWARE]) == 1
    assert ed.choose_device([SOFTWARE, NVIDIA], "auto") == 1


def test_without_a_gpu_the_software_device_and_without_a_list_the_default():
    assert ed.choose_device([SOFTWARE]) == 0
    assert ed.choose_device([]) is None


def test_overrides_pick_software_gpu_or_an_index():
    devices = [SOFTWARE, NVIDIA, SECOND_GPU]
    assert ed.choose_device(devices, "software") == 0
    assert ed.choose_device(devices, " GPU ") == 1
    assert ed.choose_device(devices, "2") == 2
    assert ed.choose_device(devices, "0") == 0


@pytest.mark.parametrize(
    ("devices", "override", "words"),
    [
        ([SOFTWARE], "gpu", "no gpu EGL device"),
        ([NVIDIA], "software", "no software EGL device"),
        ([SOFTWARE, NVIDIA], "5", "no EGL device 5"),
        ([SOFTWARE], "nvidia", "must be auto, gpu, software or a device index"),
    ],
)
def test_an_override_that_cannot_be_met_says_so_in_one_line(devices, override, words):
    with pytest.raises(InputError) as caught:
        ed.choose_device(devices, override)
    message = str(caught.value)
    assert words in message and ed.DEVICE_VARIABLE in message and "\n" not in message


def test_a_device_describes_itself():
    assert NVIDIA.describe() == "EGL device 1 (hardware: NVIDIA, NVIDIA H200, /dev/dri/card1)"
    assert SOFTWARE.describe() == "EGL device 0 (software)"
    assert SOFTWARE.software and not NVIDIA.software


@given(
    override=st.text(max_size=12),
    software=st.lists(st.booleans(), max_size=4),
)
def test_any_override_gives_a_listed_index_or_an_input_error(override, software):
    extensions = [
        frozenset({ed.SOFTWARE_EXTENSION} if s else {"EGL_EXT_device_drm"}) for s in software
    ]
    devices = [ed.EglDevice(i, e) for i, e in enumerate(extensions)]
    try:
        index = ed.choose_device(devices, override)
    except InputError:
        return
    if not devices:
        assert index is None
    else:
        assert index in range(len(devices))


def test_glcontexts_own_variable_is_left_to_glcontext(monkeypatch):
    monkeypatch.setenv(ed.GLCONTEXT_VARIABLE, "0")
    monkeypatch.setenv(ed.DEVICE_VARIABLE, "no such device")
    assert ed.device_index() is None


@pytest.mark.gl
def test_this_machines_devices_are_listed_and_the_choice_is_drawn_on():
    devices = ed.list_devices()
    assert devices, "EGL lists no device although a context can be made"
    assert [d.index for d in devices] == list(range(len(devices)))
    chosen = ed.choose_device(devices)
    # the context is made on the chosen device: a GPU's, unless there is none
    assert gl.is_software(gl.device_name()) == devices[chosen].software


@pytest.mark.gl
def test_the_render_log_names_the_device(tmp_path, caplog):
    t = np.arange(12) / 30.0
    track = MotionTrack.from_channels(30.0, {3: 300 * np.sin(9 * t)})
    with caplog.at_level(logging.INFO, logger="renderer.api"):
        render_pair(track, track, None, tmp_path / "p.mp4", settings=RenderSettings(size=64))
    assert any(gl.device_name() in r.getMessage() for r in caplog.records)


@pytest.mark.gpu
def test_on_a_gpu_machine_the_gpu_is_chosen_without_being_asked(monkeypatch):
    monkeypatch.delenv(ed.DEVICE_VARIABLE, raising=False)
    monkeypatch.delenv(ed.GLCONTEXT_VARIABLE, raising=False)
    devices = ed.list_devices()
    index = ed.choose_device(devices)
    assert index is not None and not devices[index].software
    assert not gl.is_software(gl.device_name())
