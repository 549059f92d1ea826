"""Tabular Q-learning and SARSA in numpy, for environments with discrete observations.

A dict of ``Discrete``/``MultiDiscrete`` observations (or one of them) is mapped to a state index in
mixed radix; the Q-table is a dense ``(states, actions)`` array saved as ``.npz`` (never pickle).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.errors import PolicyError


class StateIndexer:
    """Mixed-radix index of a discrete observation (dict keys in sorted order)."""

    def __init__(self, space: spaces.Space[Any]) -> None:
        parts = [space[k] for k in sorted(space.spaces)] if isinstance(space, spaces.Dict) else [space]
        self.keys = sorted(space.spaces) if isinstance(space, spaces.Dict) else None
        radices: list[int] = []
        for part in parts:
            if isinstance(part, spaces.Discrete):
                radices.append(int(part.n))
            elif isinstance(part, spaces.MultiDiscrete):
                radices.extend(int(n) for n in np.ravel(part.nvec))
            else:
                raise PolicyError(f"tabular methods need Discrete/MultiDiscrete observations, not {part}")
        self.radices = np.array(radices, dtype=np.int64)
        self.n_states = int(np.prod(self.radices))
        self._weights = np.concatenate([np.cumprod(self.radices[::-1])[::-1][1:], [1]]).tolist()

    def __call__(self, obs: Any) -> int:
        """Return the state index of an observation."""
        if self.keys is None:
            values = np.ravel(obs).tolist()
        else:
            values = []
            for k in self.keys:
                v = obs[k]
                if isinstance(v, np.ndarray):
                    values.extend(v.tolist())
                else:
                    values.append(int(v))
        return sum(w * v for w, v in zip(self._weights, values, strict=True))


class QTablePolicy:
    """Greedy policy of a Q-table."""

    def __init__(self, q: np.ndarray, indexer: StateIndexer) -> None:
        self.q = q
        self.indexer = indexer

    def __call__(self, obs: Any) -> int:
        """Return the greedy action."""
        return int(np.argmax(self.q[self.indexer(obs)]))


def save_qtable(path: Path, q: np.ndarray, env_id: str, algo: str, radices: np.ndarray) -> None:
    """Write a Q-table with what identifies the environment it belongs to."""
    np.savez_compressed(path, q=q, env_id=np.array(env_id), algo=np.array(algo), radices=radices)


def load_policy(env: gym.Env[Any, Any], path: str | Path) -> QTablePolicy:
    """Load a ``.npz`` Q-table as a greedy policy; it must match the environment's spaces."""
    try:
        with np.load(path, allow_pickle=False) as data:
            q, radices, env_id = data["q"], data["radices"], str(data["env_id"])
    except (OSError, KeyError, ValueError) as exc:
        raise PolicyError(f"`{path}` is not a gym4real Q-table (.npz with q, radices, env_id): {exc}") from exc
    indexer = StateIndexer(env.observation_space)
    n_actions = int(getattr(env.action_space, "n", 0))
    if not np.array_equal(radices, indexer.radices) or q.shape != (indexer.n_states, n_actions):
        raise PolicyError(
            f"Q-table `{path}` was trained on `{env_id}` with {q.shape[0]} states x {q.shape[1]} actions; "
            f"this environment has {indexer.n_states} x {n_actions}"
        )
    return QTablePolicy(q, indexer)


def train_tabular(env_id: str, hp: dict[str, Any], seed: int, out: Path, progress: bool) -> Path:
    """Train Q-learning or SARSA with the preset's settings; keep the best table on the evaluation env.

    ``hp`` keys: ``algo``, ``episodes``, ``alpha``, ``gamma``, ``epsilon`` (``start``, ``decay``,
    ``min``), ``eval_every``, ``eval_episodes``, ``patience``, ``min_improvement``, ``env_kwargs``,
    ``eval_env_kwargs``.
    """
    from gym4real.core.benchmark import run_episode
    from gym4real.core.rl.curves import LearningCurve

    env = gym.make(env_id, **hp.get("env_kwargs", {}))
    eval_env = gym.make(env_id, **hp.get("eval_env_kwargs", {}))
    if not isinstance(env.action_space, spaces.Discrete):
        raise PolicyError(f"tabular methods need a Discrete action space, `{env_id}` has {env.action_space}")
    indexer = StateIndexer(env.observation_space)
    n_actions = int(env.action_space.n)
    q = np.zeros((indexer.n_states, n_actions))
    best_q, best = q.copy(), -np.inf
    sarsa = hp["algo"] == "sarsa"
    alpha, gamma = float(hp["alpha"]), float(hp["gamma"])
    eps_cfg = hp["epsilon"]
    eps = float(eps_cfg["start"])
    rng = np.random.default_rng(seed)
    curve = LearningCurve(out, "episodes")
    stale = 0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=int(hp["episodes"]), desc=f"{hp['algo']} {env_id}", unit="episode")

    def act(s: int) -> int:
        return int(rng.integers(n_actions)) if rng.random() < eps else int(np.argmax(q[s]))

    for episode in range(1, int(hp["episodes"]) + 1):
        obs, _ = env.reset(seed=int(rng.integers(2**31)))
        s = indexer(obs)
        a = act(s)
        done = False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(a)
            s2 = indexer(obs)
            a2 = act(s2)
            target = reward if terminated else reward + gamma * (q[s2, a2] if sarsa else q[s2].max())
            q[s, a] += alpha * (target - q[s, a])
            s, a = s2, a2
            done = terminated or truncated
        eps = max(float(eps_cfg["min"]), eps * float(eps_cfg["decay"]))
        if bar is not None:
            bar.update()
        if episode % int(hp["eval_every"]) == 0:
            policy = QTablePolicy(q, indexer)
            rets = [
                run_episode(eval_env, policy, 1234 + i, None)["rewards"].sum() for i in range(int(hp["eval_episodes"]))
            ]
            mean = curve.add(episode, rets)
            if mean > best + float(hp["min_improvement"]):
                best, best_q, stale = mean, q.copy(), 0
            else:
                stale += 1
                if stale >= int(hp["patience"]):
                    break
    if bar is not None:
        bar.close()
    env.close()
    eval_env.close()
    path = out / "qtable.npz"
    save_qtable(path, best_q if np.isfinite(best) else q, env_id, hp["algo"], indexer.radices)
    return path
