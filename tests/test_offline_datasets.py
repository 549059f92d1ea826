"""Minari datasets of registered expert policies load back with their env and returns."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import gym4real
from gym4real.core.benchmark import run_episode
from gym4real.core.cli import main
from gym4real.core.offline import dataset_id
from gym4real.core.policies import make_policy

EXPERTS = {
    "gym4real/elevator-v0": "longest_first",
    "gym4real/dam-v0": "historical",
    "gym4real/wds-v0": "default",
    "gym4real/microgrid-v0": "battery_first",
    "gym4real/robofeeder-picking-v0": "oracle",
}
CASES = [(e, p) for e, p in EXPERTS.items() if e in gym4real.list_envs()]


@pytest.mark.parametrize(("env_id", "policy"), CASES)
def test_collect_two_episodes_and_load_them_back(env_id: str, policy: str, tmp_path: Path, monkeypatch) -> None:
    minari = pytest.importorskip("minari")
    assert (
        main(
            ["dataset", "collect", env_id, "--policy", policy, "--episodes", "2", "--seed", "3", "--out", str(tmp_path)]
        )
        == 0
    )
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset = minari.load_dataset(dataset_id(env_id, policy))
    assert dataset.total_episodes == 2
    env = dataset.recover_environment()
    assert env.spec.id == env_id
    assert os.environ["MINARI_DATASETS_PATH"] == str(tmp_path)
    episodes = list(dataset.iterate_episodes())
    expected = [run_episode(env, make_policy(env_id, policy, env), 3 + i, None)["rewards"].sum() for i in range(2)]
    np.testing.assert_allclose([float(np.sum(ep.rewards)) for ep in episodes], expected, rtol=1e-6)
    for i, ep in enumerate(episodes):  # the stored actions replay the stored transitions
        assert env.action_space.contains(ep.actions[0])
        obs, _ = env.reset(seed=3 + i)
        assert_same_obs(obs, ep.observations, 0)
        for t, action in enumerate(ep.actions):
            obs, reward, *_ = env.step(action)
            assert reward == pytest.approx(ep.rewards[t], rel=1e-9, abs=1e-9)
            assert_same_obs(obs, ep.observations, t + 1)


def assert_same_obs(obs: object, stored: object, t: int) -> None:
    if isinstance(obs, dict):
        for key, value in obs.items():
            assert_same_obs(value, stored[key], t)  # type: ignore[index]
    else:
        np.testing.assert_allclose(obs, stored[t], rtol=1e-6)  # type: ignore[index]
