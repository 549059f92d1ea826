"""Tabular Q-learning and SARSA, for environments with discrete observations.

A dict of ``Discrete``/``MultiDiscrete`` observations (or one of them) is mapped to a state index in
mixed radix; the Q-table is a dense ``(states, actions)`` array saved as ``.npz`` (never pickle).

The algorithm is the paper's: one environment, epsilon-greedy exploration with epsilon decayed after each
episode, an evaluation of the greedy table every ``eval_every`` episodes on validation episodes (seeds
``eval_seed, eval_seed + 1, ...``, disjoint from the test protocol's), keeping the best table, and early
stopping after ``patience`` evaluations without an improvement above ``min_improvement``.

An environment may offer its dynamics as compiled functions (``env.unwrapped.tabular_kernel()``, see
:class:`TabularKernel`); with numba installed (extra ``rl``) the episodes then run in the compiled loop of
:mod:`gym4real.rl.compiled`, which gives the same tables as the Python loop, number for number.
Each episode's exploration draws one uniform number per decision from its own generator: a number ``u``
below epsilon explores with action ``floor(u / epsilon * n_actions)``, else the greedy action is taken.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from gym4real.core.errors import PolicyError
from gym4real.rl.progress import Progress
from gym4real.rl.storage import write_whole


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
        self.weights = np.concatenate([np.cumprod(self.radices[::-1])[::-1][1:], [1]]).tolist()

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
        return sum(w * v for w, v in zip(self.weights, values, strict=True))


class QTablePolicy:
    """Greedy policy of a Q-table."""

    def __init__(self, q: np.ndarray, indexer: StateIndexer) -> None:
        self.q = q
        self.indexer = indexer

    def __call__(self, obs: Any) -> int:
        """Return the greedy action."""
        return int(np.argmax(self.q[self.indexer(obs)]))


#: The file name of a run's Q-table.
QTABLE = "qtable.npz"


def save_qtable(path: Path, q: np.ndarray, env_id: str, algo: str, radices: np.ndarray) -> None:
    """Write a Q-table with what identifies the environment it belongs to."""
    np.savez_compressed(path, q=q, env_id=np.array(env_id), algo=np.array(algo), radices=radices)


def save_greedy_table(source: Path, path: Path) -> None:
    """Write the greedy policy of the Q-table ``source`` as a Q-table file that :func:`load_policy` reads.

    Each state's row holds 1 (int8) at the action ``np.argmax`` picks in the trained table (the first of
    tied maxima) and 0 elsewhere, so :class:`QTablePolicy` on it acts exactly as on the trained table in every
    state, while the file is a few percent of the trained one (elevator: 0.13 MB instead of 4.8 MB). The
    values themselves are not kept: retrain the run for them.
    """
    with np.load(source, allow_pickle=False) as data:
        q, env_id, algo, radices = data["q"], str(data["env_id"]), str(data["algo"]), data["radices"]
    greedy = np.zeros(q.shape, dtype=np.int8)
    greedy[np.arange(q.shape[0]), np.argmax(q, axis=1)] = 1
    save_qtable(path, greedy, env_id, algo, radices)


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


class TabularKernel(Protocol):
    """Compiled dynamics that an environment offers through ``env.unwrapped.tabular_kernel()``.

    ``step(state, data, action) -> (reward, terminated, truncated)`` advances ``state`` in place and
    ``observe(state, data, obs)`` writes the observation flattened as :class:`StateIndexer` reads it; both
    are numba functions. ``reset(env, seed)`` returns ``(state, data)`` of the episode that
    ``env.reset(seed=seed)`` would start (drawn the same way, possibly without preparing the Python step).
    """

    horizon: int
    step: Any
    observe: Any

    def reset(self, env: Any, seed: int | None) -> tuple[np.ndarray, tuple[Any, ...]]:
        """The arrays of the episode ``env.reset(seed=seed)`` starts."""


_CHUNK = 4096


class _Draws:
    """One uniform number per decision of an episode, from the episode's own generator, drawn in chunks."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.u = np.empty(0)

    def upto(self, n: int) -> np.ndarray:
        """At least ``n`` numbers (the same first numbers however they are drawn)."""
        while len(self.u) < n:
            self.u = np.concatenate([self.u, self.rng.random(_CHUNK)])
        return self.u


