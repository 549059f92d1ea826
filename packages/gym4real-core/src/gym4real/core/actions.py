"""The one check of an action against an environment's action space, with the same error everywhere.

Every environment's ``step`` (and every batched env's, per copy) passes its action through
:class:`DiscreteAction` (:func:`discrete_action` with a fast path) or :func:`box_action`. What is not in the
action space raises :class:`~gym4real.core.errors.ActionError` (a ``ValueError``) naming the action, the space, what is
wrong with it and what was expected:

* a ``Discrete`` action is one integer (a Python ``int``, a numpy integer, or an integer array holding
  exactly one value) inside the space; floats (even ``1.0``), booleans, strings, complex numbers and
  arrays of several values are refused;
* a ``Box`` action (:func:`box_action`; :func:`box_value` for a box of one element, as a float) is an
  array of real numbers (integer or float dtype) of the space's shape (extra axes of length one are
  ignored: ``(1, 3)`` for ``(3,)``); strings, booleans, complex numbers, object arrays and non-finite
  values are refused. What happens outside the bounds is the env's definition:
  ``outside="raise"`` refuses it, ``"clip"`` clips it into the box, and ``"keep"`` returns it as it is
  for the env to clip and report itself; a ``tolerance`` lets values that far outside through, clipped
  to the bound (float rounding of an action computed at the bound).
"""

from __future__ import annotations

import math
from typing import Any, Literal, TypeVar

import numpy as np
from gymnasium import spaces

from gym4real.core.config import quote
from gym4real.core.errors import ActionError

Outside = Literal["raise", "clip", "keep"]

_INTEGER_KINDS = "iu"
_REAL_KINDS = "iuf"
_SCALAR_INTEGERS = frozenset({int, *(np.dtype(c).type for c in np.typecodes["AllInteger"])})
_S = TypeVar("_S", spaces.Box, spaces.Discrete)


def _kind(space: spaces.Space[Any], kind: type[_S]) -> _S:
    """The space as ``kind``; another kind of space is the env's bug, not the agent's."""
    if not isinstance(space, kind):
        raise TypeError(f"this check is for a {kind.__name__} action space, not {space}")
    return space


def _refuse(action: Any, space: spaces.Space[Any], problem: str, expected: str, copies: str = "") -> ActionError:
    return ActionError(
        f"action {quote(action)}{copies} is not in the action space {space}: {problem}; expected {expected}"
    )


def _kind_problem(arr: np.ndarray) -> str:
    if arr.dtype.kind == "O" and arr.ndim == 0 and arr.item() is None:
        return "it is None"
    kind = arr.dtype.kind
    if kind == "c":
        return "complex numbers are not actions (their imaginary part would be lost)"
    if kind == "b":
        return "booleans are not numbers here"
    if kind in "USO":
        what = {"U": "text", "S": "bytes", "O": "Python objects"}[kind]
        return f"it holds {what}, not numbers (convert it first, e.g. `np.asarray(a, dtype=float)`)"
    return f"its dtype {arr.dtype} is not numeric"


def _as_array(action: Any, space: spaces.Space[Any], expected: str) -> np.ndarray:
    try:
        return np.asarray(action)
    except (TypeError, ValueError) as exc:  # ragged nesting, objects numpy cannot hold
        raise _refuse(action, space, f"it is not an array of numbers ({exc})", expected) from None


class DiscreteAction:
    """:func:`discrete_action` of one env's ``Discrete`` space, with a fast path for a valid integer.

    An env makes one in ``__init__`` and calls it in ``step``: ``action = self._action(action)``. The space's
    bounds are read once, as Python ints, so a valid Python or numpy integer costs a conversion and two
    comparisons; any other action goes through :func:`discrete_action`, with all its checks and its errors.

    Args:
        space: The env's ``Discrete`` action space.
        meaning: What the values mean, for the message (``"0 (down), 1 (open) or 2 (up)"``).
    """

    __slots__ = ("_high", "_low", "meaning", "space")

    def __init__(self, space: spaces.Space[Any], meaning: str) -> None:
        self.space = _kind(space, spaces.Discrete)
        self.meaning = meaning
        self._low = int(self.space.start)
        self._high = self._low + int(self.space.n)

    def __call__(self, action: Any) -> int:
        """The action as an ``int`` of the space, or :class:`ActionError`."""
        if type(action) in _SCALAR_INTEGERS:  # a Python or numpy integer (what ``space.sample()`` gives)
            value = int(action)
            if self._low <= value < self._high:
                return value
        return discrete_action(action, self.space, self.meaning)


