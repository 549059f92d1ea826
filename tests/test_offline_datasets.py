"""Minari datasets of registered expert policies load back with their env and returns."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gym4real
from gym4real.bench.benchmark import run_episode
from gym4real.bench.policies import make_policy
from gym4real.cli import main
from gym4real.offline import dataset_id

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


NO_JAX = """
import sys
sys.modules["jax"] = None  # any `import jax` now raises ImportError
from gym4real.cli import main
code = main(["dataset", "collect", "gym4real/elevator-v0", "--policy", "longest_first", "--episodes", "2",
             "--out", sys.argv[1]])
assert "jax" not in sys.modules or sys.modules["jax"] is None
sys.exit(code)
"""


def test_collect_needs_no_jax(tmp_path: Path, monkeypatch) -> None:
    """The ``offline`` extra leaves out minari's ``create`` extra (jax, jaxlib): collection must not import jax."""
    minari = pytest.importorskip("minari")
    if "gym4real/elevator-v0" not in gym4real.list_envs():
        pytest.skip("gym4real-elevator is not installed")
    run = subprocess.run([sys.executable, "-c", NO_JAX, str(tmp_path)], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset = minari.load_dataset(dataset_id("gym4real/elevator-v0", "longest_first"))
    assert dataset.total_episodes == 2
    for episode in dataset.iterate_episodes():
        arrivals = episode.observations["arrivals"]  # the elevator observes a Dict: one array per key
        assert len(arrivals) == len(episode.actions) + 1 == len(episode.rewards) + 1
        assert episode.terminations[-1] or episode.truncations[-1]
        assert not (episode.terminations[:-1].any() or episode.truncations[:-1].any())


def test_the_optional_extra_offline_does_not_pull_jax() -> None:
    from importlib.metadata import requires

    offline = [r for r in requires("gym4real-core") or [] if r.replace('"', "'").endswith("extra == 'offline'")]
    assert offline and not [r for r in offline if "create" in r or "jax" in r], offline