def _choose(q: np.ndarray, s: int, u: float, eps: float) -> int:
    n = q.shape[1]
    if u < eps:
        return min(int(u / eps * n), n - 1)
    return int(np.argmax(q[s]))


def _python_episode(
    env: gym.Env[Any, Any],
    seed: int,
    q: np.ndarray,
    indexer: StateIndexer,
    draws: _Draws,
    hp: dict[str, Any],
    eps: float,
) -> int:
    sarsa, alpha, gamma = hp["algo"] == "sarsa", float(hp["alpha"]), float(hp["gamma"])
    obs, _ = env.reset(seed=seed)
    s = indexer(obs)
    a = _choose(q, s, draws.upto(1)[0], eps)
    k = 1
    while True:
        obs, reward, terminated, truncated, _ = env.step(a)
        s2 = indexer(obs)
        a2 = _choose(q, s2, draws.upto(k + 1)[k], eps)
        k += 1
        if terminated:
            target = float(reward)
        elif sarsa:
            target = reward + gamma * q[s2, a2]
        else:
            target = reward + gamma * np.max(q[s2])
        q[s, a] += alpha * (target - q[s, a])
        if terminated or truncated:
            return k - 1
        s, a = s2, a2


def _kernel(env: gym.Env[Any, Any]) -> TabularKernel | None:
    offer = getattr(env.unwrapped, "tabular_kernel", None)
    if offer is None:
        return None
    try:
        kernel: TabularKernel = offer()
    except ImportError as exc:
        logging.getLogger(__name__).warning(
            "%s offers compiled dynamics but %s is missing; training runs the slower Python loop "
            '(`pip install "gym4real-core[rl]"`)',
            env.spec.id if env.spec else env,
            exc.name,
        )
        return None
    return kernel


class _Checkpoint:
    """The state of an interrupted run (``checkpoint.npz``), written at every evaluation."""

    def __init__(self, out: Path) -> None:
        self.path = out / "checkpoint.npz"

    def save(self, **state: Any) -> None:
        rng = state.pop("rng")
        write_whole(self.path, lambda tmp: np.savez(tmp, rng=np.array(json.dumps(rng.bit_generator.state)), **state))

    def load(self, rng: np.random.Generator) -> dict[str, Any] | None:
        if not self.path.exists():
            return None
        with np.load(self.path, allow_pickle=False) as data:
            state = {k: data[k] for k in data.files if k != "rng"}
            rng.bit_generator.state = json.loads(str(data["rng"]))
        return state


