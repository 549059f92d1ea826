"""The compiled tabular loop is cached on disk under a key that holds in every process."""

from __future__ import annotations

import gymnasium as gym
import pytest

pytest.importorskip("numba")

from numba import njit

import gym4real  # noqa: F401  (registers the envs)
from gym4real.rl.compiled import episode_loop


def test_the_loops_cache_key_names_its_kernel_by_code_not_by_object() -> None:
    kernel = gym.make("gym4real/elevator-v0").unwrapped.tabular_kernel()
    # a second dispatcher of the same function: what a new process has (numba's own key pickles the
    # dispatcher, which differs in every process, so the loop was compiled again in every run)
    same_step = njit(kernel.step.py_func)

    def key(step: object, observe: object) -> object:
        loop = episode_loop.__wrapped__(step, observe)
        return loop._cache._index_key((), loop.targetctx.codegen())

    assert key(kernel.step, kernel.observe) == key(same_step, kernel.observe)
    assert key(kernel.step, kernel.observe) != key(kernel.observe, kernel.step)  # other code, other entry
