"""Actions: what is not in an env's action space gets the same clear error in every env.

Issue 12, section 5 (actions). Every env checks its action with ``gym4real.core.actions``; the
out-of-range behaviour each env's definition states (clip, raise, a small tolerance) is kept.
"""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import gym4real
from gym4real.core.actions import DiscreteAction, box_value, discrete_action, discrete_actions
from gym4real.core.errors import ActionError
from gym4real.dam.vector import DamVectorEnv
from gym4real.elevator.vector import ElevatorVectorEnv
from gym4real.microgrid.vector import MicrogridVectorEnv
from gym4real.trading.vector import TradingVectorEnv

IDS = gym4real.list_envs()


@functools.cache
def _env(env_id: str) -> gym.Env[Any, Any]:
    """One env per id for the whole module (robofeeder and wds take a while to build), reset once."""
    env = gym4real.make(env_id, preset="test").unwrapped
    env.reset(seed=0)
    return env


def _refusal(env: gym.Env[Any, Any], action: Any) -> str:
    with pytest.raises(ValueError) as exc:
        env.step(action)
    assert type(exc.value).__name__ == "ActionError", f"{type(exc.value).__name__}: {exc.value}"
    return str(exc.value)


def _malformed(space: spaces.Space[Any]) -> list[Any]:
    """Actions of the issue and their kind, none of them in ``space``."""
    shape = space.shape if isinstance(space, spaces.Box) else ()
    good = np.zeros(shape, np.float32) if isinstance(space, spaces.Box) else 1
    return [
        np.asarray(good, dtype=np.float64) + 0.5j,  # complex: the imaginary part was silently dropped
        "0.5",  # a string: was accepted as 0.5
        np.array([object()] * max(1, int(np.prod(shape))), dtype=object),  # raised raw float() errors
        np.array([1, 0, 1, 0][: 2 if not shape else shape[0] + 1]),  # elevator: "truth value ... ambiguous"
        None,
        True,
        [[1.0, 2.0], [3.0]],  # ragged
        np.full(shape, np.nan),
    ]


@pytest.mark.parametrize("env_id", IDS)
def test_actions_of_the_issue_get_the_same_error_in_every_env(env_id: str) -> None:
    env = _env(env_id)
    for action in _malformed(env.action_space):
        message = _refusal(env, action)
        assert message.startswith("action ") and f" is not in the action space {env.action_space}: " in message
        assert "; expected " in message


@pytest.mark.parametrize("env_id", IDS)
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(data=st.data())
def test_every_env_refuses_what_its_space_does_not_contain(env_id: str, data: st.DataObject) -> None:
    env = _env(env_id)
    space = env.action_space
    if isinstance(space, spaces.Discrete):
        action = data.draw(
            st.one_of(
                # outside [start, start + n), huge ints too (gymnasium 1.2.2's Discrete.contains overflows on them)
                st.integers().filter(lambda v: not int(space.start) <= v < int(space.start) + int(space.n)),
                st.floats(allow_nan=True, allow_infinity=True),
                st.text(max_size=3),
                st.complex_numbers(),
            )
        )
    else:
        n = int(np.prod(space.shape))
        action = data.draw(
            st.one_of(
                st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=n, max_size=n)
                .map(np.array)
                .filter(lambda a: not np.isfinite(a).all()),
                st.lists(st.floats(-1, 1), min_size=n + 1, max_size=n + 3).map(np.array),
                st.lists(st.complex_numbers(min_magnitude=1e-3, max_magnitude=1), min_size=n, max_size=n).map(np.array),
                st.text(max_size=3),
            )
        )
    message = _refusal(env, action)
    assert f"is not in the action space {space}: " in message


@pytest.mark.parametrize("env_id", ["gym4real/elevator-v0", "gym4real/trading-v0", "gym4real/wds-v0"])
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), as_array=st.booleans())
def test_every_action_of_a_discrete_space_is_accepted(env_id: str, seed: int, as_array: bool) -> None:
    env = _env(env_id)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    action = env.action_space.sample()  # a numpy integer
    env.step(np.array([action]) if as_array else int(action))


def test_elevator_refuses_two_values_with_the_shared_error() -> None:
    message = _refusal(_env("gym4real/elevator-v0"), np.array([1, 0]))
    assert "it holds 2 values; expected one integer: 0 (down), 1 (open) or 2 (up)" in message


def test_microgrid_refuses_complex_and_text_actions_it_used_to_take() -> None:
    env = _env("gym4real/microgrid-v0")
    assert "complex numbers are not actions" in _refusal(env, np.array([0.5 + 0.5j]))
    assert "it holds text" in _refusal(env, "0.5")


# -- the out-of-range behaviour of each env's definition is kept -------------------------------------


def test_dam_clips_by_definition_and_raises_when_configured() -> None:
    env = gym4real.make("gym4real/dam-v0", preset="test").unwrapped
    env.reset(seed=0)
    *_, info = env.step(np.array([1e6], np.float32))
    assert info["raw_action"] == 1e6 and info["action"] == float(np.float32(491.61))
    strict = gym4real.make("gym4real/dam-v0", preset="test", invalid_action="raise").unwrapped
    strict.reset(seed=0)
    message = _refusal(strict, np.array([600.0]))
    assert "it is outside [0, 491.61]" in message and 'set `invalid_action="clip"`' in message
    _refusal(env, np.array([np.inf]))  # a non-finite action is never clipped


