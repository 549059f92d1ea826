from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.core.benchmark import benchmark
from gym4real.core.policies import make_policy
from gym4real.core.rl.presets import load_preset
from gym4real.wds import WDSEnv, evaluation

ENV_ID = "gym4real/wds-v0"


@pytest.mark.parametrize(("name", "action"), [("p78", 2), ("p79", 1)])
def test_single_pump_baselines(name: str, action: int) -> None:
    env = gym.make(ENV_ID)
    policy = make_policy(ENV_ID, name, env)
    obs, _ = env.reset(seed=0)
    assert policy(obs) == action
    env.close()


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@pytest.mark.parametrize("profile", [0, 3, 250])
def test_default_rule_switches_at_the_tank_thresholds(fidelity: str, profile: int) -> None:
    env = WDSEnv(fidelity=fidelity)
    policy = make_policy(ENV_ID, "default", env)
    policy.reset(0)
    obs, _ = env.reset(options={"profile_index": profile})
    status = {"P78": 1, "P79": 1}  # the file's initial status
    switches = 0
    while True:
        action = policy(obs)
        new = {"P78": action >> 1 & 1, "P79": action & 1}
        for pump, tank in (("P78", 0), ("P79", 1)):
            level = obs[tank]
            if level < 5.0:
                assert new[pump] == 1
            elif level > 8.0:
                assert new[pump] == 0
            else:
                assert new[pump] == status[pump]
            switches += new[pump] != status[pump]
        status = new
        obs, _, _, truncated, info = env.step(action)
        assert info["pumps"] == new
        if truncated:
            break
    assert switches > 0
    env.close()


def test_default_rule_first_action_upstream_is_both_on() -> None:
    env = WDSEnv(fidelity="upstream")
    policy = make_policy(ENV_ID, "default", env)
    obs, _ = env.reset(seed=0)
    assert policy(obs) == 3  # zeroed reset observation: both tanks "below 5 m"
    env.close()


def test_protocol_is_the_first_20_test_profiles() -> None:
    episodes = evaluation.test_episodes({"preset": "test"})
    assert [e["options"]["profile_index"] for e in episodes] == list(range(20))
    assert len({e["seed"] for e in episodes}) == 20


def test_benchmark_runs_and_ranks_policies(tmp_path) -> None:
    result = benchmark(ENV_ID, policies=["p78", "default"], out=tmp_path)
    assert set(result.returns) == {"p78", "default"}
    for rets in result.returns.values():
        assert len(rets) == 20
        assert all(-2 * 168 <= r <= 168 for r in rets)
    comps = result.components["default"]
    np.testing.assert_allclose(np.add(comps["dsr"], comps["overflow"]), result.returns["default"], rtol=1e-9)
    assert (tmp_path / "summary.csv").exists()


@pytest.mark.parametrize("preset", ["paper", "smoke"])
def test_dqn_presets(preset: str) -> None:
    hp = load_preset(ENV_ID, "dqn", preset)
    assert hp["algo"] == "dqn" and hp["policy_kwargs"] == {"net_arch": [64, 64]}
    h = hp["hyperparams"]
    assert (h["gamma"], h["learning_rate"], h["batch_size"], h["train_freq"]) == (0.99, 1e-3, 32, 4)
    assert (h["exploration_fraction"], h["exploration_final_eps"]) == (0.1, 0.05)
    if preset == "paper":
        assert hp["n_envs"] == 8 and h["buffer_size"] == 1_000_000 and hp["total_timesteps"] == 100 * 168
    else:
        assert hp["total_timesteps"] <= 4000 and hp["n_envs"] <= 2
    gym.make(ENV_ID, **hp["env_kwargs"]).close()
    gym.make(ENV_ID, **hp["eval_env_kwargs"]).close()
