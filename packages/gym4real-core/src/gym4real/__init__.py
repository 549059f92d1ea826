"""Gym4ReaL: realistic reinforcement-learning environments with the Gymnasium API.

Each domain (``gym4real.dam``, ``gym4real.wds``, ...) is a separate distribution that contributes a
portion of this namespace and registers its environments through the ``gym4real.plugins`` entry
point group. Importing ``gym4real`` registers every installed environment with Gymnasium; the heavy
simulator imports happen only when an environment is made.
"""

# Must stay the first statement: lets the domain distributions' portions join this package.
__path__ = __import__("pkgutil").extend_path(__path__, __name__)

from typing import TYPE_CHECKING

from gym4real.core import (
    env_info,
    list_envs,
    make,
    plugin_errors,
    register_envs,
)

if TYPE_CHECKING:  # imported lazily at run time (``__getattr__``)
    from gym4real.bench.benchmark import benchmark
    from gym4real.bench.evaluate import evaluate
    from gym4real.bench.mo_eval import evaluate_mo

__all__ = ["benchmark", "env_info", "evaluate", "evaluate_mo", "list_envs", "make", "plugin_errors", "register_envs"]


def __getattr__(name: str) -> object:
    if name in ("benchmark", "evaluate"):  # measurement: the `bench` extra, imported on first use
        from gym4real.core.install_hint import require_extra

        require_extra("bench", f"`gym4real.{name}`")
    if name == "benchmark":
        from gym4real.bench.benchmark import benchmark

        return benchmark
    if name == "evaluate":
        from gym4real.bench.evaluate import evaluate

        return evaluate
    if name == "evaluate_mo":  # imports pandas and scipy: only on first use
        from gym4real.bench.mo_eval import evaluate_mo

        return evaluate_mo
    raise AttributeError(f"module `gym4real` has no attribute `{name}`")


register_envs()
