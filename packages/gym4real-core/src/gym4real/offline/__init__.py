"""Offline-RL and imitation datasets: episodes of a registered policy written as a Minari dataset.

Needs the ``offline`` extra of core (``minari[hdf5]``; pillow is pinned because minari imports it
without declaring it). The episodes are recorded here and written with minari's
``create_dataset_from_buffers``: minari's ``DataCollector`` would need jax (``minari[create]``, about
380 MB) only to append steps to its buffers.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from gym4real.bench.benchmark import run_episode
from gym4real.bench.policies import make_policy
from gym4real.core.errors import PolicyError


def as_recorded(space: gym.Space[Any], policy: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """The policy with its actions in the dtype the dataset stores (a float Box's), before they are stepped.

    A policy may act in a wider float (the dam's historical releases are float64); stepping the stored
    float32 action keeps every transition of the dataset reproducible from its own actions.
    """
    if not (isinstance(space, gym.spaces.Box) and np.issubdtype(space.dtype, np.floating)):
        return policy
    dtype = space.dtype
    return lambda obs: np.asarray(policy(obs)).astype(dtype)


class Recorder(gym.Wrapper[Any, Any, Any, Any]):
    """Records every episode it runs as lists of observations (the first one included), actions and rewards."""

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        super().__init__(env)
        self.episodes: list[dict[str, Any]] = []

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset the env and open a new episode record."""
        obs, info = self.env.reset(seed=seed, options=options)
        self.episodes.append({"seed": seed, "observations": [obs], "actions": [], "rewards": [], "ends": []})
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env and add the transition to the open episode record."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        episode = self.episodes[-1]
        episode["observations"].append(obs)
        episode["actions"].append(action)
        episode["rewards"].append(reward)
        episode["ends"].append((terminated, truncated))
        return obs, reward, terminated, truncated, info


def stacked(space: gym.Space[Any], values: list[Any]) -> Any:
    """Per-step values of a space as Minari stores them: a list of leaves, nested like a Dict or Tuple space."""
    if isinstance(space, gym.spaces.Dict):
        return {key: stacked(sub, [v[key] for v in values]) for key, sub in space.spaces.items()}
    if isinstance(space, gym.spaces.Tuple):
        return tuple(stacked(sub, [v[i] for v in values]) for i, sub in enumerate(space.spaces))
    return values


def episode_buffer(env: gym.Env[Any, Any], index: int, episode: dict[str, Any]) -> Any:
    """One recorded episode as a ``minari.data_collector.EpisodeBuffer``."""
    from minari.data_collector import EpisodeBuffer

    return EpisodeBuffer(
        id=index,
        seed=episode["seed"],
        observations=stacked(env.observation_space, episode["observations"]),
        actions=stacked(env.action_space, episode["actions"]),
        rewards=episode["rewards"],
        terminations=[t for t, _ in episode["ends"]],
        truncations=[t for _, t in episode["ends"]],
        infos={},  # not recorded, as minari's DataCollector by default
    )


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
        from minari.data_collector.callbacks import EpisodeMetadataCallback
    except ImportError as exc:
        msg = f'dataset collection needs minari ({exc.name} is missing): `pip install "gym4real-core[offline]"`'
        raise PolicyError(msg) from exc
    out = Path(out).resolve()
    previous = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(out)
    try:
        collected = gym.make(env_id, **dict(env_kwargs or {}))
        env = Recorder(collected)
        acting = as_recorded(env.action_space, make_policy(env_id, policy, env))
        for i in range(episodes):
            run_episode(env, acting, seed + i, None)
        env.close()
        dataset = minari.create_dataset_from_buffers(
            dataset_id=dataset_id(env_id, policy),
            buffer=[episode_buffer(collected, i, ep) for i, ep in enumerate(env.episodes)],
            env=collected,  # its spec carries the overrides
            eval_env=collected.spec,  # so the eval env replays the stored episodes too
            algorithm_name=policy,
            author="gym4real",
            description=f"{episodes} episodes of policy `{policy}` on `{env_id}` (seeds {seed}..{seed + episodes - 1})",
        )
        dataset.storage.update_episode_metadata(dataset.storage.apply(EpisodeMetadataCallback()))
        return Path(dataset.spec.data_path).parent
    finally:
        if previous is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = previous
