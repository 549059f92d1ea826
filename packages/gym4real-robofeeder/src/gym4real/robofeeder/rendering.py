"""Headless offscreen rendering: a lazily created MuJoCo renderer that the env closes.

The OpenGL backend is chosen in :mod:`gym4real.robofeeder._gl` (EGL, else OSMesa, else a clear error).
Shadows, reflections and the skybox are off unless asked for: they do not change the top-down view of
the bin (checked pixel for pixel) and cost two thirds of the render time on a software rasteriser.

Forks (``AsyncVectorEnv``'s default start method on Linux): a child cannot render with the EGL display
it inherits (Mesa's rasteriser threads are not copied, and its first frame waits for them for good).
So before every fork the open renderers are closed and MuJoCo's EGL display is terminated; parent and
child each open a fresh one at their next frame. When a MuJoCo renderer that is not ours still holds
the display, it is left alone and the child's first frame raises :class:`RenderingError` at once, with
the fix (the ``spawn`` start method), instead of hanging.
"""

from __future__ import annotations

import gc
import os
import sys
import threading
import weakref
from typing import Any

import numpy as np

from gym4real.robofeeder import _gl
from gym4real.robofeeder._gl import mujoco
from gym4real.robofeeder.portable_math import dot


class RenderingError(RuntimeError):
    """No headless OpenGL backend could create a renderer."""


#: Renderers with an open context, closed before a fork.
_OPEN: weakref.WeakSet[LazyRenderer] = weakref.WeakSet()
#: Held while a context is opened, used or closed, and across a fork.
_LOCK = threading.RLock()
#: Set in a forked child that inherited a live EGL display: its frames would never finish.
_INHERITED_DISPLAY = False

FORK_FIX = (
    "create the vector env with the `spawn` start method: `gym.vector.AsyncVectorEnv(fns, context='spawn')` or "
    "`gym.make_vec(id, n, vectorization_mode='async', vector_kwargs={'context': 'spawn'})`, or close the other "
    "MuJoCo renderers of the parent before it forks"
)


def _egl_module() -> Any:
    """MuJoCo's EGL module when a display of it is initialised, else None."""
    egl = sys.modules.get("mujoco.egl")
    return egl if egl is not None and getattr(egl, "EGL_DISPLAY", None) is not None else None


def _before_fork() -> None:
    _LOCK.acquire()
    egl = _egl_module()
    if egl is None:
        return
    for renderer in list(_OPEN):
        renderer.close()
    if any(issubclass(type(o), egl.GLContext) and o._context for o in gc.get_objects()):
        return  # a renderer of someone else uses the display: the child is told so at its first frame
    egl.EGL.eglTerminate(egl.EGL_DISPLAY)
    egl.EGL_DISPLAY = None


def _after_fork_in_parent() -> None:
    _LOCK.release()


def _after_fork_in_child() -> None:
    global _LOCK, _INHERITED_DISPLAY
    _LOCK = threading.RLock()
    _INHERITED_DISPLAY = _egl_module() is not None


os.register_at_fork(before=_before_fork, after_in_parent=_after_fork_in_parent, after_in_child=_after_fork_in_child)


class LazyRenderer:
    """A ``mujoco.Renderer`` created on the first frame and freed by :meth:`close`.

    Args:
        model: The model to render.
        width: Image width (px).
        height: Image height (px).
        effects: Keep shadows, reflections and the skybox.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int, effects: bool = False) -> None:
        self.model = model
        self.width = width
        self.height = height
        self.effects = effects
        self._renderer: mujoco.Renderer | None = None
        self._option = mujoco.MjvOption()
        # the top-down camera never sees the robot (out of view at every observation) nor the floor and the
        # transparent pick plane: hiding geom groups 0 and 1 leaves its image unchanged and halves its cost
        self._top_down_option = mujoco.MjvOption()
        self._top_down_option.geomgroup[0] = 0
        self._top_down_option.geomgroup[1] = 0

    @property
    def is_open(self) -> bool:
        """Whether the OpenGL context exists."""
        return self._renderer is not None

    def _open(self) -> mujoco.Renderer:
        if not _gl.CHOICE.get("backend"):
            raise RenderingError(_gl.backend_error())
        if _INHERITED_DISPLAY:
            raise RenderingError(
                f"process {os.getpid()} was forked from one whose EGL display was in use by another MuJoCo "
                f"renderer; a frame rendered here would never finish. Fix: {FORK_FIX}"
            )
        try:
            forced = _gl.context_class()
            if forced is None:
                renderer = mujoco.Renderer(self.model, height=self.height, width=self.width)
            else:
                # mujoco chose GLFW at its import: hand its Renderer the headless context class for this one
                # construction (Renderer reads `gl_context.GLContext` when it is built), then restore it
                from mujoco.rendering.classic import gl_context

                saved = gl_context.GLContext
                gl_context.GLContext = forced
                try:
                    renderer = mujoco.Renderer(self.model, height=self.height, width=self.width)
                finally:
                    gl_context.GLContext = saved
        except Exception as exc:  # the GL libraries raise assorted error types
            raise RenderingError(_gl.backend_error(exc)) from exc
        if not self.effects:
            for flag in (
                mujoco.mjtRndFlag.mjRND_SHADOW,
                mujoco.mjtRndFlag.mjRND_REFLECTION,
                mujoco.mjtRndFlag.mjRND_SKYBOX,
            ):
                renderer.scene.flags[flag] = 0
        return renderer

    def render(self, data: mujoco.MjData, camera: str = "top_down", robot: bool = False) -> np.ndarray:
        """An RGB frame (uint8, height x width x 3) of ``camera``; ``robot`` shows the arm in the top-down view too."""
        with _LOCK:
            if self._renderer is None:
                self._renderer = self._open()
                _OPEN.add(self)
            option = self._top_down_option if camera == "top_down" and not robot else self._option
            self._renderer.update_scene(data, camera=camera, scene_option=option)
            return np.asarray(self._renderer.render())

    def close(self) -> None:
        """Free the OpenGL context (a later frame opens a new one)."""
        with _LOCK:
            if self._renderer is not None:
                self._renderer.close()
                self._renderer = None
            _OPEN.discard(self)


def grayscale(rgb: np.ndarray) -> np.ndarray:
    """The reference's grayscale: (R, G, B) . (0.2989, 0.5870, 0.1140) / 255, float32 in [0, 1]."""
    weights = np.array([0.2989, 0.5870, 0.1140], dtype=np.float32)
    gray = dot(rgb.astype(np.float32), weights) / np.float32(255.0)
    return np.clip(gray, 0.0, 1.0, out=gray)


def engine_info() -> dict[str, Any]:
    """Run-time facts for ``gym4real info``: MuJoCo version and the OpenGL backend."""
    return {
        "engine": "MuJoCo",
        "mujoco": mujoco.__version__,
        "gl_backend": _gl.CHOICE.get("backend") or "none",
        "gl_backend_reason": _gl.CHOICE.get("reason", ""),
    }
