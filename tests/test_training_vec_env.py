"""The vector env SB3 trains on steps exactly as SB3's DummyVecEnv of the same seeded envs."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, VecCheckNan

from gym4real.rl.sb3 import _rescale
from gym4real.rl.vec_env import TrainingVecEnv

CASES = [
    # Box actions rescaled to [-1, 1], episodes of 24 decisions: several autoresets in 60 steps
    ("gym4real/microgrid-v0", {"preset": "test", "max_steps": 24}),
    # Discrete actions, trading days of 7 decisions
    ("gym4real/trading-v0", {"preset": "train"}),
]


@pytest.mark.parametrize(("env_id", "kwargs"), CASES, ids=[c[0].split("/")[1] for c in CASES])
def test_training_vec_env_steps_as_dummy_vec_env(env_id: str, kwargs: dict[str, Any]) -> None:
    def make(cls: type) -> Any:
        kw = {"render_mode": None, **kwargs}
        return make_vec_env(env_id, n_envs=3, seed=5, env_kwargs=kw, vec_env_cls=cls, wrapper_class=_rescale)

    ours, theirs = VecCheckNan(make(TrainingVecEnv), raise_exception=True), make(DummyVecEnv)
    np.testing.assert_array_equal(ours.reset(), theirs.reset())
    theirs.action_space.seed(0)
    ends = 0
    for _ in range(60):
        actions = np.array([theirs.action_space.sample() for _ in range(3)])
        obs, rewards, dones, infos = ours.step(actions)
        obs_d, rewards_d, dones_d, infos_d = theirs.step(actions)
        np.testing.assert_array_equal(obs, obs_d)
        np.testing.assert_array_equal(rewards, rewards_d)
        np.testing.assert_array_equal(dones, dones_d)
        for info, info_d in zip(infos, infos_d, strict=True):
            assert info["TimeLimit.truncated"] == info_d["TimeLimit.truncated"]
            assert ("terminal_observation" in info) == ("terminal_observation" in info_d)
            if "terminal_observation" in info:
                np.testing.assert_array_equal(info["terminal_observation"], info_d["terminal_observation"])
                assert info["episode"]["r"] == info_d["episode"]["r"] and info["episode"]["l"] == info_d["episode"]["l"]
                ends += 1
    assert ends >= 3  # the comparison crossed episode ends and resets


def test_ppo_trains_on_the_training_vec_env() -> None:
    from stable_baselines3 import PPO

    venv = make_vec_env(
        "gym4real/microgrid-v0",
        n_envs=2,
        seed=0,
        env_kwargs={"render_mode": None, "preset": "test", "max_steps": 24},
        vec_env_cls=TrainingVecEnv,
        wrapper_class=_rescale,
    )
    model = PPO("MlpPolicy", VecCheckNan(venv, raise_exception=True), n_steps=64, batch_size=32, n_epochs=1, seed=0)
    model.learn(256)
    assert model.num_timesteps == 256
    assert len(model.ep_info_buffer) == 10  # 128 steps per env in 24-step episodes: Monitor's 2 x 5 records reach SB3
