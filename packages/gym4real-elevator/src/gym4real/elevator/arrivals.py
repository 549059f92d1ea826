"""Passenger arrival processes: per-floor Poisson counts for a whole episode, drawn at once."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from gym4real.core.vector import compiled_kernel

#: numpy's ``Generator.poisson`` draws a rate below this by multiplying uniforms (the compiled loop's method).
_MULTIPLICATION_BELOW = 10.0


def draw_rates(rng: np.random.Generator, n_floors: int, low: float, high: float) -> np.ndarray:
    """Per-floor Poisson rates, uniform in ``[low, high]``."""
    return np.array([rng.uniform(low, high) for _ in range(n_floors)])


@functools.cache
def _compiled(required: bool) -> Any:
    """:func:`gym4real.elevator.arrivals_kernel.capped_poisson_counts`, or None without numba (unless required)."""
    kernel = "gym4real.elevator.arrivals_kernel"
    return compiled_kernel(
        kernel, "capped_poisson_counts", True if required else None, "pip install gym4real-elevator[fast]"
    )


def corrected_arrivals(
    rng: np.random.Generator,
    rates: np.ndarray,
    duration: int,
    max_arrivals: int,
    out: np.ndarray | None = None,
    compiled: bool | None = None,
) -> np.ndarray:
    """Arrival counts ``(duration, floors)``: independent streams per floor, each capped at ``max_arrivals``.

    Floor by floor, ``rng.poisson(rate, size=duration)``. With numba (the extra ``fast``) a compiled loop draws
    the same numbers (:mod:`gym4real.elevator.arrivals_kernel`) when every rate is below 10.

    Args:
        rng: The episode's generator.
        rates: Each served floor's rate (1/s).
        duration: Seconds of the episode.
        max_arrivals: The largest count kept per floor and second.
        out: Where to write the counts (a new array if None).
        compiled: True requires numba, False takes numpy, None takes numba where it is installed.
    """
    if out is None:
        out = np.empty((duration, len(rates)), dtype=np.int64)
    kernel = None if compiled is False else _compiled(bool(compiled))
    if kernel is not None and bool((rates < _MULTIPLICATION_BELOW).all()):
        kernel(rng, np.asarray(rates, dtype=np.float64), max_arrivals, out)
        return out
    for floor, rate in enumerate(rates):
        np.minimum(rng.poisson(rate, size=duration), max_arrivals, out=out[:, floor])
    return out


def upstream_arrivals(seed: int, rates: np.ndarray, duration: int, max_arrivals: int) -> np.ndarray:
    """The reference's arrivals: every floor's stream restarts from the same ``seed``.

    The reference draws ``Poisson(lambda)`` second by second from a fresh ``default_rng(seed)`` per floor;
    a vector draw from the same generator yields the same numbers (a test checks it against the loop).
    """
    counts = np.stack([np.random.default_rng(seed).poisson(lam, size=duration) for lam in rates], axis=1)
    return np.minimum(counts, max_arrivals)
