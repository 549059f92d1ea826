"""Multi-objective, safety and challenge wrappers over the installed environments."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import gym4real
from gym4real.wrappers import (
    ActionDelay,
    ActionPersistence,
    MultiObjective,
    ObservationDelay,
    ObservationNoise,
    SafetyCost,
    SensorDropout,
    challenge,
)
from gym4real.wrappers.multi_objective import scalar_env

IDS = gym4real.list_envs(multi_objective=False)  # wrappers of scalar-reward envs


@pytest.mark.parametrize("env_id", IDS)
def test_multi_objective_sums_to_the_scalar_reward(env_id: str) -> None:
    env = MultiObjective(gym.make(env_id))
    assert env.unwrapped is env and env.reward_dim == len(env.components)
    assert env.reward_space.shape == (len(env.components),)
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(10):
        _, vector, terminated, truncated, info = env.step(env.action_space.sample())
        assert vector.shape == env.reward_space.shape
        assert np.isclose(vector.sum(), info["scalar_reward"], rtol=1e-9, atol=1e-9)
        if terminated or truncated:
            break


def test_mo_gymnasium_linear_reward_recovers_the_scalar() -> None:
    mo = pytest.importorskip("mo_gymnasium")
    base = gym.make("gym4real/elevator-v0")
    env = mo.wrappers.LinearReward(MultiObjective(gym.make("gym4real/elevator-v0")), weight=np.ones(2))
    base.reset(seed=3)
    env.reset(seed=3)
    for a in [2, 2, 1, 0, 0, 1] * 20:
        _, r0, *_ = base.step(a)
        _, r1, *_ = env.step(a)
        assert r1 == pytest.approx(r0)


@pytest.mark.parametrize("env_id", IDS)
def test_safety_wrapper_returns_six_items(env_id: str) -> None:
    env = SafetyCost(gym.make(env_id))
    env.reset(seed=0)
    out = env.step(env.action_space.sample())
    assert len(out) == 6 and isinstance(out[2], float) and out[2] >= 0


def test_action_persistence_repeats_and_sums() -> None:
    base = gym.make("gym4real/elevator-v0", init_elevator_pos=0.0)
    env = ActionPersistence(gym.make("gym4real/elevator-v0", init_elevator_pos=0.0), 3)
    base.reset(seed=1)
    env.reset(seed=1)
    total = sum(base.step(2)[1] for _ in range(3))
    obs, reward, *_, info = env.step(2)
    assert reward == total and obs["current_position"] == 3
    assert sum(info["reward_components"].values()) == reward


def test_action_delay_applies_the_old_action() -> None:
    env = ActionDelay(gym.make("gym4real/elevator-v0", init_elevator_pos=0.0), 2)
    env.reset(seed=0)
    positions = [env.step(a)[0]["current_position"] for a in (2, 0, 0, 0, 0)]
    assert positions == [1, 2, 3, 2, 1]  # up, up (the first action fills the delay), up, then down, down


def test_observation_delay_and_noise_and_dropout_are_seeded() -> None:
    def make() -> gym.Env:
        return ObservationDelay(SensorDropout(ObservationNoise(gym.make("CartPole-v1"), 0.05), 0.3), 1)

    a, b = make(), make()
    oa, _ = a.reset(seed=4)
    ob, _ = b.reset(seed=4)
    for _ in range(5):
        oa, *_ = a.step(1)
        ob, *_ = b.step(1)
        np.testing.assert_array_equal(oa, ob)
        assert a.observation_space.contains(oa)


def test_observation_delay_shows_the_past() -> None:
    env = ObservationDelay(gym.make("gym4real/elevator-v0", init_elevator_pos=0.0), 2)
    env.reset(seed=0)
    seen = [env.step(2)[0]["current_position"] for _ in range(4)]
    assert seen == [0, 0, 1, 2]


def test_dropout_nan_mode_declares_an_unbounded_space() -> None:
    env = SensorDropout(gym.make("CartPole-v1"), 1.0, mode="nan")
    env.reset(seed=0)
    obs, *_ = env.step(0)
    assert np.isnan(obs).all()
    assert env.observation_space.shape == (4,) and np.isinf(env.observation_space.high).all()


@pytest.mark.parametrize("level", ["easy", "medium", "hard"])
@pytest.mark.parametrize("env_id", IDS)
def test_challenge_presets_run_on_every_env(env_id: str, level: str) -> None:
    env = challenge(gym.make(env_id), level)
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(5):
        *_, terminated, truncated, info = env.step(env.action_space.sample())
        assert "reward_components" in info
        if terminated or truncated:
            break


def test_unknown_level_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="hard"):
        challenge(gym.make("gym4real/elevator-v0"), "extreme")


def test_multi_objective_ids_for_the_papers_morl_envs() -> None:
    from gym4real.core.registry import registry

    for env_id in IDS:
        spec = registry().envs[env_id]
        mo_id = env_id.replace("-v", "-mo-v")
        assert (mo_id in gym.registry) == ("multi_objective" in spec.flags)
        if mo_id in gym.registry:
            env = gym.make(mo_id)
            assert env.unwrapped.reward_space.shape == (len(env.unwrapped.components),)


def test_scalar_env_reaches_the_env_a_multi_objective_view_owns() -> None:
    """Through a vector-reward id to the scalar env it owns (made with the scalar id's spec); a scalar id's own."""
    pairs = [(i.replace("-v", "-mo-v"), i) for i in IDS if i.replace("-v", "-mo-v") in gym.registry]
    assert pairs
    for mo_id, scalar_id in pairs:
        via_mo, direct = scalar_env(gym.make(mo_id)), scalar_env(gym.make(scalar_id))
        assert not isinstance(via_mo, MultiObjective) and type(via_mo) is type(direct), mo_id
        assert via_mo is via_mo.unwrapped and via_mo.spec is not None and via_mo.spec.id == scalar_id


def _perturbable_ids() -> list[str]:
    out = []
    for env_id in IDS:
        env = gym.make(env_id)
        if getattr(env.unwrapped, "perturbable", ()):
            out.append(env_id)
        env.close()
    return out


@pytest.mark.parametrize("env_id", _perturbable_ids())
def test_exogenous_perturbation_is_drawn_per_episode_and_seeded(env_id: str) -> None:
    from gym4real.wrappers import ExogenousPerturbation

    a = ExogenousPerturbation(gym.make(env_id), 0.1)
    b = ExogenousPerturbation(gym.make(env_id), 0.1)
    _, ia = a.reset(seed=5)
    _, ib = b.reset(seed=5)
    assert ia["perturbation"] == ib["perturbation"]
    assert set(ia["perturbation"]) == set(a.unwrapped.perturbable)
    assert all(0.9 <= v <= 1.1 for v in ia["perturbation"].values())
    _, ia2 = a.reset()
    assert ia2["perturbation"] != ia["perturbation"]


def test_perturbation_needs_a_perturbable_env() -> None:
    from gym4real.wrappers import ExogenousPerturbation

    with pytest.raises(ValueError, match="perturbable"):
        ExogenousPerturbation(gym.make("gym4real/elevator-v0"), 0.1)