def discrete_action(action: Any, space: spaces.Space[Any], meaning: str) -> int:
    """The action as an ``int`` of ``space``, or :class:`ActionError`.

    Args:
        action: What the agent passed to ``step``.
        space: The env's ``Discrete`` action space.
        meaning: What the values mean, for the message (``"0 (down), 1 (open) or 2 (up)"``).
    """
    space = _kind(space, spaces.Discrete)
    if type(action) is int or (isinstance(action, np.integer) and not isinstance(action, np.bool_)):
        value = int(action)
    else:
        arr = _as_array(action, space, meaning)
        if isinstance(action, bool) or arr.dtype.kind not in _INTEGER_KINDS:
            problem = "it is not an integer" if arr.dtype.kind == "f" else _kind_problem(arr)
            raise _refuse(action, space, problem, f"one integer: {meaning}")
        if arr.size != 1:
            raise _refuse(action, space, f"it holds {arr.size} values", f"one integer: {meaning}")
        value = int(arr.reshape(-1)[0])
    low = int(space.start)
    if not low <= value < low + int(space.n):
        raise _refuse(action, space, f"{value} is outside [{low}, {low + int(space.n) - 1}]", meaning)
    return value


def discrete_actions(actions: Any, space: spaces.Space[Any], num_envs: int, meaning: str) -> np.ndarray:
    """The actions of ``num_envs`` copies as an ``int64`` array ``(num_envs,)`` (a copy), or :class:`ActionError`."""
    if (
        type(space) is spaces.Discrete
        and type(actions) is np.ndarray
        and (actions.dtype.kind == "i" or (actions.dtype.kind == "u" and actions.dtype.itemsize < 8))
        and actions.shape == (num_envs,)
        and num_envs > 0
    ):  # the usual case: one reduction (below the start wraps around to a huge unsigned number)
        values = actions.astype(np.int64)
        low = space.start
        if (values - low if low else values).view(np.uint64).max() < space.n:
            return values
    space = _kind(space, spaces.Discrete)
    low = int(space.start)
    high = low + int(space.n) - 1
    expected = f"{num_envs} integers, one per copy: {meaning}"
    arr = _as_array(actions, space, expected)
    if arr.dtype.kind not in _INTEGER_KINDS:
        problem = "they are not integers" if arr.dtype.kind == "f" else _kind_problem(arr)
        raise _refuse(actions, space, problem, expected)
    if arr.size != num_envs or _squeezed(arr.shape) != _squeezed((num_envs,)):
        raise _refuse(actions, space, f"shape {arr.shape}, not ({num_envs},)", expected)
    flat = arr.reshape(num_envs)
    bad = (flat < low) | (flat > high)  # compared before the int64 copy, which would wrap a huge uint64 around
    if bad.any():
        problem = f"{flat[bad].tolist()} outside [{low}, {high}]"
        raise _refuse(actions, space, problem, meaning, copies=f" (copies {np.flatnonzero(bad).tolist()})")
    return flat.astype(np.int64)


def _squeezed(shape: tuple[int, ...]) -> tuple[int, ...]:
    return tuple(d for d in shape if d != 1)


