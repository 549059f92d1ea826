"""What the native batched envs share: the episode limit of a vector entry point, their copies' generators.

A native batched env whose copies give the single env's numbers bit for bit (observations, rewards, flags,
info) says so with a boolean attribute ``exact_copies`` (microgrid's with its compiled step);
:func:`exact_copies` reads it, False where an env does not declare it. One whose ``info`` costs much of its
step may offer ``step_arrays(actions)``: ``step`` without building ``info`` (:func:`step_arrays` falls back
to ``step``), for callers that never read it, such as a trainer's rollout.
"""

from __future__ import annotations

import importlib
import math
import operator
from typing import Any

import numpy as np
from gymnasium.utils import seeding


def check_max_episode_steps(value: object) -> int | None:
    """Validate ``max_episode_steps`` of a native vector env (``gymnasium.make_vec`` passes it through).

    A native vector env truncates every copy after this many steps, as ``gymnasium.make`` wraps a
    single env in ``TimeLimit``; ``None`` or ``-1`` (``make``'s "no wrapper") mean no limit.

    Raises:
        ValueError: Not a positive int, None or -1.
    """
    if value is None or (not isinstance(value, bool) and value == -1):
        return None
    try:
        steps = None if isinstance(value, bool) else operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        steps = None
    if steps is None or steps < 1:
        raise ValueError(f"max_episode_steps must be a positive int (or None for no limit), not {value!r}")
    return steps


def exact_copies(vector: Any) -> bool:
    """Whether a native batched env declares that its copies give the single env's numbers bit for bit."""
    return bool(getattr(vector, "exact_copies", False))


def step_arrays(vector: Any, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``vector.step(actions)`` without its ``info``: the env's own ``step_arrays`` where it has one.

    The same observations, rewards and flags, and the same next state, as ``step`` (the env's ``info`` is
    only not built).
    """
    own = getattr(vector, "step_arrays", None)
    if own is not None:
        return own(actions)  # type: ignore[no-any-return]
    obs, reward, terminated, truncated, _ = vector.step(actions)
    return obs, reward, terminated, truncated


def copy_generators(env: Any, current: list[np.random.Generator] | None, seed: int | None) -> list[np.random.Generator]:
    """The generators of a native vector env's copies at a reset, as ``SyncVectorEnv``'s copies have theirs.

    Copy ``i`` is seeded with ``seed + i``; without a seed the ``current`` ones go on, and the first time
    they are seeded from the batch's own generator (``env.np_random``).
    """
    if seed is not None:
        return [seeding.np_random(seed + i)[0] for i in range(env.num_envs)]
    if current is None:
        return [seeding.np_random(int(k))[0] for k in env.np_random.integers(2**31, size=env.num_envs)]
    return current


def per_copy(value: Any, num_envs: int, name: str) -> np.ndarray:
    """A reset option as one value per copy: one value for every copy, or ``num_envs`` of them.

    Raises:
        ValueError: Neither one value nor ``num_envs``, naming the option.
    """
    arr = np.asarray(value)
    if arr.ndim == 0:
        arr = np.full(num_envs, arr)
    if arr.shape != (num_envs,):
        raise ValueError(f"reset option `{name}` must be one value or {num_envs} (one per copy), not {value!r}")
    return arr


def scalar_power(base: np.ndarray, exponent: float) -> np.ndarray:
    """``base ** exponent`` element by element with the C library's ``pow``, as the single envs compute it.

    NumPy's vectorised ``power`` may differ from ``pow`` in the last bit (about one value in twenty): the
    numpy fallback of a batched env calls this where its single env raises a Python float to a power, so that
    its numbers stay those of the single env. About 80 ns per value.
    """
    return np.fromiter(map(math.pow, base.ravel().tolist(), [exponent] * base.size), float, base.size).reshape(
        base.shape
    )


def scalar_exp(x: np.ndarray) -> np.ndarray:
    """``exp`` element by element with the C library's ``exp``, as the single envs compute it.

    See :func:`scalar_power`.
    """
    return np.fromiter(map(math.exp, x.ravel().tolist()), float, x.size).reshape(x.shape)


def with_masks(info: dict[str, Any], num_envs: int, present: np.ndarray | None = None) -> dict[str, Any]:
    """``info`` of a batch with Gymnasium's masks: a boolean array ``_key`` next to each key, nested dicts included.

    Gymnasium's vector envs mark which copies a key holds a value for (``info["reward_components"]["_pnl"]``
    and ``info["_reward_components"]``). ``present`` says which copies report (all of them by default: the
    native batched envs step and reset their copies together, except where a copy is autoreset).
    """
    return _with_mask(info, np.ones(num_envs, dtype=bool) if present is None else present)


def _with_mask(info: dict[str, Any], mask: np.ndarray) -> dict[str, Any]:
    """:func:`with_masks` with a copy of ``mask`` next to each key (a copy: cheaper than a new array)."""
    masked: dict[str, Any] = {}
    for key, value in info.items():
        masked[key] = _with_mask(value, mask) if isinstance(value, dict) else value
        masked[f"_{key}"] = mask.copy()
    return masked


def compiled_kernel(module: str, name: str, compiled: bool | None, install: str) -> Any:
    """A native batched env's compiled step (numba), or None for its numpy path (the same numbers).

    Args:
        module: The module holding the compiled function (it imports numba).
        name: The function's name.
        compiled: True requires numba, False takes numpy, None takes numba where it is installed.
        install: The pip command that installs numba for this env, for the error.

    Raises:
        ImportError: ``compiled=True`` without numba, naming ``install``.
    """
    if compiled is False:
        return None
    try:
        return getattr(importlib.import_module(module), name)
    except ImportError:
        if compiled:
            raise ImportError(f"compiled=True needs numba: `{install}` (or compiled=None for numpy)") from None
        return None
