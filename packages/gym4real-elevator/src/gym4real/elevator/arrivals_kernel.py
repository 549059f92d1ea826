"""The elevator's arrival draws as one compiled loop (numba), with numpy's own Poisson algorithm.

:func:`gym4real.elevator.arrivals.corrected_arrivals` runs :func:`capped_poisson_counts` when numba is
installed (the extra ``fast``). For a rate below 10, numpy's ``Generator.poisson`` multiplies uniforms from
the generator until their product falls to ``exp(-rate)`` (its ``random_poisson_mult``). This loop draws the
same uniforms from the same generator in the same order (floor by floor, second by second) and stops on
the same comparison; it computes ``exp(-rate)`` once per floor instead of once per draw. The counts and the
generator's state afterwards are numpy's (a test compares both).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def capped_poisson_counts(rng: np.random.Generator, rates: np.ndarray, cap: int, out: np.ndarray) -> None:
    """Fill ``out`` (seconds x floors) with Poisson counts of each floor's rate (each below 10), capped at ``cap``.

    Args:
        rng: The generator to draw from (its state advances as numpy's ``rng.poisson`` would advance it).
        rates: The rate of each floor (1/s), each in ``[0, 10)``.
        cap: The largest count kept.
        out: Out, ``(seconds, floors)`` integers.
    """
    for floor in range(rates.size):
        rate = rates[floor]
        if rate == 0.0:  # numpy returns 0 without drawing
            out[:, floor] = 0
            continue
        threshold = math.exp(-rate)
        for second in range(out.shape[0]):
            count, product = 0, 1.0
            while True:
                product *= rng.random()
                if product <= threshold:
                    break
                count += 1
            out[second, floor] = min(count, cap)
