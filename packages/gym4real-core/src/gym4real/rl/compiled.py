"""The episode loop of tabular Q-learning and SARSA in compiled code (numba, extra ``rl``).

It runs the dynamics an environment offers as compiled functions (its ``tabular_kernel()``: ``step`` and
``observe``, see :mod:`gym4real.rl.tabular`) and does exactly what the Python loop of
:func:`gym4real.rl.tabular.train_tabular` does, number for number.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit
from numba.core.caching import FunctionCache


@njit(cache=True)
def _choose(q: np.ndarray, s: int, u: np.ndarray, k: int, eps: float) -> int:
    n = q.shape[1]
    if eps > 0.0 and u[k] < eps:
        return min(int(u[k] / eps * n), n - 1)
    best = 0
    for a in range(1, n):
        if q[s, a] > q[s, best]:
            best = a
    return best


@njit(cache=True)
def _index(obs: np.ndarray, weights: np.ndarray) -> int:
    s = 0
    for i in range(obs.size):
        s += obs[i] * weights[i]
    return s


class _KernelCache(FunctionCache):  # type: ignore[misc]
    """Numba's on-disk cache of an episode loop, keyed on its kernel functions' names and code.

    Numba keys a closure on its pickled cells, and a pickled dispatcher differs in every process: the
    loop would be compiled again (seconds) in every run.
    """

    def _index_key(self, sig: Any, codegen: Any) -> tuple[Any, ...]:
        kernel = [cell.cell_contents.py_func for cell in self._py_func.__closure__ or ()]
        parts = [f"{f.__module__}.{f.__qualname__}".encode() + f.__code__.co_code for f in kernel]
        digest = hashlib.sha256(b"\0".join([self._py_func.__code__.co_code, *parts])).hexdigest()
        return sig, codegen.magic_tuple(), digest


@functools.cache
def episode_loop(step: Callable[..., Any], observe: Callable[..., Any]) -> Callable[..., tuple[float, int]]:
    """The compiled episode loop of the dynamics ``step`` and ``observe`` (numba functions).

    The loop calls them as constants of its closure and is cached on disk, keyed on their names and
    code (numba writes the cache beside this module, or in the user's cache folder where the package's
    folder is read-only): the compilation is paid once, not in every run.
    """

    def run_episode(
        state: np.ndarray,
        data: tuple[Any, ...],
        q: np.ndarray,
        weights: np.ndarray,
        u: np.ndarray,
        eps: float,
        alpha: float,
        gamma: float,
        sarsa: bool,
        learn: bool,
    ) -> tuple[float, int]:
        """Run one episode from ``state`` (epsilon-greedy on ``q``, updating it when ``learn``).

        Returns the episode's return and its number of steps.
        """
        obs = np.zeros(weights.size, dtype=np.int64)
        observe(state, data, obs)
        s = _index(obs, weights)
        a = _choose(q, s, u, 0, eps)
        k = 1
        total = 0.0
        while True:
            reward, terminated, truncated = step(state, data, a)
            observe(state, data, obs)
            s2 = _index(obs, weights)
            a2 = _choose(q, s2, u, k, eps)
            k += 1
            if learn:
                if terminated:
                    target = reward
                elif sarsa:
                    target = reward + gamma * q[s2, a2]
                else:
                    target = reward + gamma * np.max(q[s2])
                q[s, a] += alpha * (target - q[s, a])
            total += reward
            if terminated or truncated:
                return total, k - 1
            s, a = s2, a2

    loop = njit(run_episode)
    loop._cache = _KernelCache(run_episode)  # type: ignore[attr-defined]  # `cache=True`, with the key above
    return loop  # type: ignore[no-any-return]
