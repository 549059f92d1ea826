"""The vector-reward variants (gym4real/dam-mo-v0, microgrid-mo-v0, wds-mo-v0) are environments like the others."""

from __future__ import annotations

import json
import warnings

import gymnasium as gym
import numpy as np
import pytest

import gym4real
from gym4real.bench.policies import make_policy
from gym4real.cli import main
from gym4real.core.registry import registry
from gym4real.core.testing import check_contract

MORL = [e for e in gym4real.list_envs(multi_objective=False) if "multi_objective" in registry().envs[e].flags]
MO_IDS = [e.replace("-v", "-mo-v") for e in MORL]


def test_every_paper_morl_env_has_a_listed_vector_reward_variant(capsys: pytest.CaptureFixture[str]) -> None:
    assert set(MO_IDS) <= set(gym4real.list_envs())
    assert not set(MO_IDS) & set(gym4real.list_envs(multi_objective=False))
    assert registry().multi_objective == dict(zip(MO_IDS, MORL, strict=True))
    assert main(["list"]) == 0
    listed = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    for mo_id, env_id in zip(MO_IDS, MORL, strict=True):
        assert f"multi-objective {env_id}" in listed[mo_id]


@pytest.mark.parametrize("mo_id", MO_IDS)
def test_gymnasium_make_steps_a_vector_reward_without_warnings(mo_id: str) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gym.make(mo_id)
        env.reset(seed=0)
        env.action_space.seed(0)
        for _ in range(3):
            _, reward, *_ = env.step(env.action_space.sample())
        env.close()
    reward_space = env.unwrapped.reward_space
    assert reward.shape == reward_space.shape and reward_space.shape[0] >= 2
    assert [str(w.message) for w in caught if "reward" in str(w.message)] == []


@pytest.mark.filterwarnings(
    "ignore:.*The reward returned by `step\\(\\)` must be a float:UserWarning"
)  # check_env's rule
@pytest.mark.parametrize("mo_id", MO_IDS)
def test_contract(mo_id: str) -> None:
    check_contract(mo_id, steps=10)


@pytest.mark.parametrize("mo_id", MO_IDS[:1])
def test_info_shows_the_reward_space_its_components_and_the_baselines(
    mo_id: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["info", mo_id, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    env = gym.make(mo_id)
    assert record["interface"]["reward_space"] == str(env.unwrapped.reward_space)
    env.reset(seed=0)
    *_, info = env.step(env.action_space.sample())
    env.close()
    # the vector's entries named in order: the wrapped env's reward terms, as its step reports them
    assert sorted(record["interface"]["reward_components"]) == sorted(info["reward_components"])
    assert main(["info", mo_id]) == 0
    text = " ".join(capsys.readouterr().out.split())  # the rows are wrapped
    assert "one entry each: " + ", ".join(record["interface"]["reward_components"]) + " episode end" in text
    base = registry().multi_objective[mo_id]
    assert record["baselines"] == list(gym4real.env_info(base).baselines)
    assert record["benchmark"]["description"] == registry().benchmarks[base].description


def test_bench_reports_each_objective() -> None:
    if "gym4real/dam-mo-v0" not in gym4real.list_envs():
        pytest.skip("gym4real-dam is not installed")
    kwargs = {"sim_horizon": 20}
    result = gym4real.benchmark("gym4real/dam-mo-v0", ["ead"], episodes=2, seed=4, env_kwargs=kwargs)
    env = gym.make("gym4real/dam-mo-v0", **kwargs)
    names = env.unwrapped.components
    assert result.objectives == names
    table = result.table()
    header = table.splitlines()[table.splitlines().index("") + 1]  # below the protocol run
    assert all(f"{n}_mean" in header for n in names)
    policy = make_policy("gym4real/dam-v0", "ead", env.unwrapped.env)
    for i in range(2):  # the reported objectives are the sums of the vector rewards the env returns
        if hasattr(policy, "reset"):
            policy.reset(4 + i)
        obs, _ = env.reset(seed=4 + i)
        total, done = np.zeros(len(names)), False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(policy(obs))
            total += reward
            done = terminated or truncated
        np.testing.assert_allclose([result.components["ead"][n][i] for n in names], total, rtol=1e-12)
        assert result.returns["ead"][i] == pytest.approx(total.sum(), rel=1e-12)
    env.close()
