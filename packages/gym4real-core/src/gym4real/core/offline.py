"""Offline-RL and imitation datasets: episodes of a registered policy written as a Minari dataset.

Needs the ``offline`` extra of core (``minari[create,hdf5]``; pillow is pinned because minari imports
it without declaring it).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.benchmark import run_episode
from gym4real.core.errors import PolicyError
from gym4real.core.policies import make_policy


def as_recorded(space: gym.Space[Any], policy: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """The policy with its actions in the dtype the dataset stores (a float Box's), before they are stepped.

    A policy may act in a wider float (the dam's historical releases are float64); stepping the stored
    float32 action keeps every transition of the dataset reproducible from its own actions.
    """
    if not (isinstance(space, gym.spaces.Box) and np.issubdtype(space.dtype, np.floating)):
        return policy
    dtype = space.dtype
    return lambda obs: np.asarray(policy(obs)).astype(dtype)


def dataset_id(env_id: str, policy: str) -> str:
    """``gym4real/elevator-v0`` + ``longest_first`` -> ``gym4real/elevator-longest_first-v0``."""
    name, _, version = env_id.rpartition("-v")
    return f"{name}-{policy.replace(':', '_').replace('/', '_')}-v{version}"


def collect(
    env_id: str,
    policy: str,
    episodes: int,
    out: str | Path,
    seed: int = 0,
    env_kwargs: Mapping[str, Any] | None = None,
) -> Path:
    """Run ``episodes`` seeded episodes of ``policy`` and write them as a Minari dataset under ``out``.

    Returns:
        The dataset's folder (load it with ``minari.load_dataset(id)`` and ``MINARI_DATASETS_PATH=out``).

    Raises:
        PolicyError: minari is not installed, or the policy is unknown.
    """
    try:
        import minari
    except ImportError as exc:
        msg = f'dataset collection needs minari ({exc.name} is missing): `pip install "gym4real-core[offline]"`'
        raise PolicyError(msg) from exc
    out = Path(out).resolve()
    previous = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(out)
    try:
        collected = gym.make(env_id, **dict(env_kwargs or {}))
        env = minari.DataCollector(collected)
        acting = as_recorded(env.action_space, make_policy(env_id, policy, env))
        for i in range(episodes):
            run_episode(env, acting, seed + i, None)
        name = dataset_id(env_id, policy)
        dataset = env.create_dataset(
            dataset_id=name,
            eval_env=collected.spec,  # with the overrides: the eval env replays the stored episodes
            algorithm_name=policy,
            author="gym4real",
            description=f"{episodes} episodes of policy `{policy}` on `{env_id}` (seeds {seed}..{seed + episodes - 1})",
        )
        env.close()
        return Path(dataset.spec.data_path).parent
    finally:
        if previous is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = previous
