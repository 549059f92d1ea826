"""Planning environment: spaces, rewards of the issue, idle, empty crops, the pretrained agents."""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.core.errors import PolicyError
from gym4real.robofeeder.agents import OnnxPickingAgent, OnnxPlanningAgent
from gym4real.robofeeder.baselines import oracle, pretrained

PLAN = "gym4real/robofeeder-planning-v0"
PRETRAINED = Path(os.environ["GYM4REAL_DATA_DIR"]) / "robofeeder" / "pretrained"


@pytest.fixture(scope="module")
def env():
    e = gym.make(PLAN)
    yield e
    e.close()


def test_spaces_and_reset(env) -> None:
    assert env.action_space == gym.spaces.Discrete(4)
    assert env.observation_space.shape == (3, 50, 50)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert (obs.reshape(3, -1).max(axis=1) > 0.5).all()  # three detected parts, one per crop
    assert info["objects_left"] == 3
    assert env.spec.max_episode_steps == 5


def test_idle_charges_graspable_objects(env) -> None:
    _, info = env.reset(seed=1)
    _, reward, terminated, truncated, step_info = env.step(0)
    assert terminated and not truncated
    assert reward == -info["graspable"] == step_info["reward_components"]["idle"]
    assert info["graspable"] == 3  # the corrected spawn places graspable objects


def test_pick_rewards_and_truncation(env) -> None:
    env.reset(seed=2)
    rewards = []
    for _ in range(5):
        _, reward, terminated, truncated, info = env.step(1)
        assert reward in (1.0, -1.0)
        assert info["reward_components"]["picked" if reward > 0 else "failed"] == reward
        rewards.append(reward)
        if terminated or truncated:
            break
    assert truncated and not terminated and len(rewards) == 5  # picking everything does not end it


def test_empty_crop_is_a_failed_unfeasible_pick() -> None:
    e = gym.make(PLAN, n_objects=1)
    obs, _ = e.reset(seed=0)
    empty = int(np.flatnonzero(obs.reshape(3, -1).max(axis=1) == 0)[0])
    steps = e.unwrapped.sim.physics_steps
    _, reward, _, _, info = e.step(empty + 1)
    assert reward == -1.0 and info["cost"] == 1.0 and not info["feasible"]
    assert e.unwrapped.sim.physics_steps == steps
    e.close()


def test_oracle_planner_with_oracle_picker() -> None:
    e = gym.make(PLAN, picking_agent="oracle")
    policy = oracle(e)
    returns = []
    for seed in range(3):
        obs, _ = e.reset(seed=seed)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = e.step(policy(obs))
            total += reward
            done = terminated or truncated
        returns.append(total)
    e.close()
    assert np.mean(returns) >= 2.0  # three picks then idle with nothing left would be 3


@pytest.mark.parametrize("bad", [4, -1, 1.5, np.array([1, 2])])
def test_bad_actions_raise(env, bad) -> None:
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(bad)


def test_user_picking_policy() -> None:
    calls = []

    def policy(crop: np.ndarray) -> np.ndarray:
        calls.append(crop.shape)
        return np.zeros(3)

    e = gym.make(PLAN, picking_policy=policy)
    e.reset(seed=0)
    e.step(1)
    assert calls == [(1, 50, 50)]
    e.close()
    broken = gym.make(PLAN, picking_policy=lambda crop: np.zeros(2))
    broken.reset(seed=0)
    with pytest.raises(PolicyError):
        broken.step(1)
    broken.close()


def test_pretrained_picking_agent_shapes() -> None:
    agent = OnnxPickingAgent(PRETRAINED / "robofeeder-picking.onnx")
    crop = np.random.default_rng(0).random((1, 50, 50), dtype=np.float32)
    action = agent(crop)
    assert action.shape == (3,) and action.dtype == np.float32 and np.all(np.abs(action) <= 1)
    np.testing.assert_array_equal(action, agent(crop))  # the mean is deterministic
    np.testing.assert_allclose(np.exp(agent.log_std), [0.0393, 0.0333, 0.0742], atol=2e-4)
    sampler = OnnxPickingAgent(PRETRAINED / "robofeeder-picking.onnx", mode="sample", clip=False)
    a1 = sampler(crop, np.random.default_rng(1))
    np.testing.assert_array_equal(a1, sampler(crop, np.random.default_rng(1)))
    with pytest.raises(PolicyError, match="shape"):
        agent(np.zeros((3, 50, 50), np.float32))


def test_pretrained_mean_matches_the_graph_samples() -> None:
    import onnxruntime as ort

    path = PRETRAINED / "robofeeder-picking.onnx"
    crop = np.random.default_rng(3).random((1, 1, 50, 50), dtype=np.float32)
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    samples = np.array([session.run(None, {"input": crop})[0][0] for _ in range(400)])
    mean = OnnxPickingAgent(path, clip=False)(crop[0])
    assert np.all(np.abs(samples.mean(axis=0) - mean) < 4 * samples.std(axis=0) / np.sqrt(400) + 1e-4)


def test_pretrained_planning_model_ignores_its_input(env) -> None:
    # documented in agents.py, the baseline's registration and the README: a new model file that reads its input
    # fails this test, and those notes are to be revised
    agent = OnnxPlanningAgent(PRETRAINED / "robofeeder-planning.onnx")
    rng = np.random.default_rng(0)
    observations = [env.reset(seed=seed)[0] for seed in range(3)]
    observations += [np.ones((3, 50, 50), np.float32), rng.random((3, 50, 50), dtype=np.float32)]
    assert not np.allclose(observations[0], observations[1])  # different scenes
    logits = np.array([agent.logits(obs) for obs in observations])
    np.testing.assert_allclose(logits, np.broadcast_to(logits[0], logits.shape), rtol=0, atol=1e-6)
    assert [pretrained(env)(obs) for obs in observations] == [1] * len(observations)
    assert agent(np.zeros((3, 50, 50), np.float32)) == 0  # only an all-black observation gives other logits


def test_pretrained_picking_baseline_picks() -> None:
    picking = gym.make("gym4real/robofeeder-picking-v0")
    policy = pretrained(picking)
    wins = 0
    for seed in range(8):
        obs, _ = picking.reset(seed=seed)
        action = policy(obs)
        assert picking.action_space.contains(action)  # the corrected baseline clips the agent's action
        wins += picking.step(action)[4]["success"]
    picking.close()
    assert wins >= 2  # 3 of these 8 measured; the fixed baseline picks none of them
