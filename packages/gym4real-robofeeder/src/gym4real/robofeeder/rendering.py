"""Headless offscreen rendering: a lazily created MuJoCo renderer that the env closes.

The OpenGL backend is chosen in :mod:`gym4real.robofeeder._gl` (EGL, else OSMesa, else a clear error).
Shadows, reflections and the skybox are off unless asked for: they do not change the top-down view of
the bin (checked pixel for pixel) and cost two thirds of the render time on a software rasteriser.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gym4real.robofeeder import _gl
from gym4real.robofeeder._gl import mujoco


class RenderingError(RuntimeError):
    """No headless OpenGL backend could create a renderer."""


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

    def render(self, data: mujoco.MjData, camera: str = "top_down") -> np.ndarray:
        """An RGB frame (uint8, height x width x 3) of ``camera``."""
        if self._renderer is None:
            self._renderer = self._open()
        option = self._top_down_option if camera == "top_down" else self._option
        self._renderer.update_scene(data, camera=camera, scene_option=option)
        return np.asarray(self._renderer.render())

    def close(self) -> None:
        """Free the OpenGL context (a later frame opens a new one)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def grayscale(rgb: np.ndarray) -> np.ndarray:
    """The reference's grayscale: (R, G, B) . (0.2989, 0.5870, 0.1140) / 255, float32 in [0, 1]."""
    weights = np.array([0.2989, 0.5870, 0.1140], dtype=np.float32)
    gray = rgb.astype(np.float32) @ weights / np.float32(255.0)
    return np.clip(gray, 0.0, 1.0, out=gray)


def engine_info() -> dict[str, Any]:
    """Run-time facts for ``gym4real info``: MuJoCo version and the OpenGL backend."""
    return {
        "engine": "MuJoCo",
        "mujoco": mujoco.__version__,
        "gl_backend": _gl.CHOICE.get("backend") or "none",
        "gl_backend_reason": _gl.CHOICE.get("reason", ""),
    }
