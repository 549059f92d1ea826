"""PPO on RLlib with two env runners on Gym4ReaL envs (runs where the `ray` extra is installed)."""

from __future__ import annotations

import math

import pytest

import gym4real

ray = pytest.importorskip("ray")
IDS = [i for i in ("gym4real/dam-v0", "gym4real/wds-v0", "gym4real/elevator-v0") if i in gym4real.list_envs()][:2]


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


@pytest.mark.parametrize("env_id", IDS)
def test_ppo_two_iterations_with_two_env_runners(env_id: str, local_ray: None) -> None:
    from ray.rllib.algorithms.ppo import PPOConfig

    from gym4real.integrations.rllib import register_all

    assert env_id in register_all(flatten=env_id == "gym4real/elevator-v0")
    config = (
        PPOConfig()
        .environment(env_id, env_config={"duration": 200} if env_id == "gym4real/elevator-v0" else {})
        .env_runners(num_env_runners=2, num_cpus_per_env_runner=0.5)
        .training(train_batch_size_per_learner=800, minibatch_size=200, num_epochs=1)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    try:
        results = [algo.train() for _ in range(2)]
    finally:
        algo.stop()
    returns = results[-1]["env_runners"]["episode_return_mean"]
    assert isinstance(returns, float) and math.isfinite(returns)
    assert results[-1]["env_runners"]["num_episodes_lifetime"] >= 1


@pytest.mark.parametrize(
    "env_id", [i for i in ("gym4real/dam-v0", "gym4real/elevator-v0") if i in gym4real.list_envs()]
)
def test_ppo_on_the_native_vector_env(env_id: str, local_ray: None) -> None:
    """`gym_env_vectorize_mode="vector_entry_point"`: RLlib steps the env's batched VectorEnv."""
    from ray.rllib.algorithms.ppo import PPOConfig

    from gym4real.integrations.rllib import register_all

    flatten = env_id == "gym4real/elevator-v0"
    register_all(flatten=flatten)
    config = (
        PPOConfig()
        .environment(env_id, env_config={"duration": 100} if flatten else {"max_episode_steps": 50})
        .env_runners(num_env_runners=0, num_envs_per_env_runner=4, gym_env_vectorize_mode="vector_entry_point")
        .training(train_batch_size_per_learner=400, minibatch_size=200, num_epochs=1)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    try:
        env = algo.env_runner.env.unwrapped
        assert type(env).__name__.endswith("VectorEnv") and env.num_envs == 4
        result = algo.train()
    finally:
        algo.stop()
    assert result["env_runners"]["num_episodes_lifetime"] >= 4
    assert math.isfinite(result["env_runners"]["episode_return_mean"])
