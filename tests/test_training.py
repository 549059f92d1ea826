"""Every registered smoke training preset trains, saves, reloads and acts; wrong model files are refused."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pandas as pd
import pytest

import gym4real
from gym4real.core.errors import PolicyError
from gym4real.core.policies import make_policy
from gym4real.core.registry import registry
from gym4real.core.rl.train import train

SMOKE = sorted((e, a) for (e, a, p) in registry().trainings if p == "smoke" and e in gym4real.list_envs())


@pytest.mark.parametrize(("env_id", "algo"), SMOKE, ids=[f"{e.split('/')[1]}-{a}" for e, a in SMOKE])
def test_smoke_training_saves_reloads_and_acts(env_id: str, algo: str, tmp_path: Path) -> None:
    if algo in ("ppo", "dqn"):
        pytest.importorskip("stable_baselines3")
    run = train(env_id, algo, "smoke", seed=0, out=tmp_path)
    assert run.model_path.exists() and run.model_path.stat().st_size > 0
    curve = pd.read_csv(run.curve_csv)
    assert len(curve) >= 1 and curve["mean_return"].notna().all()
    assert (tmp_path / "curve.png").stat().st_size > 0
    env = gym.make(env_id)
    policy = make_policy(env_id, run.policy, env)
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        action = policy(obs)
        assert env.action_space.contains(action) or env.action_space.contains(
            env.action_space.dtype.type(action) if hasattr(env.action_space, "dtype") else action
        )
        obs, *_ = env.step(action)
    env.close()


def test_model_of_another_env_is_refused(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    other = gym.make("CartPole-v1")
    PPO("MlpPolicy", other, n_steps=64, batch_size=32, device="cpu").save(tmp_path / "model.zip")
    env = gym.make("gym4real/elevator-v0")
    with pytest.raises(PolicyError, match="trained on observation space"):
        make_policy("gym4real/elevator-v0", f"ppo:{tmp_path / 'model.zip'}", env)


def test_qtable_of_another_env_is_refused(tmp_path: Path) -> None:
    import numpy as np

    from gym4real.core.rl.tabular import save_qtable

    save_qtable(tmp_path / "q.npz", np.zeros((10, 3)), "gym4real/other-v0", "qlearning", np.array([10]))
    env = gym.make("gym4real/elevator-v0")
    with pytest.raises(PolicyError, match="trained on `gym4real/other-v0`"):
        make_policy("gym4real/elevator-v0", f"qlearning:{tmp_path / 'q.npz'}", env)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(PolicyError, match="not a gym4real Q-table"):
        make_policy("gym4real/elevator-v0", f"qlearning:{tmp_path / 'junk.npz'}", env)


def test_unknown_preset_lists_the_registered_ones() -> None:
    with pytest.raises(gym4real.core.ConfigError, match="qlearning/paper"):
        train("gym4real/elevator-v0", "qlearning", "huge")


def test_box_actions_are_learnt_on_minus_one_one_and_mapped_back() -> None:
    pytest.importorskip("stable_baselines3")
    import numpy as np

    from gym4real.core.rl.sb3 import NormalizedPolicy, rescaled

    box = gym.spaces.Box(0.0, 491.61, (1,), np.float32)
    assert rescaled(box) and not rescaled(gym.spaces.Box(-1.0, 1.0, (3,))) and not rescaled(gym.spaces.Discrete(3))

    class Model:
        def __init__(self, action: float) -> None:
            self.action = np.array([action], dtype=np.float32)

        def predict(self, obs, deterministic):
            return self.action, None

    for raw, expected in ((-1.0, 0.0), (0.0, 245.805), (1.0, 491.61), (3.0, 491.61)):
        action = NormalizedPolicy(Model(raw), None, box)(np.zeros(4))
        assert box.contains(action) and action[0] == pytest.approx(expected, rel=1e-6)