@pytest.mark.parametrize(
    ("env_id", "inside", "outside"),
    [
        ("gym4real/microgrid-v0", np.array([1.0 + 5e-7]), np.array([1.0 + 1e-5])),
        ("gym4real/robofeeder-picking-v0", np.array([0.0, 0.0, -1.0 - 5e-7]), np.array([0.0, 0.0, -1.0 - 1e-5])),
    ],
)
def test_the_small_tolerance_of_an_env_is_kept(env_id: str, inside: np.ndarray, outside: np.ndarray) -> None:
    env = _env(env_id)
    env.reset(seed=1)
    env.step(inside)
    env.reset(seed=1)
    assert "it is outside [" in _refusal(env, outside)


# -- batched envs: the same check, naming the copies -------------------------------------------------


@pytest.mark.parametrize(
    ("make", "good"),
    [
        (lambda: DamVectorEnv(3, preset="test"), np.full((3, 1), 100.0)),
        (lambda: MicrogridVectorEnv(3, preset="test"), np.full((3, 1), 0.5)),
        (lambda: ElevatorVectorEnv(3, preset="test"), np.array([0, 1, 2])),
        (lambda: TradingVectorEnv(3, preset="test"), np.array([0, 1, 2])),
    ],
    ids=["dam", "microgrid", "elevator", "trading"],
)
def test_batched_envs_refuse_what_the_single_env_refuses(make: Any, good: np.ndarray) -> None:
    vec = make()
    vec.reset(seed=0)
    for bad in (good + 0.5j, good.astype(str), good.astype(object), good[:2], np.where(np.arange(3) == 1, np.nan, 0)):
        with pytest.raises(ValueError, match="is not in the action space") as exc:
            vec.step(bad)
        assert type(exc.value).__name__ == "ActionError"
    vec.step(good)


INTEGER_TYPES = [int, np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64]


@pytest.mark.parametrize("start", [0, -1, 2])
@pytest.mark.parametrize("kind", INTEGER_TYPES)
def test_the_fast_path_of_one_integer_accepts_exactly_the_space(start: int, kind: type) -> None:
    """Brute force over values around the space (and the extremes of each type) against ``Discrete.contains``,
    for the function and for an env's :class:`DiscreteAction` (its fast path for a Python int)."""
    space = spaces.Discrete(3, start=start)
    info = np.iinfo(kind) if kind is not int else None
    values = [v for v in range(start - 3, start + 6) if info is None or info.min <= v <= info.max]
    extremes = [10**30, -(10**30)] if info is None else [int(info.min), int(info.max)]
    for check in (lambda a: discrete_action(a, space, "m"), DiscreteAction(space, "m")):
        for v in values + extremes:
            action = kind(v)
            if space.contains(np.int64(v)) if abs(v) < 2**62 else False:
                assert check(action) == v and type(check(action)) is int
            else:
                with pytest.raises(ActionError, match="outside"):
                    check(action)


@pytest.mark.parametrize("action", [True, False, 1.0, np.float64(1.0), "1", np.array([1, 1]), None, 1 + 0j])
def test_an_envs_discrete_action_refuses_what_the_function_refuses(action: object) -> None:
    space = spaces.Discrete(3)
    with pytest.raises(ActionError) as by_function:
        discrete_action(action, space, "0, 1 or 2")
    with pytest.raises(ActionError) as by_check:
        DiscreteAction(space, "0, 1 or 2")(action)
    assert str(by_check.value) == str(by_function.value)


@pytest.mark.parametrize("start", [0, -1, 2])
@pytest.mark.parametrize("dtype", [np.int8, np.uint8, np.int32, np.int64, np.uint64])
def test_the_fast_path_of_a_batch_refuses_every_copy_outside_the_space(start: int, dtype: type) -> None:
    """Brute force over one copy's value (the others valid), the extremes of each dtype included."""
    space = spaces.Discrete(3, start=start)
    info = np.iinfo(dtype)
    candidates = [v for v in range(start - 3, start + 6) if info.min <= v <= info.max] + [int(info.min), int(info.max)]
    for v in candidates:
        actions = np.full(4, start, dtype=dtype) if info.min <= start <= info.max else np.zeros(4, dtype=dtype)
        actions[2] = v
        base_ok = space.contains(np.int64(actions[0]))
        wanted = base_ok and start <= v < start + 3
        if wanted:
            out = discrete_actions(actions, space, 4, "m")
            assert out.dtype == np.int64 and out.tolist() == [int(x) for x in actions]
        else:
            with pytest.raises(ActionError, match=r"\(copies \[2\]\).* outside"):
                discrete_actions(actions, space, 4, "m")


def test_the_fast_path_of_a_one_element_box_keeps_every_check() -> None:
    box = spaces.Box(-1.0, 2.0, (1,), np.float32)
    assert box_value(np.array([2.0]), box, "m") == 2.0 and box_value(np.array([-1.0], np.float32), box, "m") == -1.0
    for bad in (np.array([2.5]), np.array([np.nan]), np.array([-np.inf], np.float32)):
        with pytest.raises(ActionError):
            box_value(bad, box, "m")
    assert box_value(np.array([2.5]), box, "m", outside="clip") == 2.0
    wide = spaces.Box(-1.0, 2.0, (2,), np.float32)  # one value for a box of two is refused, not read as in bounds
    with pytest.raises(ActionError, match="shape"):
        box_value(np.array([0.5]), wide, "m")
