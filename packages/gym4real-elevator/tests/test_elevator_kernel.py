"""The compiled reset and step of the tabular trainer follow ElevatorEnv step by step, in both fidelity modes."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from gym4real.elevator import ElevatorEnv
from gym4real.rl.tabular import StateIndexer


def _flat(obs: dict, indexer: StateIndexer) -> list[int]:
    values: list[int] = []
    for key in indexer.keys or []:
        v = obs[key]
        values.extend(np.ravel(v).tolist())
    return values


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@pytest.mark.parametrize("wait_on_delivery", [False, True])
def test_kernel_follows_the_env_step_by_step(fidelity: str, wait_on_delivery: bool) -> None:
    steps = 900
    env = ElevatorEnv(duration=steps, fidelity=fidelity, waiting_penalty_on_delivery=wait_on_delivery)
    source = ElevatorEnv(duration=steps, fidelity=fidelity, waiting_penalty_on_delivery=wait_on_delivery)
    kernel = source.tabular_kernel()
    indexer = StateIndexer(env.observation_space)
    rng = np.random.default_rng(1)
    obs_buf = np.zeros(len(indexer.weights), dtype=np.int64)
    for episode in range(2):
        obs, _ = env.reset(seed=episode)
        state, data = kernel.reset(source, episode)  # drawn by another env as env.reset draws it
        # a biased walk that often opens the doors at floors, so that boarding and delivery happen
        actions = rng.choice(3, size=steps, p=[0.45, 0.35, 0.2])
        delivered = 0
        for t, a in enumerate(actions):
            kernel.observe(state, data, obs_buf)
            assert obs_buf.tolist() == _flat(obs, indexer), (episode, t)
            obs, reward, terminated, truncated, _ = env.step(int(a))
            k_reward, k_term, k_trunc = kernel.step(state, data, int(a))
            assert (k_reward, k_term, k_trunc) == (reward, terminated, truncated), (episode, t)
            delivered += reward > 0
        kernel.observe(state, data, obs_buf)
        assert obs_buf.tolist() == _flat(obs, indexer)
        assert terminated or truncated
        assert delivered > 0  # the walk exercised deliveries
        assert state[3] == env.delivered and state[4] == env.turned_away
