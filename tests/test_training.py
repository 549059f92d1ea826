"""Every registered smoke training preset trains, saves, reloads and acts; wrong model files are refused."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pandas as pd
import pytest

import gym4real
from gym4real.core.errors import ConfigError, PolicyError
from gym4real.core.policies import make_policy
from gym4real.core.registry import registry
from gym4real.core.rl.presets import load_preset
from gym4real.core.rl.train import default_out, train

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


def test_every_registered_preset_is_valid() -> None:
    for env_id, algo, preset in registry().trainings:
        hp = load_preset(env_id, algo, preset)
        assert hp["algo"] == algo and hp["eval_env_kwargs"] is not None


ELEVATOR_SMOKE = """
algo: qlearning
episodes: 4
alpha: 0.1
gamma: 1.0
epsilon: {start: 1.0, decay: 0.9, min: 0.05}
eval_every: 2
eval_episodes: 1
patience: 5
env_kwargs: {duration: 300}
"""


def test_a_users_yaml_file_is_a_preset(tmp_path: Path) -> None:
    path = tmp_path / "mine.yml"
    path.write_text(ELEVATOR_SMOKE)
    run = train("gym4real/elevator-v0", "qlearning", str(path), seed=1, out=tmp_path / "run")
    assert run.model_path.exists()
    assert load_preset("gym4real/elevator-v0", "qlearning", str(path))["eval_env_kwargs"] == {"duration": 300}
    assert default_out("gym4real/elevator-v0", "qlearning", str(path), 1).name == "qlearning-mine-seed1"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("episodes: 4", "episodes: 4\nepisode: 3"), "unknown field `episode`"),
        (("gamma: 1.0", "gamma: 1.5"), r"field `gamma`: Input should be less than or equal to 1"),
        (("algo: qlearning", "algo: sarsa"), "says algo `sarsa`"),
    ],
)
def test_a_bad_preset_file_names_the_file_and_the_field(tmp_path: Path, edit: tuple[str, str], message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(ELEVATOR_SMOKE.replace(*edit))
    with pytest.raises(ConfigError, match=message) as err:
        load_preset("gym4real/elevator-v0", "qlearning", str(path))
    assert str(path) in str(err.value)


def test_an_unknown_sb3_hyperparameter_is_named(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    path = tmp_path / "ppo.yaml"
    path.write_text("algo: ppo\ntotal_timesteps: 64\nhyperparams: {n_steps: 32, lr: 0.1}\n")
    with pytest.raises(ConfigError, match=r"unknown field `hyperparams.lr` for PPO; expected some of .*learning_rate"):
        train("gym4real/elevator-v0", "ppo", str(path), out=tmp_path / "run")
