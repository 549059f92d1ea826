"""Ray RLlib: every installed Gym4ReaL environment registered with Ray Tune's registry.

Install the ``ray`` extra of core (``ray[rllib]``, which pins gymnasium 1.2.2, the floor Gym4ReaL
supports). On a cluster, start the head with ``ray start --head``, join workers with
``ray start --address=<head>:6379`` and point the driver at it with ``RAY_ADDRESS=<head>:6379``;
then::

    from gym4real.integrations.rllib import register_all
    from ray.rllib.algorithms.ppo import PPOConfig

    register_all()
    algo = PPOConfig().environment("gym4real/dam-v0", env_config={"preset": "train"}).build_algo()

Each env runner makes its own environments from the id (``env_config`` holds ``make()`` keyword
arguments), so heavy handles (EPANET projects, MuJoCo renderers, ONNX sessions) open in the worker.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.registry import list_envs, register_envs


def make_env(env_id: str, env_config: Mapping[str, Any] | None = None, flatten: bool = False) -> gym.Env[Any, Any]:
    """Make a Gym4ReaL env from an RLlib ``env_config`` (a mapping of ``make()`` keyword arguments).

    ``flatten`` wraps it in ``FlattenObservation`` and casts to float32 (dict and discrete observations
    become one float vector, which RLlib's default encoders need).
    """
    register_envs()
    env = gym.make(env_id, **dict(env_config or {}))
    if flatten:
        env = gym.wrappers.DtypeObservation(gym.wrappers.FlattenObservation(env), np.float32)
    return env


def register_all(flatten: bool = False) -> list[str]:
    """Register every installed environment with Ray Tune under its Gymnasium id; return the ids.

    Args:
        flatten: Flatten observations (for envs with ``Dict`` or discrete observations, such as the elevator).
    """
    try:
        from ray.tune.registry import register_env
    except ImportError as exc:
        msg = f'RLlib integration needs ray ({exc.name} is missing): `pip install "gym4real-core[ray]"`'
        raise ImportError(msg) from exc
    ids = list_envs()
    for env_id in ids:
        register_env(env_id, lambda config, env_id=env_id: make_env(env_id, config, flatten))
    return ids
