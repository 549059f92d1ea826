"""Passenger arrival processes: per-floor Poisson counts for a whole episode, drawn at once."""

from __future__ import annotations

import numpy as np


def draw_rates(rng: np.random.Generator, n_floors: int, low: float, high: float) -> np.ndarray:
    """Per-floor Poisson rates, uniform in ``[low, high]``."""
    return np.array([rng.uniform(low, high) for _ in range(n_floors)])


def corrected_arrivals(rng: np.random.Generator, rates: np.ndarray, duration: int, max_arrivals: int) -> np.ndarray:
    """Arrival counts ``(duration, floors)``: independent streams per floor, each capped at ``max_arrivals``."""
    counts = np.stack([rng.poisson(lam, size=duration) for lam in rates], axis=1)
    return np.minimum(counts, max_arrivals)


def upstream_arrivals(seed: int, rates: np.ndarray, duration: int, max_arrivals: int) -> np.ndarray:
    """The reference's arrivals: every floor's stream restarts from the same ``seed``.

    The reference draws ``Poisson(lambda)`` second by second from a fresh ``default_rng(seed)`` per floor;
    a vector draw from the same generator yields the same numbers (a test checks it against the loop).
    """
    counts = np.stack([np.random.default_rng(seed).poisson(lam, size=duration) for lam in rates], axis=1)
    return np.minimum(counts, max_arrivals)
