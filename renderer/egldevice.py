"""Which EGL device draws the frames: a GPU when the machine has one, else Mesa's CPU device.

EGL lists a machine's devices through EGL_EXT_device_enumeration (``eglQueryDevicesEXT``); each
device names its extensions through EGL_EXT_device_query (``eglQueryDeviceStringEXT`` with
``EGL_EXTENSIONS``). Mesa's software device, the one llvmpipe draws on, carries
EGL_MESA_device_software (Khronos EGL registry, "EGL_EXT_device_enumeration",
"EGL_EXT_device_query"; Mesa, docs/_extra/specs/EGL_MESA_device_software.txt: "This can be
distinguished from other device classes in the usual way by calling
eglQueryDeviceStringEXT(EGL_EXTENSIONS) and matching this extension's string"). The order of
the list is the driver's: with NVIDIA's driver and Mesa both installed under glvnd, Mesa's
software device may come first, so taking device 0 (what EGL and moderngl do by default) can
draw on the CPU beside an idle GPU.

:func:`choose_device` picks from a list of :class:`EglDevice` (pure, tested on made-up lists);
:func:`list_devices` asks the EGL library for the real one. The choice can be overridden with
``FACEPAIR_GL_DEVICE`` (:data:`DEVICE_VARIABLE`): ``auto`` (the default: the first device that
is not a software one, else the first), ``gpu`` (the first non-software device, or an error),
``software`` (Mesa's CPU device) or a device's index in the list. glcontext's own
``GLCONTEXT_DEVICE_INDEX``, when set, still wins, as it always did.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from dataclasses import dataclass

from app.errors import InputError

#: Environment variable that overrides the device choice (see the module's docstring).
DEVICE_VARIABLE = "FACEPAIR_GL_DEVICE"
#: glcontext's own variable: a device index that is used as is.
GLCONTEXT_VARIABLE = "GLCONTEXT_DEVICE_INDEX"

#: The device extension of Mesa's software device.
SOFTWARE_EXTENSION = "EGL_MESA_device_software"

# tokens of EGL 1.5 and of EGL_EXT_device_drm / EGL_EXT_device_query_name
_EGL_EXTENSIONS = 0x3055
_EGL_VENDOR = 0x3053
_EGL_DRM_DEVICE_FILE_EXT = 0x3233
_EGL_RENDERER_EXT = 0x335F
_MAX_DEVICES = 32


@dataclass(frozen=True)
class EglDevice:
    """One EGL device: its index in EGL's list, its extensions and what it says of itself
    (vendor and renderer from EGL_EXT_device_query_name, DRM node from EGL_EXT_device_drm;
    empty where the driver does not say)."""

    index: int
    extensions: frozenset[str]
    vendor: str = ""
    renderer: str = ""
    drm_file: str = ""

    @property
    def software(self) -> bool:
        """Whether this is a CPU rasteriser's device (Mesa's software device)."""
        return SOFTWARE_EXTENSION in self.extensions

    def describe(self) -> str:
        """One line naming the device, for logs and error messages."""
        words = [w for w in (self.vendor, self.renderer, self.drm_file) if w]
        kind = "software" if self.software else "hardware"
        return f"EGL device {self.index} ({kind}{': ' + ', '.join(words) if words else ''})"


def choose_device(devices: list[EglDevice], override: str | None = None) -> int | None:
    """The index of the EGL device to draw on, or None to let EGL take its default.

    ``override`` is the value of :data:`DEVICE_VARIABLE` (None or empty: ``auto``). With
    ``auto`` the first non-software device is taken, else the first device; None when EGL
    listed no devices (the extension is missing), so that the default display is used. An
    override that cannot be met (``gpu`` without one, an index past the list, a word not
    understood) raises an :class:`~app.errors.InputError` naming the variable and the devices.
    """
    choice = (override or "auto").strip().lower()
    listed = "; ".join(d.describe() for d in devices) or "none listed"
    if choice == "auto":
        if not devices:
            return None
        hardware = [d for d in devices if not d.software]
        return (hardware or devices)[0].index
    if choice in ("gpu", "software"):
        want_software = choice == "software"
        for d in devices:
            if d.software == want_software:
                return d.index
        raise InputError(
            f"no {choice} EGL device on this machine ({listed})", field=DEVICE_VARIABLE
        )
    try:
        index = int(choice)
    except ValueError:
        raise InputError(
            f"must be auto, gpu, software or a device index, got {override!r}",
            field=DEVICE_VARIABLE,
        ) from None
    if not any(d.index == index for d in devices):
        raise InputError(f"no EGL device {index} ({listed})", field=DEVICE_VARIABLE)
    return index


def list_devices(libegl: str | None = None) -> list[EglDevice]:
    """The EGL devices of this machine, in EGL's order; empty where EGL cannot list them
    (no EGL library, or no EGL_EXT_device_enumeration)."""
    name = libegl or os.environ.get("GLCONTEXT_LINUX_LIBEGL") or ctypes.util.find_library("EGL")
    if not name:
        return []
    try:
        egl = ctypes.CDLL(name)
    except OSError:
        return []
    get_proc = egl.eglGetProcAddress
    get_proc.restype, get_proc.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    query_devices_ptr = get_proc(b"eglQueryDevicesEXT")
    query_string_ptr = get_proc(b"eglQueryDeviceStringEXT")
    if not query_devices_ptr or not query_string_ptr:
        return []
    query_devices = ctypes.CFUNCTYPE(
        ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int)
    )(query_devices_ptr)
    query_string = ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)(
        query_string_ptr
    )
    handles = (ctypes.c_void_p * _MAX_DEVICES)()
    count = ctypes.c_int(0)
    if not query_devices(_MAX_DEVICES, handles, ctypes.byref(count)):
        return []

    def text(handle: int | None, token: int) -> str:
        value = query_string(handle, token)  # NULL (and an EGL error) where not supported
        return value.decode("utf-8", "replace").strip() if value else ""

    devices = []
    for i in range(count.value):
        extensions = frozenset(text(handles[i], _EGL_EXTENSIONS).split())
        named = "EGL_EXT_device_query_name" in extensions
        devices.append(
            EglDevice(
                index=i,
                extensions=extensions,
                vendor=text(handles[i], _EGL_VENDOR) if named else "",
                renderer=text(handles[i], _EGL_RENDERER_EXT) if named else "",
                drm_file=(
                    text(handles[i], _EGL_DRM_DEVICE_FILE_EXT)
                    if "EGL_EXT_device_drm" in extensions
                    else ""
                ),
            )
        )
    return devices


def device_index() -> int | None:
    """The device index to make this process's context on (see :func:`choose_device`);
    None to leave it to glcontext (``GLCONTEXT_DEVICE_INDEX`` set, or nothing listed)."""
    if os.environ.get(GLCONTEXT_VARIABLE):
        return None
    return choose_device(list_devices(), os.environ.get(DEVICE_VARIABLE))
