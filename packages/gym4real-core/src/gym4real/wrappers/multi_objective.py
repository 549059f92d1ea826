"""Multi-objective view of an environment (MO-Gymnasium API), without requiring mo-gymnasium."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces


class MultiObjective(gym.Env[Any, Any]):
    """Vector reward: the env's reward components, in a fixed order, with a declared ``reward_space``.

    The vector holds the weighted components of ``info["reward_components"]``, which sum to the scalar
    reward, so MO-Gymnasium's ``LinearReward`` with unit weights recovers it exactly. The scalar reward is
    kept in ``info["scalar_reward"]``. This is an environment that owns the wrapped one (not a
    ``gym.Wrapper``) because MO-Gymnasium reads ``reward_space`` from ``env.unwrapped``.

    Args:
        env: A Gym4ReaL environment, or its id (made with ``**kwargs``).
        components: Component names, in order; default: the env's ``reward_component_names``.
        **kwargs: ``make()`` arguments when ``env`` is an id.
    """

    #: The render modes a Gym4ReaL env may have (``gymnasium.make`` reads them from the class); each
    #: instance holds its owned env's ``metadata``, and the owned env rejects a mode it lacks.
    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(self, env: gym.Env[Any, Any] | str, components: Sequence[str] | None = None, **kwargs: Any) -> None:
        self.env = gym.make(env, **kwargs) if isinstance(env, str) else env
        names = components or getattr(self.env.unwrapped, "reward_component_names", None)
        if not names:
            msg = f"{self.env.unwrapped.__class__.__name__} declares no `reward_component_names`; pass `components=`"
            raise ValueError(msg)
        self.components = tuple(names)
        self.observation_space = self.env.observation_space
        self.action_space = self.env.action_space
        self.reward_dim = len(self.components)
        self.reward_space = spaces.Box(-np.inf, np.inf, shape=(self.reward_dim,), dtype=np.float64)
        self.metadata = self.env.metadata
        self.render_mode = self.env.render_mode

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset the owned environment."""
        super().reset(seed=seed)
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, np.ndarray, bool, bool, dict[str, Any]]:
        """Step and return the vector of reward components."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        comps = info["reward_components"]
        if set(comps) != set(self.components):
            raise KeyError(f"reward components {sorted(comps)} do not match {list(self.components)}")
        info["scalar_reward"] = reward
        vector = np.array([comps[c] for c in self.components], dtype=np.float64)
        return obs, vector, terminated, truncated, info

    def render(self) -> Any:
        """Render the owned environment."""
        return self.env.render()

    def close(self) -> None:
        """Close the owned environment."""
        self.env.close()


def scalar_env(env: gym.Env[Any, Any]) -> gym.Env[Any, Any]:
    """The unwrapped scalar-reward env behind ``env``: through a :class:`MultiObjective` view to the env it owns.

    A planner or any code that needs the domain's own env class calls this on what ``gymnasium.make`` returned,
    whether the id was the scalar one (``gym4real/dam-v0``) or its vector-reward variant (``gym4real/dam-mo-v0``).

    Args:
        env: An environment, wrapped or not.
    """
    base = env.unwrapped
    return base.env.unwrapped if isinstance(base, MultiObjective) else base
