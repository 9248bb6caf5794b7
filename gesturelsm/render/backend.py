"""Choosing the offscreen OpenGL backend (OSMesa or EGL) before anything imports OpenGL.

PyOpenGL fixes its platform when `OpenGL` is first imported, from the environment variable
`PYOPENGL_PLATFORM`; pyrender then opens an OSMesa or EGL context from the same variable. So
`select_platform()` must run before `pyrender`/`OpenGL` are imported; every function of this package
that renders calls it first, and importing `gesturelsm.render` calls it (without importing OpenGL).

Order of choice:
1. `PYOPENGL_PLATFORM` already set (egl | osmesa): used as is.
2. `GESTURELSM_GL=egl|osmesa`: that one (no fallback, so a test of one backend tests that backend).
3. Otherwise each backend is probed through ctypes (load the library, create/destroy a tiny context or
   count EGL devices), without importing PyOpenGL: with a GPU device node (/dev/nvidia0) EGL is tried
   first (hardware rendering); without one OSMesa first: on Mesa's llvmpipe it renders ~1.5x faster than
   EGL, whose pyrender path hard-codes 4x MSAA.
When neither works the error names the missing system library and the Debian/Ubuntu packages.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from functools import lru_cache

from ..errors import RenderError

BACKENDS = ("osmesa", "egl")
PACKAGES = {"osmesa": "libosmesa6", "egl": "libegl1 libegl-mesa0 libgl1-mesa-dri"}
LIBRARIES = {"osmesa": "libOSMesa.so (OSMesa)", "egl": "libEGL.so.1 (EGL)"}


def _load(names: tuple[str, ...]) -> ctypes.CDLL:
    errors = []
    for name in names:
        if name is None:
            continue
        try:
            return ctypes.CDLL(name)
        except OSError as exc:
            errors.append(str(exc))
    raise OSError("; ".join(errors) or "not found")


def _probe_osmesa() -> None:
    lib = _load((ctypes.util.find_library("OSMesa"), "libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"))
    create = lib.OSMesaCreateContextExt
    create.restype = ctypes.c_void_p
    create.argtypes = [ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_void_p]
    ctx = create(0x1908, 24, 0, 0, None)                   # GL_RGBA, 24-bit depth
    if not ctx:
        raise OSError("OSMesaCreateContextExt returned NULL")
    lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
    lib.OSMesaDestroyContext(ctx)
    if not hasattr(lib, "OSMesaCreateContextAttribs"):
        raise OSError("this OSMesa lacks OSMesaCreateContextAttribs (needs Mesa >= 12)")


def _probe_egl() -> None:
    lib = _load((ctypes.util.find_library("EGL"), "libEGL.so.1", "libEGL.so"))
    lib.eglGetProcAddress.restype = ctypes.c_void_p
    lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    addr = lib.eglGetProcAddress(b"eglQueryDevicesEXT")
    if not addr:
        raise OSError("EGL has no eglQueryDevicesEXT (is libegl-mesa0 installed?)")
    query = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(ctypes.c_int))(addr)
    n = ctypes.c_int(0)
    if not query(0, None, ctypes.byref(n)) or n.value < 1:
        raise OSError("EGL reports no rendering device (is libgl1-mesa-dri installed?)")


_PROBES = {"osmesa": _probe_osmesa, "egl": _probe_egl}


def _order() -> tuple[str, ...]:
    return ("egl", "osmesa") if os.path.exists("/dev/nvidia0") else ("osmesa", "egl")


@lru_cache(maxsize=1)
def select_platform() -> str:
    """Set PYOPENGL_PLATFORM (and PYGLET_HEADLESS) once per process and return the backend name.

    Runs when `gesturelsm.render` is imported (errors are kept for the first render) and again, cached,
    before each renderer is made."""
    os.environ.setdefault("PYGLET_HEADLESS", "true")
    chosen = os.environ.get("PYOPENGL_PLATFORM", "").lower()
    if chosen:
        if chosen not in BACKENDS:
            raise RenderError(f"PYOPENGL_PLATFORM={chosen!r} cannot render offscreen; use 'osmesa' or 'egl' "
                              "(or unset it to choose automatically)")
        return chosen
    if "OpenGL" in sys.modules:
        raise RenderError("OpenGL was imported before gesturelsm.render chose a backend; set "
                          "PYOPENGL_PLATFORM=osmesa (or egl) in the environment, or import gesturelsm.render first")
    forced = os.environ.get("GESTURELSM_GL", "").lower()
    if forced and forced not in BACKENDS:
        raise RenderError(f"GESTURELSM_GL={forced!r}: use 'osmesa' or 'egl'")
    name = choose_backend((forced,) if forced else _order())
    os.environ["PYOPENGL_PLATFORM"] = name
    return name


def choose_backend(candidates: tuple[str, ...], probes: dict | None = None) -> str:
    """The first candidate whose probe passes; else a RenderError naming each missing library and package."""
    probes = probes or _PROBES
    failures = []
    for name in candidates:
        try:
            probes[name]()
        except (OSError, AttributeError) as exc:
            failures.append(f"{name}: {LIBRARIES[name]} unusable ({exc}); install: apt-get install {PACKAGES[name]}")
            continue
        return name
    raise RenderError("No offscreen OpenGL backend works on this machine (rendering needs OSMesa or EGL "
                      "from Mesa).\n  " + "\n  ".join(failures))