def _checked_box(
    action: Any,
    box: spaces.Box,
    shape: tuple[int, ...],
    expected: str,
    meaning: str,
    outside: Outside,
    tolerance: float,
    fix: str,
) -> np.ndarray:
    """``action`` as a float64 copy of ``shape``: real, finite, and inside the box as ``outside`` says."""
    arr = _as_array(action, box, expected)
    if arr.dtype.kind not in _REAL_KINDS:
        raise _refuse(action, box, _kind_problem(arr), expected)
    if arr.shape != shape and (arr.size != math.prod(shape) or _squeezed(arr.shape) != _squeezed(shape)):
        raise _refuse(action, box, f"shape {arr.shape}, not {shape}", expected)
    a = np.array(arr, dtype=np.float64).reshape(shape)  # a copy: the caller's array is never changed
    low, high = box.low, box.high
    if ((a >= low) & (a <= high)).all():  # the usual case; False with a NaN
        return a
    finite = np.isfinite(a)
    if not finite.all():
        raise _refuse(action, box, "NaN and infinities are not actions", expected, _copies(~finite, box))
    if outside == "keep":
        return a
    if outside == "raise":
        beyond = (a < low - tolerance) | (a > high + tolerance)
        if beyond.any():
            problem = f"it is outside {_describe(box)}"
            raise _refuse(action, box, problem, f"{meaning}; {fix}", _copies(beyond, box))
    return np.clip(a, low, high)


def _copies(bad: np.ndarray, space: spaces.Box) -> str:
    """`` (copies [...])`` naming the rows of a batch with a ``bad`` element; empty for a single action."""
    if bad.ndim == len(space.shape):
        return ""
    return f" (copies {np.flatnonzero(bad.reshape(len(bad), -1).any(axis=1)).tolist()})"


def _describe(space: spaces.Box) -> str:
    low, high = np.unique(space.low), np.unique(space.high)
    if low.size == high.size == 1:
        return f"[{low[0]:g}, {high[0]:g}]"
    return f"[{space.low.tolist()}, {space.high.tolist()}]"


def box_action(
    action: Any,
    space: spaces.Space[Any],
    meaning: str,
    *,
    outside: Outside = "raise",
    tolerance: float = 0.0,
    fix: str = "clip it into the box (`np.clip(a, low, high)`)",
) -> np.ndarray:
    """The action as a float64 array of ``space.shape`` (a copy), or :class:`ActionError`.

    Args:
        action: What the agent passed to ``step``.
        space: The env's ``Box`` action space.
        meaning: What the values mean, for the message (``"the release in m3/s"``).
        outside: Beyond the bounds: ``"raise"``, ``"clip"`` into the box, or ``"keep"`` (the env clips).
        tolerance: How far beyond the bounds a value is still accepted (and clipped to the bound).
        fix: What to do about an action outside the bounds (with ``outside="raise"``).
    """
    box = _kind(space, spaces.Box)
    return _checked_box(action, box, box.shape, meaning, meaning, outside, tolerance, fix)


def box_value(
    action: Any,
    space: spaces.Space[Any],
    meaning: str,
    *,
    outside: Outside = "raise",
    tolerance: float = 0.0,
    fix: str = "clip it into the box (`np.clip(a, low, high)`)",
) -> float:
    """:func:`box_action` for a ``Box`` of one element, as a float (a float array inside the box returns at once)."""
    if type(action) is np.ndarray and action.size == 1 and action.dtype.kind == "f" and type(space) is spaces.Box:
        x = action.item()  # a Python float
        if space.shape == (1,) and space.low.item() <= x <= space.high.item():  # the usual case; False with a NaN
            return x  # type: ignore[no-any-return]
    box = _kind(space, spaces.Box)
    return float(_checked_box(action, box, box.shape, meaning, meaning, outside, tolerance, fix)[0])


def box_actions(
    actions: Any,
    space: spaces.Space[Any],
    num_envs: int,
    meaning: str,
    *,
    outside: Outside = "raise",
    tolerance: float = 0.0,
    fix: str = "clip them into the box (`np.clip(a, low, high)`)",
) -> np.ndarray:
    """The actions of ``num_envs`` copies as float64 ``(num_envs, *space.shape)``, checked as :func:`box_action`."""
    box = _kind(space, spaces.Box)
    expected = f"{num_envs} actions, one per copy: {meaning}"
    return _checked_box(actions, box, (num_envs, *box.shape), expected, meaning, outside, tolerance, fix)
