"""Policies for the benchmark harness: registered baselines, trained models and plain callables.

A policy is a callable ``obs -> action``. It may define ``reset(seed)``, which the harness calls at
the start of each episode with that episode's seed. Plugins register baselines as factories,
``factory(env) -> policy``, so a policy can read the environment it acts in.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import gymnasium as gym

from gym4real.core.errors import PolicyError
from gym4real.core.registry import base_env, registry
from gym4real.wrappers.multi_objective import MultiObjective


class Policy(Protocol):
    """What the harness calls: the action for an observation."""

    def __call__(self, obs: Any) -> Any:
        """Return the action for ``obs``."""
        ...


def load_object(path: str) -> Any:
    """Import ``"module:attr"`` (attr may be dotted)."""
    module, _, attr = path.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


class RandomPolicy:
    """Uniform random actions from the action space, seeded at each episode."""

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        self.space = env.action_space

    def reset(self, seed: int | None = None) -> None:
        """Seed the action space's generator."""
        self.space.seed(seed)

    def __call__(self, obs: Any) -> Any:
        """Return a random action."""
        return self.space.sample()


class ConstantPolicy:
    """The same action at every step."""

    def __init__(self, action: Any) -> None:
        self.action = action

    def __call__(self, obs: Any) -> Any:
        """Return the constant action."""
        return self.action


def random_policy(env: gym.Env[Any, Any]) -> RandomPolicy:
    """Baseline factory: uniform random actions (every env registers it as ``random``)."""
    return RandomPolicy(env)


#: Prefix of a ``kind:path`` policy string -> ``"module:loader"``; ``loader(env, path)`` returns a policy.
MODEL_LOADERS: dict[str, str] = {
    "ppo": "gym4real.core.rl.sb3:load_ppo",
    "dqn": "gym4real.core.rl.sb3:load_dqn",
    "qlearning": "gym4real.core.rl.tabular:load_policy",
    "sarsa": "gym4real.core.rl.tabular:load_policy",
}


def baseline_names(env_id: str) -> list[str]:
    """Return the names of the baselines registered for an environment (a vector-reward variant: its env's)."""
    return sorted(registry().baselines.get(base_env(env_id), {}))


def make_policy(env_id: str, policy: str | Callable[[Any], Any], env: gym.Env[Any, Any]) -> Callable[[Any], Any]:
    """Turn a policy reference into a callable policy.

    Args:
        env_id: The environment's id (baselines are looked up under it; a vector-reward variant such as
            ``gym4real/dam-mo-v0`` uses the baselines of the env it wraps).
        policy: A baseline name (``longest_first``), a trained model as ``kind:path``
            (``ppo:runs/dam/model.zip``, ``qlearning:runs/elevator/qtable.npz``), or a callable.
        env: The environment the policy will act in.

    Raises:
        PolicyError: An unknown name or kind, or a model file that does not fit the environment.
    """
    if callable(policy):
        return policy
    if isinstance(env.unwrapped, MultiObjective):  # same spaces; a baseline may read the env it acts in
        env = env.unwrapped.env
    kind, sep, path = policy.partition(":")
    if sep:
        if kind not in MODEL_LOADERS:
            raise PolicyError(f"unknown policy kind `{kind}` in `{policy}`; expected one of {sorted(MODEL_LOADERS)}")
        if not Path(path).is_file():
            raise PolicyError(f"policy file `{path}` (from `{policy}`) does not exist")
        policy_from_file: Callable[[Any], Any] = load_object(MODEL_LOADERS[kind])(env, path)
        return policy_from_file
    baselines = registry().baselines.get(base_env(env_id), {})
    if policy not in baselines:
        raise PolicyError(
            f"unknown policy `{policy}` for `{env_id}`; baselines: {sorted(baselines)}, or `ppo:PATH`, "
            f"`dqn:PATH`, `qlearning:PATH`, `sarsa:PATH` for a trained model"
        )
    built: Callable[[Any], Any] = load_object(baselines[policy].entry_point)(env)
    return built
