"""The evaluation episodes of a training run stepped together, one forward pass of the policy per step.

Episode ``i`` is seeded ``seed + i``, as :func:`gym4real.bench.benchmark.run_episode` runs it one at a
time, and gives the same rewards: the environments make the same calls, and the policy's batched action
of each row is its action of that observation alone (up to the rounding of a matrix product over a
batch). Episodes that have ended are left out of the following steps.

Where the domain registers a native batched env (``vector_entry_point``), they run in it when there are at
least :data:`NATIVE_MIN_EPISODES` episodes, or when its copies give the single env's numbers bit for bit
(:func:`gym4real.core.vector.exact_copies`: microgrid's compiled one, whose ten validation episodes take 1.4 s
instead of 2.95 s); else each episode in its own ``gymnasium.make`` env (a native batch costs about as much a
step as 30 single dam or microgrid steps without numba: below that it is slower, see
``benchmarks/bench_training.py``). In the native env, too, only the running episodes' observations go through
the policy, as a batch of those rows, so that exact copies give the single envs' rewards bit for bit.
"""

from __future__ import annotations

import contextlib
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from gym4real.core.vector import exact_copies


class BatchPolicy(Protocol):
    """A deterministic policy that acts on a batch of observations (first axis) in one call.

    :class:`~gym4real.rl.sb3.NormalizedPolicy` (SB3 models) and :class:`~gym4real.rl.actor_critic.Model`
    (the JAX trainer's) are.
    """

    def actions(self, obs: Any) -> np.ndarray:
        """The deterministic action of each observation."""


#: The fewest episodes evaluated in a native batched env (below, single envs step faster).
NATIVE_MIN_EPISODES = 32


def _stack(observations: list[Any]) -> Any:
    if isinstance(observations[0], dict):
        return {k: np.stack([o[k] for o in observations]) for k in observations[0]}
    return np.stack(observations)


def _rows(observations: Any, rows: np.ndarray) -> Any:
    """The ``rows`` of a batch of observations (a dict of arrays or an array), as a new batch."""
    if isinstance(observations, dict):
        return {k: v[rows] for k, v in observations.items()}
    return observations[rows]


class BatchEvaluation:
    """Seeded evaluation episodes of one environment, run as a batch by a :class:`BatchPolicy`.

    Args:
        env_id: A registered id.
        env_kwargs: Keyword arguments of ``gymnasium.make`` (or of the native batched env).
        episodes: The number of episodes of one evaluation.
        seed: The seed of episode 0; episode ``i`` is seeded ``seed + i``.
        native: Run in the domain's native batched env; default: when it has one (and it batches this
            configuration) and there are at least :data:`NATIVE_MIN_EPISODES` episodes or its copies are exact.
    """

    def __init__(
        self, env_id: str, env_kwargs: dict[str, Any], episodes: int, seed: int, native: bool | None = None
    ) -> None:
        self.episodes, self.seed = episodes, seed
        self.vector: gym.vector.VectorEnv[Any, Any, Any] | None = None
        self.envs: list[gym.Env[Any, Any]] = []
        by_default = native is None
        if native is None:
            native = gym.spec(env_id).vector_entry_point is not None
        if native:
            # a configuration the native env does not batch (upstream fidelity) runs in single envs
            with contextlib.suppress(ValueError):
                self.vector = gym.make_vec(env_id, episodes, vectorization_mode="vector_entry_point", **env_kwargs)
        if by_default and self.vector is not None and episodes < NATIVE_MIN_EPISODES and not exact_copies(self.vector):
            self.vector.close()  # few episodes step faster in single envs
            self.vector = None
        if self.vector is not None:
            self.single_action_space = self.vector.single_action_space
        else:
            self.envs = [gym.make(env_id, **env_kwargs) for _ in range(episodes)]
            self.single_action_space = self.envs[0].action_space

    def run(self, policy: BatchPolicy) -> list[np.ndarray]:
        """Run every episode with ``policy``; return each episode's per-step rewards.

        The reward of a step is its ``info["scalar_reward"]`` where the env gives one (vector rewards), as
        :func:`gym4real.bench.benchmark.run_episode` counts it.
        """
        return self._run_vector(policy) if self.vector is not None else self._run_envs(policy)

    def _run_envs(self, policy: BatchPolicy) -> list[np.ndarray]:
        obs = [env.reset(seed=self.seed + i)[0] for i, env in enumerate(self.envs)]
        rewards: list[list[float]] = [[] for _ in self.envs]
        active = list(range(len(self.envs)))
        while active:
            actions = policy.actions(_stack([obs[i] for i in active]))
            still = []
            for i, action in zip(active, actions, strict=True):
                obs[i], reward, terminated, truncated, info = self.envs[i].step(action)
                rewards[i].append(float(info.get("scalar_reward", reward)))
                if not (terminated or truncated):
                    still.append(i)
            active = still
        return [np.asarray(r) for r in rewards]

    def _run_vector(self, policy: BatchPolicy) -> list[np.ndarray]:
        assert self.vector is not None
        obs, _ = self.vector.reset(seed=self.seed)
        rewards: list[list[float]] = [[] for _ in range(self.episodes)]
        active = np.ones(self.episodes, dtype=bool)
        actions: np.ndarray | None = None
        while active.any():
            running = np.flatnonzero(active)  # they act as a batch of their rows, as in single envs
            acted = policy.actions(obs if running.size == self.episodes else _rows(obs, running))
            if actions is None:
                actions = acted
            else:  # the ended episodes' copies repeat their last action; their results are dropped
                actions[running] = acted
            obs, reward, terminated, truncated, info = self.vector.step(actions)
            reward = np.asarray(info.get("scalar_reward", reward), dtype=np.float64)
            for i in np.flatnonzero(active):
                rewards[i].append(float(reward[i]))
            active &= ~(np.asarray(terminated) | np.asarray(truncated))
        return [np.asarray(r) for r in rewards]

    def close(self) -> None:
        """Close the environments."""
        if self.vector is not None:
            self.vector.close()
        for env in self.envs:
            env.close()
