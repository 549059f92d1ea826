"""Choice of the headless OpenGL backend, made before MuJoCo is imported (and MuJoCo itself).

MuJoCo fixes its OpenGL backend from ``MUJOCO_GL`` when ``mujoco`` is first imported, so every module
of this package that imports ``mujoco`` imports this one first. A ``MUJOCO_GL`` set by the user is
always respected. Otherwise EGL is used when an EGL device can be initialised (Mesa's llvmpipe on a
CPU-only machine), else OSMesa when ``libOSMesa`` is present; when neither works ``MUJOCO_GL`` is left
unset and :func:`require_backend` raises an error that says what to install.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

from gym4real.core.install_hint import declared_requirement, missing_dependency

#: The distribution that declares MuJoCo.
DIST = "gym4real-robofeeder"

_EGL_PLATFORM_DEVICE_EXT = 0x313F

#: What was chosen and why (reported by ``gym4real info``).
CHOICE: dict[str, str] = {}


def _egl_works() -> bool:
    """Whether an EGL device can be initialised (the way MuJoCo's EGL context opens one)."""
    name = ctypes.util.find_library("EGL")
    if not name:
        return False
    try:
        lib = ctypes.CDLL(name)
        get_proc = lib.eglGetProcAddress
        get_proc.restype = ctypes.c_void_p
        get_proc.argtypes = [ctypes.c_char_p]
        query_addr = get_proc(b"eglQueryDevicesEXT")
        display_addr = get_proc(b"eglGetPlatformDisplayEXT")
        if not query_addr or not display_addr:
            return False
        query = ctypes.CFUNCTYPE(
            ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int)
        )(query_addr)
        get_display = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p)(display_addr)
        lib.eglInitialize.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        lib.eglTerminate.argtypes = [ctypes.c_void_p]
        devices = (ctypes.c_void_p * 8)()
        count = ctypes.c_int(0)
        if not query(8, devices, ctypes.byref(count)):
            return False
        for i in range(count.value):
            display = get_display(_EGL_PLATFORM_DEVICE_EXT, devices[i], None)
            if display and lib.eglInitialize(display, None, None):
                lib.eglTerminate(display)
                return True
    except (OSError, AttributeError, TypeError):
        return False
    return False


def _osmesa_available() -> bool:
    name = ctypes.util.find_library("OSMesa")
    if not name:
        return False
    try:
        ctypes.CDLL(name)
    except OSError:
        return False
    return True


def select_backend() -> str:
    """Set ``MUJOCO_GL`` (if unset and MuJoCo not yet imported) and return the backend in use."""
    if CHOICE:
        return CHOICE["backend"]
    current = os.environ.get("MUJOCO_GL", "").strip().lower()
    if current:
        CHOICE.update(backend=current, reason="MUJOCO_GL set by the user")
    else:
        # `mujoco` imported first with MUJOCO_GL unset has picked GLFW: the renderer then opens the
        # chosen headless context itself (see `rendering.LazyRenderer`)
        direct = "mujoco" in sys.modules
        if _egl_works():
            CHOICE.update(backend="egl", reason="EGL device initialised")
        elif _osmesa_available():
            CHOICE.update(backend="osmesa", reason="no usable EGL device; libOSMesa found")
        else:
            CHOICE.update(backend="", reason="neither an EGL device nor libOSMesa was found")
        if direct and CHOICE["backend"]:
            CHOICE.update(direct="1", reason=CHOICE["reason"] + "; mujoco was imported first, context opened directly")
        elif CHOICE["backend"]:
            os.environ["MUJOCO_GL"] = CHOICE["backend"]
    return CHOICE["backend"]


def context_class() -> type | None:
    """The headless GL context class to force when MuJoCo was imported before the backend was chosen."""
    if not CHOICE.get("direct"):
        return None
    if CHOICE["backend"] == "egl":
        from mujoco.egl import GLContext
    else:
        from mujoco.osmesa import GLContext
    return GLContext


def backend_error(cause: BaseException | None = None) -> str:
    """The message of a rendering failure: what was tried and how to fix it."""
    chosen = CHOICE.get("backend") or "none"
    why = CHOICE.get("reason", "")
    detail = f" ({type(cause).__name__}: {cause})" if cause is not None else ""
    return (
        f"cannot create a headless MuJoCo renderer with backend `{chosen}` ({why}){detail}. "
        "Install Mesa EGL (`apt-get install libegl1 libgl1-mesa-dri`) or OSMesa (`apt-get install libosmesa6`), "
        "and set `MUJOCO_GL=egl` or `MUJOCO_GL=osmesa` before anything imports `mujoco`."
    )


def import_error(exc: BaseException) -> ImportError:
    """The error of a failed ``import mujoco``.

    The ``pip install`` when it is missing; the GL backend's libraries only when the user chose the backend
    (``MUJOCO_GL``) and the failure is about OpenGL; else the failure itself and how to reinstall MuJoCo.
    """
    if isinstance(exc, ModuleNotFoundError) and exc.name == "mujoco":
        return missing_dependency(DIST, "mujoco", "mujoco")
    what = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
    about_gl = any(word in f"{what} {getattr(exc, 'name', '')}".lower() for word in ("opengl", "egl", "osmesa", "glfw"))
    if CHOICE.get("reason") == "MUJOCO_GL set by the user" and about_gl:
        return ImportError(
            f"`import mujoco` failed with MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r} ({what}). Install that "
            "backend's library (`libosmesa6` for osmesa, `libegl1` and `libgl1-mesa-dri` for egl) or unset MUJOCO_GL "
            "to let gym4real.robofeeder choose one."
        )
    reinstall = f'pip install --force-reinstall "{declared_requirement(DIST, "mujoco")}"'
    return ImportError(f"`import mujoco` failed ({what}); reinstall it: `{reinstall}`")


select_backend()

# Only now: MuJoCo fixes its OpenGL backend when first imported. Modules of this package import
# `mujoco` from here (`from gym4real.robofeeder._gl import mujoco`), never directly.
try:
    import mujoco
except (AttributeError, ImportError, OSError) as _exc:  # e.g. MUJOCO_GL=osmesa without libOSMesa (PyOpenGL fails)
    raise import_error(_exc) from None

__all__ = ["CHOICE", "backend_error", "context_class", "mujoco", "select_backend"]
