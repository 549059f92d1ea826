"""A dataset collected with env overrides replays bit for bit from its recovered eval env, as from its env."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gym4real
from gym4real.cli import main
from gym4real.offline import dataset_id

CASES = [
    (e, p, o)
    for e, p, o in [
        ("gym4real/dam-v0", "historical", ["sim_horizon=40", "preset=test"]),
        ("gym4real/elevator-v0", "longest_first", ["duration=300", "preset=test"]),
    ]
    if e in gym4real.list_envs()
]


def assert_stored(obs, stored, t: int, what: str) -> None:
    if isinstance(obs, dict):
        for key, value in obs.items():
            assert_stored(value, stored[key], t, f"{what}, `{key}`")
    else:
        np.testing.assert_array_equal(obs, stored[t], err_msg=f"{what}: observation {t}")


def replay(env, episode, seed: int, what: str) -> None:
    """Step the stored actions from the stored seed; every observation and reward is the stored one, bit for bit."""
    obs, _ = env.reset(seed=seed)
    assert_stored(obs, episode.observations, 0, what)
    for t, action in enumerate(episode.actions):
        obs, reward, terminated, truncated, _ = env.step(action)
        assert_stored(obs, episode.observations, t + 1, what)
        assert reward == episode.rewards[t], f"{what}: reward {t}"
        assert (terminated, truncated) == (episode.terminations[t], episode.truncations[t]), f"{what}: end {t}"


@pytest.mark.parametrize(("env_id", "policy", "overrides"), CASES)
def test_the_eval_env_carries_the_collection_config(env_id, policy, overrides, tmp_path: Path, monkeypatch) -> None:
    minari = pytest.importorskip("minari")
    args = ["dataset", "collect", env_id, "--policy", policy, "--episodes", "2", "--seed", "5", "--out", str(tmp_path)]
    for pair in overrides:
        args += ["--env", pair]
    assert main(args) == 0
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset = minari.load_dataset(dataset_id(env_id, policy))
    episodes = list(dataset.iterate_episodes())
    assert len(episodes) == 2
    for what, recovered in [
        ("recovered env", dataset.recover_environment()),
        ("recovered eval env", dataset.recover_environment(eval_env=True)),
    ]:
        for i, episode in enumerate(episodes):
            replay(recovered, episode, 5 + i, what)
        recovered.close()
