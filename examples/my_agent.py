"""Bring your own agent: the two factories ``gym4real evaluate`` imports from your code.

``gym4real evaluate`` runs code of yours named ``module:attr`` (imported from the working folder; trust it
as you trust a plugin). This file holds one of each kind, run from the repository root:

- a **plain factory** ``factory(env, seed=S) -> policy``, called once per environment and training seed
  of ``--seeds``; a policy is a callable ``obs -> action`` which may define ``reset(seed)`` (called at each
  episode start)::

      gym4real evaluate "mine=examples.my_agent:make_policy" --envs gym4real/trading-v0 --seeds 0,1

- a **weight-conditioned factory** for ``--mo``, ``factory(env, weights=w, seed=S) -> policy``, called at
  each of the expected-utility weights ``w`` (one weight per objective, summing to 1; the objectives are
  those ``gym4real info gym4real/dam-mo-v0`` lists, here ``shortage`` then ``flooding``)::

      gym4real evaluate --mo "release=examples.my_agent:make_weighted_policy" --envs gym4real/dam-mo-v0

Replace the bodies with your trained agent: load its weights in the factory (per ``seed``), act in the
policy. docs/evaluate.md walks through the commands and what they print.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np


class SeededRandomPolicy:
    """A policy in the form ``gym4real evaluate`` runs: ``policy(obs) -> action``, with ``reset(seed)``.

    It samples the env's action space from a generator seeded by the training seed and each episode's
    seed, so that a run is reproducible; yours would compute the action from ``obs``.
    """

    def __init__(self, action_space: gym.Space[Any], seed: int) -> None:
        self.action_space = action_space
        self.seed = seed
        self.rng = np.random.default_rng(seed)

    def reset(self, seed: int | None = None) -> None:
        """Called at each episode start with the episode's reset seed (None where the protocol has none)."""
        self.rng = np.random.default_rng([self.seed, 0 if seed is None else seed])

    def __call__(self, obs: Any) -> Any:
        """The action for ``obs``: here a seeded sample of the action space."""
        self.action_space.seed(int(self.rng.integers(2**31)))
        return self.action_space.sample()


def make_policy(env: gym.Env[Any, Any], seed: int = 0) -> SeededRandomPolicy:
    """The plain factory: one policy for ``env`` (the test env, already made) and the training seed ``seed``."""
    return SeededRandomPolicy(env.action_space, seed)


class ConstantRelease:
    """A dam policy releasing one fixed amount every day (m^3/s), within the action space's bounds."""

    def __init__(self, release: float) -> None:
        self.action = np.array([release], dtype=np.float32)

    def __call__(self, obs: Any) -> np.ndarray:
        """The same release whatever ``obs`` says."""
        return self.action


def make_weighted_policy(env: gym.Env[Any, Any], weights: Sequence[float], seed: int = 0) -> ConstantRelease:
    """The weight-conditioned factory of ``--mo`` on ``gym4real/dam-mo-v0``: one policy per weight vector.

    ``weights`` are over the objectives (``shortage``, ``flooding``): the more ``flooding`` weighs, the more
    water is released every day (the lake stays lower; less is kept for the dry season), from the action
    box's low (all weight on shortage) to its high. A trained weight-conditioned agent would take
    ``weights`` as an input instead.
    """
    space = env.action_space
    if not isinstance(space, gym.spaces.Box):
        raise TypeError(f"make_weighted_policy drives the dam's release (a Box action), not {space}")
    w = np.asarray(weights, dtype=float)
    share = float(w[1] / w.sum())
    low, high = float(space.low[0]), float(space.high[0])
    return ConstantRelease(low + share * (high - low))
