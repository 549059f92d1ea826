from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gym4real  # noqa: F401  (registers the ids)
from gym4real.core.errors import ConfigError
from gym4real.core.testing import check_contract
from gym4real.elevator import ElevatorEnv
from gym4real.elevator.arrivals import upstream_arrivals
from gym4real.elevator.env import DOWN, OPEN, UP

ENV_ID = "gym4real/elevator-v0"


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_contract(fidelity: str) -> None:
    check_contract(ENV_ID, steps=200, seeded=fidelity == "corrected", fidelity=fidelity)


def test_spaces_match_the_spec() -> None:
    env = ElevatorEnv()
    assert env.action_space == gym.spaces.Discrete(3)
    space = env.observation_space
    assert space["current_position"].n == 9  # 24 m / 3 m + 1
    assert space["n_passengers"].n == 5
    assert list(space["floor_queues"].nvec) == [4, 4, 4, 4]
    assert list(space["arrivals"].nvec) == [3, 3, 3, 3]
    states = 9 * 5 * 4**4 * 3**4
    assert states == 933_120


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@settings(max_examples=25, deadline=None)
@given(actions=st.lists(st.integers(0, 2), min_size=1, max_size=400), seed=st.integers(0, 2**16))
def test_passengers_are_conserved(fidelity: str, actions: list[int], seed: int) -> None:
    env = ElevatorEnv(fidelity=fidelity, floors={"lambda_min": 0.2, "lambda_max": 0.6}, duration=400)
    obs, _ = env.reset(seed=seed)
    for a in actions:
        obs, _, terminated, truncated, _ = env.step(a)
        c = env.counts()
        assert c["arrived"] == c["waiting"] + c["riding"] + c["delivered"] + c["turned_away"] + c["pending"]
        assert c["waiting"] == int(np.sum(obs["floor_queues"]))
        assert c["riding"] == obs["n_passengers"] <= 4
        if terminated or truncated:
            break


def test_same_seed_same_arrivals_and_different_seed_differs() -> None:
    a, b = ElevatorEnv(), ElevatorEnv()
    a.reset(seed=5)
    b.reset(seed=5)
    np.testing.assert_array_equal(a._arrivals, b._arrivals)
    b.reset(seed=6)
    assert not np.array_equal(a._arrivals, b._arrivals)


def test_arrival_rates_within_bounds_and_counts_capped() -> None:
    env = ElevatorEnv()
    for seed in range(20):
        env.reset(seed=seed)
        assert np.all((env.rates >= 0.01) & (env.rates <= 0.1))
        assert env._arrivals.max() <= 2


def test_upstream_vector_draw_equals_the_reference_loop() -> None:
    rates = np.array([0.03, 0.07, 0.1, 0.01])
    table = upstream_arrivals(1234, rates, 3600, 2)
    for col, lam in enumerate(rates):
        rng = np.random.default_rng(1234)  # the reference: a fresh generator per floor, one draw per second
        loop = [min(int(rng.poisson(lam)), 2) for _ in range(3600)]
        assert table[:, col].tolist() == loop
    # one seed for every floor: floors with the same rate get the very same arrivals
    same = upstream_arrivals(1234, np.full(4, 0.05), 3600, 2)
    assert all(np.array_equal(same[:, 0], same[:, k]) for k in range(1, 4))


def _wait(env: ElevatorEnv, floor: int, people: int) -> None:
    """Put ``people`` in the queue of ``floor`` (1..4), in the env's state and its observation."""
    env._queues[floor] = people
    env._queue_obs[floor - 1] = people
    env._waiting = sum(env._queues)


def _env_with_queue(fidelity: str, position_m: float) -> ElevatorEnv:
    env = ElevatorEnv(fidelity=fidelity, init_elevator_pos=position_m, floors={"lambda_min": 0, "lambda_max": 0})
    env.reset(seed=0)
    _wait(env, 1, 2)  # two people wait at floor 1
    return env


def test_corrected_doors_stay_closed_between_floors() -> None:
    env = _env_with_queue("corrected", 9.0)  # between floors 1 and 2
    obs, reward, *_ = env.step(OPEN)
    assert obs["n_passengers"] == 0 and obs["floor_queues"][0] == 2
    assert reward == -2.0


