from __future__ import annotations

from importlib import resources

import numpy as np
import pytest
import yaml

import gym4real
from gym4real.core.registry import registry
from gym4real.microgrid import MicrogridEnv
from gym4real.microgrid.baselines import battery_first, fifty_fifty, only_market
from gym4real.microgrid.evaluation import test_episodes as protocol

ENV_ID = "gym4real/microgrid-v0"


def test_baselines_are_the_paper_constants() -> None:
    env = MicrogridEnv()
    obs, _ = env.reset(seed=0)
    for factory, a in ((only_market, 0.0), (battery_first, 1.0), (fifty_fifty, 0.5)):
        action = factory(env)(obs)
        assert env.action_space.contains(action) and action[0] == a


def test_protocol_is_the_28_test_households() -> None:
    episodes = protocol({"preset": "test"})
    assert [e["options"]["profile"] for e in episodes] == [str(p) for p in range(370, 398)]
    spec = registry().benchmarks[ENV_ID]
    assert spec.objective == ("trading", "degradation") and spec.final_info == ("soh",)
    assert set(spec.policies) == {"random", "only_market", "battery_first", "fifty_fifty"}


def test_benchmark_reports_the_objective_in_eur_and_the_final_soh() -> None:
    result = gym4real.benchmark(
        ENV_ID,
        ["only_market", "battery_first", "fifty_fifty", "random"],
        env_kwargs={"max_steps": 24 * 30, "profiles": ["370", "385"]},
    )
    summary = result.summary()
    for name in ("only_market", "battery_first", "fifty_fifty", "random"):
        objective = result.objective_values(name)
        comps = result.components[name]
        np.testing.assert_allclose(objective, np.add(comps["trading"], comps["degradation"]))
        np.testing.assert_allclose(result.returns[name], objective)  # the test preset's return is in EUR
        assert 0.99 < summary.loc[name, "final_soh_mean"] < 1.0
    # only-market never cycles the battery: it ages by calendar aging alone, least of all
    assert summary.loc["only_market", "final_soh_mean"] > summary.loc["battery_first", "final_soh_mean"]
    assert summary.loc["battery_first", "trading_mean"] > summary.loc["only_market", "trading_mean"]


@pytest.mark.parametrize("preset", ["paper", "smoke"])
def test_ppo_presets(preset: str) -> None:
    spec = registry().trainings[(ENV_ID, "ppo", preset)]
    package, path = spec.resource.split(":")
    cfg = yaml.safe_load((resources.files(package) / path).read_text())
    assert cfg["algo"] == "ppo" and cfg["policy"] == "MlpPolicy"
    assert cfg["policy_kwargs"] == {"net_arch": [64, 32], "log_std_init": -1.0}
    hp = cfg["hyperparams"]
    assert (hp["gamma"], hp["batch_size"], hp["n_epochs"]) == (0.99, 512, 10)
    # "Learning Rate 5e-5", cosine-annealed to 0 as the reference script
    assert hp["learning_rate"] == {"schedule": "cosine", "initial": 5e-5, "final": 0.0}
    assert cfg["normalize_obs"] is True and cfg["normalize_reward"] is False
    if preset == "paper":
        # the table's 8912 rollouts read as 8192: 8 * 8192 is a multiple of the 512 batch (see the preset)
        assert hp["n_steps"] == 8192 and cfg["n_envs"] == 8 and cfg["env_kwargs"] == {"preset": "train"}
        # the reference's EvalCallback(eval_freq=8760 * 4, n_eval_episodes=10) counts calls of its 8 envs
        assert (cfg["eval_freq"], cfg["eval_episodes"]) == (8760 * 4 * cfg["n_envs"], 10)
    else:
        assert cfg["total_timesteps"] <= 4096 and cfg["n_envs"] <= 2
        MicrogridEnv(**cfg["env_kwargs"])  # runs offline
        MicrogridEnv(**cfg["eval_env_kwargs"])
