"""Batched evaluation of a training run gives each episode the rewards of today's one-at-a-time evaluation."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from gym4real.bench.benchmark import run_episode
from gym4real.rl.evaluation import BatchEvaluation
from gym4real.rl.sb3 import NormalizedPolicy, rescaled


def _policy(env_id: str, kwargs: dict[str, Any], algo: str, normalize: bool) -> NormalizedPolicy:
    """An untrained (seeded) SB3 model on ``env_id``'s spaces, with observation statistics of a random walk."""
    from stable_baselines3 import DQN, PPO

    env = gym.make(env_id, **kwargs)
    actions = env.action_space
    if rescaled(actions):
        actions = gym.spaces.Box(-1.0, 1.0, actions.shape, actions.dtype)  # type: ignore[arg-type]

    class Spaces(gym.Env[Any, Any]):
        observation_space, action_space = env.observation_space, actions

    algo_cls = {"ppo": PPO, "dqn": DQN}[algo]
    model = algo_cls("MlpPolicy", Spaces(), seed=0, device="cpu", policy_kwargs={"net_arch": [64, 32]})
    stats = None
    if normalize:
        env.action_space.seed(1)
        first, _ = env.reset(seed=99)
        walk = np.array([first] + [env.step(env.action_space.sample())[0] for _ in range(40)], dtype=np.float64)
        stats = {"mean": walk.mean(0), "var": walk.var(0) + 0.1, "epsilon": np.array(1e-8), "clip_obs": np.array(10.0)}
    return NormalizedPolicy(model, stats, env.action_space)


def _one_at_a_time(env_id: str, kwargs: dict[str, Any], policy: NormalizedPolicy, n: int) -> list[np.ndarray]:
    """Today's evaluation: one env, episode ``i`` seeded ``7 + i``, one ``predict`` per step."""
    env = gym.make(env_id, **kwargs)
    return [run_episode(env, policy, 7 + i, None)["rewards"] for i in range(n)]


@pytest.mark.parametrize("native", [False, True], ids=["single-envs", "native-vector"])
def test_batched_evaluation_of_normalised_continuous_actions_equals_one_at_a_time(native: bool) -> None:
    # microgrid: Box actions on [0, 1] (learnt on [-1, 1]) with normalised observations
    kwargs = {"preset": "test", "max_steps": 40}
    policy = _policy("gym4real/microgrid-v0", kwargs, "ppo", normalize=True)
    expected = _one_at_a_time("gym4real/microgrid-v0", kwargs, policy, 4)
    evaluation = BatchEvaluation("gym4real/microgrid-v0", kwargs, 4, 7, native=native)
    got = evaluation.run(policy)
    evaluation.close()
    assert [len(r) for r in got] == [len(r) for r in expected]
    # a matrix product over the batch may round the float32 actions differently from one row (a few ulps),
    # and the native env reorders float64 sums (equal to the single env to 1e-9): not bit-equal, but close
    for a, b in zip(got, expected, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-6)
    assert sum(float(np.abs(r).sum()) for r in got) > 0  # the rewards compared are not all zero


@pytest.mark.parametrize("native", [False, True], ids=["single-envs", "native-vector"])
@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_batched_evaluation_of_discrete_actions_equals_one_at_a_time_exactly(algo: str, native: bool) -> None:
    # trading: Discrete(3) actions from argmax/mode: the same actions, so the very same rewards
    kwargs = {"preset": "validation"}
    policy = _policy("gym4real/trading-v0", kwargs, algo, normalize=False)
    expected = _one_at_a_time("gym4real/trading-v0", kwargs, policy, 6)
    evaluation = BatchEvaluation("gym4real/trading-v0", kwargs, 6, 7, native=native)
    got = evaluation.run(policy)
    evaluation.close()
    assert [r.tolist() for r in got] == [r.tolist() for r in expected]
    assert any(np.any(r != 0) for r in got)


def test_batched_actions_are_each_rows_own_action() -> None:
    kwargs = {"preset": "test", "max_steps": 40}
    policy = _policy("gym4real/microgrid-v0", kwargs, "ppo", normalize=True)
    env = gym.make("gym4real/microgrid-v0", **kwargs)
    observations = np.stack([env.reset(seed=s)[0] for s in range(5)])
    batch = policy.actions(observations)
    assert batch.shape == (5, 1) and batch.dtype == np.float32
    assert np.all((batch >= 0) & (batch <= 1))  # mapped onto the env's bounds
    for row, obs in zip(batch, observations, strict=True):
        np.testing.assert_allclose(row, policy(obs), rtol=1e-6, atol=1e-7)


