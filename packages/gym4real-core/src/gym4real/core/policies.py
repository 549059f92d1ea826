"""The policy protocol and the plain policies of the plugin API.

A policy is a callable ``obs -> action``. It may define ``reset(seed)``, which the harness calls at
the start of each episode with that episode's seed. Plugins register baselines as factories,
``factory(env) -> policy``, so a policy can read the environment it acts in. Policy strings (baselines,
model files, your own code) are resolved by :mod:`gym4real.bench.policies`.
"""

from __future__ import annotations

from typing import Any, Protocol

import gymnasium as gym


class Policy(Protocol):
    """What the harness calls: the action for an observation."""

    def __call__(self, obs: Any) -> Any:
        """Return the action for ``obs``."""
        ...


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
