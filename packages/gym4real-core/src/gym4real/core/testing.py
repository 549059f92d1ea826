"""Contract checks shared by every domain's test suite (installed code, so each suite can import it)."""

from __future__ import annotations

import dataclasses
import json
import pickle
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env


def rollout(env: gym.Env[Any, Any], seed: int, steps: int, options: dict[str, Any] | None = None) -> list[Any]:
    """Reset with ``seed`` and take ``steps`` actions drawn from the action space seeded with ``seed``."""
    obs, _ = env.reset(seed=seed, options=options)
    env.action_space.seed(seed)
    trace: list[Any] = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        trace += [obs, reward, terminated, truncated]
        if terminated or truncated:
            break
    return trace


def assert_same_trace(a: list[Any], b: list[Any]) -> None:
    """Assert two rollouts are identical (observations compared element-wise)."""
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if isinstance(x, dict):
            assert x.keys() == y.keys()
            for k in x:
                np.testing.assert_array_equal(x[k], y[k])
        else:
            np.testing.assert_array_equal(x, y)


def check_contract(env_id: str, steps: int = 50, seeded: bool = True, **kwargs: Any) -> None:
    """The contract of every Gym4ReaL env.

    Gymnasium's ``check_env``; same seed, same trajectory; a fresh env survives a pickle round-trip;
    ``env.spec`` round-trips through JSON; ``info["reward_components"]`` sums to the reward (to the sum of a
    vector reward).

    Args:
        env_id: The registered id.
        steps: Steps of each rollout.
        seeded: False for a mode whose randomness ``reset(seed=)`` does not drive (the reference's
            behaviour in some ``fidelity="upstream"`` modes): the same-seed checks are skipped.
        **kwargs: Keyword arguments of ``gymnasium.make``.
    """
    env = gym.make(env_id, **kwargs)
    try:
        if not seeded and env.spec is not None:
            env.unwrapped.spec = dataclasses.replace(env.spec, nondeterministic=True)
        check_env(env.unwrapped, skip_render_check=True)
        if seeded:
            assert_same_trace(rollout(env, 7, steps), rollout(env, 7, steps))
        assert env.spec is not None
        assert gym.spec(env_id).id == env.spec.id
        assert json.loads(env.spec.to_json())["kwargs"] == json.loads(json.dumps(env.spec.kwargs))
        env.reset(seed=3)
        env.action_space.seed(3)
        for _ in range(steps):
            _, reward, terminated, truncated, info = env.step(env.action_space.sample())
            comps = info["reward_components"]
            total = float(np.sum(np.asarray(reward)))  # a vector reward (multi-objective ids) sums to the scalar one
            assert np.isclose(sum(comps.values()), total, rtol=1e-9, atol=1e-9), (comps, reward)
            if terminated or truncated:
                break
    finally:
        env.close()
    fresh = gym.make(env_id, **kwargs)
    clone = pickle.loads(pickle.dumps(fresh))
    if seeded:
        assert_same_trace(rollout(fresh, 11, 5), rollout(clone, 11, 5))
    else:
        rollout(clone, 11, 5)
    fresh.close()
    clone.close()


@dataclasses.dataclass
class VectorComparison:
    """How a native vector env compared with ``SyncVectorEnv`` of the single env (per copy)."""

    max_obs_diff: np.ndarray  # largest |native - sync| / max(|sync|, 1) over every observation entry
    max_reward_diff: np.ndarray  # the same for rewards
    episode_ends: np.ndarray  # episodes each copy ended (terminated or truncated; the next step autoresets it)


def _leaves(obs: Any) -> list[np.ndarray]:
    if isinstance(obs, dict):
        return [np.asarray(obs[k], dtype=np.float64) for k in sorted(obs)]
    return [np.asarray(obs, dtype=np.float64)]


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per copy (first axis): the largest |a - b| / max(|b|, 1)."""
    d = np.abs(a - b) / np.maximum(np.abs(b), 1.0)
    return d.reshape(len(d), -1).max(axis=1) if d.ndim > 1 else d


def _assert_same_masks(native: dict[str, Any], sync: dict[str, Any], where: str) -> None:
    """Every info key of the native env carries Gymnasium's mask ``_key``, equal to ``SyncVectorEnv``'s."""
    for key, value in native.items():
        if key.startswith("_"):
            continue
        assert f"_{key}" in native, f"{where}: info[{key!r}] has no mask `_{key}`"
        if f"_{key}" in sync:
            np.testing.assert_array_equal(native[f"_{key}"], sync[f"_{key}"], err_msg=f"{where}: mask `_{key}`")
        if isinstance(value, dict) and isinstance(sync.get(key), dict):
            _assert_same_masks(value, sync[key], f"{where}, info[{key!r}]")


def compare_vector_with_sync(
    env_id: str, num_envs: int, steps: int, seed: int = 0, rtol: float = 0.0, **kwargs: Any
) -> VectorComparison:
    """Step a native vector env and ``SyncVectorEnv`` of the single env side by side, across autoresets.

    Both are made with ``gymnasium.make_vec`` (``vector_entry_point`` and ``sync``) from ``kwargs``,
    reset with ``seed`` (copy ``i`` seeded ``seed + i``, then continuing without a seed at each
    autoreset) and stepped with the same actions, sampled from the batched action space seeded with
    ``seed``. Termination and truncation flags must agree exactly, observations and rewards within
    ``rtol`` (relative, absolute below 1), and each info key of the native env must carry Gymnasium's mask
    ``_key``, equal to ``SyncVectorEnv``'s where that has the key; the differences are returned for reporting.

    Raises:
        AssertionError: The native env departs from ``SyncVectorEnv``.
    """
    native = gym.make_vec(env_id, num_envs, vectorization_mode="vector_entry_point", **kwargs)
    sync = gym.make_vec(env_id, num_envs, vectorization_mode="sync", **kwargs)
    try:
        obs_n, info_n = native.reset(seed=seed)
        obs_s, info_s = sync.reset(seed=seed)
        _assert_same_masks(info_n, info_s, "reset")
        sync.action_space.seed(seed)
        obs_diff = np.zeros(num_envs)
        reward_diff = np.zeros(num_envs)
        ends = np.zeros(num_envs, dtype=np.int64)
        for t in range(steps + 1):
            for a, b in zip(_leaves(obs_n), _leaves(obs_s), strict=True):
                d = _relative(a, b)
                assert (d <= rtol).all(), (
                    f"step {t}: observations differ by {d.max():.3g} (copies {np.flatnonzero(d > rtol)})"
                )
                obs_diff = np.maximum(obs_diff, d)
            if t == steps:
                break
            actions = sync.action_space.sample()
            obs_n, r_n, term_n, trunc_n, info_n = native.step(actions)
            obs_s, r_s, term_s, trunc_s, info_s = sync.step(actions)
            _assert_same_masks(info_n, info_s, f"step {t}")
            np.testing.assert_array_equal(term_n, term_s, err_msg=f"terminated at step {t}")
            np.testing.assert_array_equal(trunc_n, trunc_s, err_msg=f"truncated at step {t}")
            d = _relative(np.asarray(r_n, dtype=np.float64), np.asarray(r_s, dtype=np.float64))
            assert (d <= rtol).all(), f"step {t}: rewards differ by {d.max():.3g} (copies {np.flatnonzero(d > rtol)})"
            reward_diff = np.maximum(reward_diff, d)
            ends += np.asarray(term_s) | np.asarray(trunc_s)
        return VectorComparison(obs_diff, reward_diff, ends)
    finally:
        native.close()
        sync.close()