def test_episodes_that_end_early_drop_out_of_the_batch() -> None:
    # CartPole's episodes under an untrained policy end at different steps: each must keep its own length
    # and rewards, none of the steps after its end (an autoreset would add reward 1 per step)
    policy = _policy("CartPole-v1", {}, "dqn", normalize=False)
    expected = _one_at_a_time("CartPole-v1", {}, policy, 8)
    evaluation = BatchEvaluation("CartPole-v1", {}, 8, 7, native=False)
    got = evaluation.run(policy)
    evaluation.close()
    assert len({len(r) for r in expected}) > 1  # the episodes do end at different steps
    assert [r.tolist() for r in got] == [r.tolist() for r in expected]


def test_a_configuration_the_native_env_does_not_batch_runs_in_single_envs() -> None:
    kwargs = {"preset": "test", "max_steps": 10, "fidelity": "upstream"}  # MicrogridVectorEnv batches "corrected"
    evaluation = BatchEvaluation("gym4real/microgrid-v0", kwargs, 2, 7, native=True)
    assert evaluation.vector is None and len(evaluation.envs) == 2
    policy = _policy("gym4real/microgrid-v0", kwargs, "ppo", normalize=False)
    assert [len(r) for r in evaluation.run(policy)] == [10, 10]
    evaluation.close()


def test_microgrids_native_evaluation_equals_single_envs_bit_for_bit_when_episodes_end_apart() -> None:
    """Microgrid's compiled native env gives the single env's numbers: evaluated in it (its ten validation
    episodes: 1.4 s instead of 2.95 s in single envs, issue 43), a policy of the JAX trainer scores the rewards
    of single envs bit for bit, also once some episodes have ended (batteries near their end of life end apart)
    and the batch goes on with them."""
    pytest.importorskip("numba")  # the native env's copies are the single env's bit for bit when compiled
    from gym4real.rl.actor_critic import Model, architecture, initial_parameters

    kwargs = {
        "preset": "test",
        "max_steps": 100,
        "decision_interval": 3,
        "battery": {"eol_soh": 0.9998, "replacement_cost": 1.5},
    }
    env = gym.make("gym4real/microgrid-v0", **kwargs)
    arch = architecture(env.observation_space, env.action_space, {"net_arch": [16]})
    model = Model(arch, initial_parameters(arch, 0.0, 3), None, env.observation_space, env.action_space, True)
    runs = {}
    for native in (False, True):
        evaluation = BatchEvaluation("gym4real/microgrid-v0", kwargs, 6, 7, native=native)
        assert (evaluation.vector is not None) == native
        runs[native] = evaluation.run(model)
        evaluation.close()
    assert len({len(r) for r in runs[False]}) > 1  # the episodes do end apart
    assert [r.tolist() for r in runs[True]] == [r.tolist() for r in runs[False]]


def test_few_episodes_run_in_the_native_env_by_default_only_where_its_copies_are_exact() -> None:
    """Microgrid's compiled copies are the single env's bit for bit: its ten validation episodes run in them
    (1.4 s instead of 2.95 s); dam's copies do not declare it (its `clipping` term is numpy's square, the single
    env's libm `pow`: one ulp apart for some releases), so its 13 episodes stay in single envs."""
    pytest.importorskip("numba")
    microgrid = BatchEvaluation("gym4real/microgrid-v0", {"preset": "test", "max_steps": 10}, 10, 7)
    dam = BatchEvaluation("gym4real/dam-v0", {}, 13, 7)
    try:
        assert microgrid.vector is not None and microgrid.vector.exact_copies  # type: ignore[attr-defined]
        assert dam.vector is None and len(dam.envs) == 13
    finally:
        microgrid.close()
        dam.close()
    numpy_path = gym.make_vec(
        "gym4real/microgrid-v0", 2, vectorization_mode="vector_entry_point", compiled=False, preset="test"
    )
    assert not numpy_path.exact_copies  # type: ignore[attr-defined]  # exp and pow differ in the last bit
    numpy_path.close()