def test_upstream_doors_open_between_floors_and_board_the_floor_below() -> None:
    env = _env_with_queue("upstream", 9.0)
    obs, reward, *_ = env.step(OPEN)
    assert obs["n_passengers"] == 2 and obs["floor_queues"][0] == 0
    assert reward == -2.0


@pytest.mark.parametrize(("fidelity", "joined"), [("corrected", 2), ("upstream", 1)])
def test_queue_transfer_of_two_simultaneous_arrivals(fidelity: str, joined: int) -> None:
    env = ElevatorEnv(fidelity=fidelity, init_elevator_pos=0.0)
    env.reset(seed=0)
    env._rows[0] = [2, 0, 0, 0]
    env._any_arrival[0] = True
    env.step(DOWN)  # no move at the bottom
    assert env._queues[1] == joined
    assert env.turned_away == 2 - joined


def test_a_round_trip_delivers_and_pays_the_bonus() -> None:
    env = _env_with_queue("corrected", 0.0)
    rewards = [env.step(a)[1] for a in (UP, UP, OPEN, DOWN, DOWN)]
    assert rewards == [-2.0, -2.0, -2.0, -2.0, -2.0]  # two people waiting, then riding
    obs, reward, _, _, info = env.step(OPEN)
    assert reward == 20.0 and info["reward_components"] == {"delivery": 20.0, "waiting": 0.0}
    assert env.delivered == 2 and obs["n_passengers"] == 0


def test_waiting_penalty_on_delivery_is_optional() -> None:
    env = ElevatorEnv(
        init_elevator_pos=0.0, waiting_penalty_on_delivery=True, floors={"lambda_min": 0, "lambda_max": 0}
    )
    env.reset(seed=0)
    env._load = 3
    _wait(env, 2, 1)
    _, reward, *_ = env.step(OPEN)
    assert reward == 30.0 - 1.0


@pytest.mark.parametrize(("fidelity", "terminated"), [("corrected", False), ("upstream", True)])
def test_time_limit(fidelity: str, terminated: bool) -> None:
    env = ElevatorEnv(fidelity=fidelity, duration=5)
    env.reset(seed=0)
    for _ in range(4):
        assert env.step(OPEN)[2:4] == (False, False)
    assert env.step(OPEN)[2:4] == (terminated, not terminated)


def test_upstream_mode_is_repeatable_from_its_config_seed() -> None:
    a, b = ElevatorEnv(fidelity="upstream", preset="test"), ElevatorEnv(fidelity="upstream", preset="test")
    for _ in range(3):
        oa, _ = a.reset()
        ob, _ = b.reset(seed=99)  # reset's seed does not drive the reference's randomness
        assert oa["current_position"] == ob["current_position"]
        np.testing.assert_array_equal(a._arrivals, b._arrivals)


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"elevator": {"floor_height": 7.0}}, "floor_height"),
        ({"duration": "long"}, "duration"),
        ({"reward_coef": 3.0}, "reward_coef"),
        ({"floors": {"max_queue_length": 0}}, "floors.max_queue_length"),
    ],
)
def test_bad_config_names_the_field(overrides: dict[str, object], field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        gym.make(ENV_ID, **overrides)


def test_invalid_action_is_a_clear_error() -> None:
    env = ElevatorEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not in the action space"):
        env.step(3)


def test_ansi_render_draws_every_floor() -> None:
    env = gym.make(ENV_ID, render_mode="ansi")
    env.reset(seed=0)
    text = env.render()
    assert isinstance(text, str)
    for floor in range(5):
        assert f"F{floor}" in text
    assert "(goal)" in text


def test_an_agent_changing_its_observations_does_not_change_the_episode() -> None:
    """The observation's arrays are the agent's: writing into them leaves the dynamics and later observations."""
    kept, changed = ElevatorEnv(), ElevatorEnv()
    obs_kept, _ = kept.reset(seed=4)
    obs_changed, _ = changed.reset(seed=4)
    rng = np.random.default_rng(0)
    for _ in range(400):
        for key in ("arrivals", "floor_queues"):
            np.testing.assert_array_equal(obs_changed[key], obs_kept[key])
            obs_changed[key] += 7  # the agent scribbles on what it was given
        action = int(rng.integers(3))
        obs_kept, r_kept, *_ = kept.step(action)
        obs_changed, r_changed, *_ = changed.step(action)
        assert r_changed == r_kept
    assert changed.counts() == kept.counts()