def train_tabular(
    env_id: str,
    hp: dict[str, Any],
    seed: int,
    out: Path,
    progress: Progress | None = None,
    compiled: bool | None = None,
) -> tuple[Path, dict[str, int]]:
    """Train Q-learning or SARSA with the preset's settings; keep the best table on the validation episodes.

    A run interrupted after an evaluation resumes from its ``checkpoint.npz``.

    Args:
        env_id: A registered id with discrete observations and actions.
        hp: The settings of a :class:`~gym4real.rl.presets.TabularPreset`.
        seed: Seed of the run (environment resets and exploration).
        out: Folder of ``qtable.npz``, the learning curve and the checkpoint.
        progress: Called with (episodes done, episodes budget).
        compiled: Run the compiled loop (default: when the environment offers one and numba is installed).

    Returns:
        The path of ``qtable.npz`` and the counts of environment steps (``train``, ``eval``).
    """
    from gym4real.bench.benchmark import run_episode
    from gym4real.rl.curves import LearningCurve

    env = gym.make(env_id, **hp.get("env_kwargs", {}))
    eval_env = gym.make(env_id, **(hp.get("eval_env_kwargs") or {}))
    if not isinstance(env.action_space, spaces.Discrete):
        raise PolicyError(f"tabular methods need a Discrete action space, `{env_id}` has {env.action_space}")
    indexer = StateIndexer(env.observation_space)
    kernel = _kernel(env) if compiled is not False else None
    if compiled and kernel is None:
        raise PolicyError(f"`{env_id}` offers no compiled dynamics (tabular_kernel) or numba is missing")
    n_actions = int(env.action_space.n)
    weights = np.array(indexer.weights, dtype=np.int64)
    sarsa = hp["algo"] == "sarsa"
    alpha, gamma = float(hp["alpha"]), float(hp["gamma"])
    eps_cfg, episodes = hp["epsilon"], int(hp["episodes"])
    eval_seed, eval_episodes = int(hp["eval_seed"]), int(hp["eval_episodes"])
    rng = np.random.default_rng(seed)
    checkpoint = _Checkpoint(out)
    steps = {"train": 0, "eval": 0}
    saved = checkpoint.load(rng)
    if saved is None:
        q = np.zeros((indexer.n_states, n_actions))
        best_q, best, eps, done, stale = q.copy(), -np.inf, float(eps_cfg["start"]), 0, 0
    else:
        q, best_q = saved["q"], saved["best_q"]
        best, eps, done, stale = float(saved["best"]), float(saved["eps"]), int(saved["episode"]), int(saved["stale"])
        steps["train"], steps["eval"] = int(saved["train_steps"]), int(saved["eval_steps"])
    curve = LearningCurve.load(out, "episodes", upto=done)

    if kernel is not None:
        from gym4real.rl.compiled import episode_loop

        compiled_episode = episode_loop(kernel.step, kernel.observe)

        no_draws = np.zeros(1)

        def evaluate(table: np.ndarray) -> list[float]:
            rets = []
            for i in range(eval_episodes):
                state, data = kernel.reset(eval_env.unwrapped, eval_seed + i)
                ret, n = compiled_episode(state, data, table, weights, no_draws, 0.0, 0.0, 0.0, False, False)
                rets.append(ret)
                steps["eval"] += n
            return rets
    else:

        def evaluate(table: np.ndarray) -> list[float]:
            policy = QTablePolicy(table, indexer)
            rewards = [run_episode(eval_env, policy, eval_seed + i, None)["rewards"] for i in range(eval_episodes)]
            steps["eval"] += sum(len(r) for r in rewards)
            return [float(r.sum()) for r in rewards]

    while done < episodes and stale < int(hp["patience"]):
        episode_seed, explore_seed = int(rng.integers(2**31)), int(rng.integers(2**63))
        draws = _Draws(explore_seed)
        if kernel is not None:
            state, data = kernel.reset(env.unwrapped, episode_seed)
            u = draws.upto(kernel.horizon + 1)
            _, n = compiled_episode(state, data, q, weights, u, eps, alpha, gamma, sarsa, True)
        else:
            n = _python_episode(env, episode_seed, q, indexer, draws, hp, eps)
        steps["train"] += n
        done += 1
        eps = max(float(eps_cfg["min"]), eps * float(eps_cfg["decay"]))
        if done % int(hp["eval_every"]) == 0:
            mean = curve.add(done, evaluate(q))
            if mean > best + float(hp["min_improvement"]):
                best, best_q, stale = mean, q.copy(), 0
            else:
                stale += 1
            checkpoint.save(
                q=q,
                best_q=best_q,
                best=best,
                eps=eps,
                episode=done,
                stale=stale,
                train_steps=steps["train"],
                eval_steps=steps["eval"],
                rng=rng,
            )
        if progress is not None:
            progress(done, episodes)
    env.close()
    eval_env.close()
    path = out / QTABLE
    save_qtable(path, best_q if np.isfinite(best) else q, env_id, hp["algo"], indexer.radices)
    checkpoint.path.unlink(missing_ok=True)
    return path, steps
