"""Ray RLlib: every installed scalar-reward Gym4ReaL environment registered with Ray Tune's registry.

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
Envs with a native batched ``VectorEnv`` (dam, elevator, microgrid, trading) can step all of a
runner's copies at once: ``.env_runners(gym_env_vectorize_mode="vector_entry_point",
num_envs_per_env_runner=N)``.

The vector-reward ids (``gym4real/dam-mo-v0``...) are not registered: RLlib's env checker and learners
take a float reward. Train on one of them through a scalarising wrapper, for example MO-Gymnasium's
``LinearReward`` (extra ``mo``) with one weight per reward component (``env.unwrapped.components``;
unit weights give the scalar env's reward)::

    import numpy as np
    from mo_gymnasium.wrappers import LinearReward
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.tune.registry import register_env

    from gym4real.integrations.rllib import make_env

    weights = np.array([1.0, 1.0, 1.0, 0.5, 1.0])  # deficit, overflow, starving, wasted_water, clipping
    register_env("dam-weighted", lambda config: LinearReward(make_env("gym4real/dam-mo-v0", config), weights))
    algo = PPOConfig().environment("dam-weighted").build_algo()
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.registry import list_envs, register_envs


def make_env(
    env_id: str, env_config: Mapping[str, Any] | None = None, flatten: bool = False
) -> gym.Env[Any, Any] | gym.vector.VectorEnv[Any, Any, Any]:
    """Make a Gym4ReaL env from an RLlib ``env_config`` (a mapping of ``make()`` keyword arguments).

    With ``num_envs`` in the config (RLlib's ``gym_env_vectorize_mode="vector_entry_point"`` asks so), the
    env's native batched ``VectorEnv`` of that many copies, made with the other keys.
    ``flatten`` wraps it in ``FlattenObservation`` and casts to float32 (dict and discrete observations
    become one float vector, which RLlib's default encoders need).

    Raises:
        ValueError: ``num_envs`` for an env without a native vector env.
    """
    register_envs()
    kwargs = dict(env_config or {})
    num_envs = kwargs.pop("num_envs", None)
    if num_envs is None:
        env = gym.make(env_id, **kwargs)
        if flatten:
            env = gym.wrappers.DtypeObservation(gym.wrappers.FlattenObservation(env), np.float32)
        return env
    if gym.spec(env_id).vector_entry_point is None:
        msg = (
            f"`{env_id}` has no native vector env for gym_env_vectorize_mode='vector_entry_point'; "
            "use gym_env_vectorize_mode='sync'"
        )
        raise ValueError(msg)
    vec = gym.make_vec(env_id, int(num_envs), vectorization_mode="vector_entry_point", **kwargs)
    if flatten:
        vec = gym.wrappers.vector.DtypeObservation(gym.wrappers.vector.FlattenObservation(vec), np.float32)
    return vec


def register_all(flatten: bool = False) -> list[str]:
    """Register every installed scalar-reward environment with Ray Tune under its Gymnasium id; return the ids.

    The vector-reward variants (``gym4real/dam-mo-v0``) are left out: RLlib runs them through a scalarising
    wrapper (see the module's docstring).

    Args:
        flatten: Flatten observations (for envs with ``Dict`` or discrete observations, such as the elevator).
    """
    try:
        from ray.tune.registry import register_env
    except ImportError as exc:
        msg = f'RLlib integration needs ray ({exc.name} is missing): `pip install "gym4real-core[ray]"`'
        raise ImportError(msg) from exc
    ids = list_envs(multi_objective=False)
    for env_id in ids:
        register_env(env_id, lambda config, env_id=env_id: make_env(env_id, config, flatten))
    return ids
