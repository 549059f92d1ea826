"""Numbers written for people: four significant digits, thousands separated, no exponent above 1e-4."""

from __future__ import annotations

import math

#: Significant digits of a number shown to people.
DIGITS = 4


def human(value: float) -> str:
    """``value`` with :data:`DIGITS` significant digits, as a person writes it.

    ``17170.4`` -> ``17,170``; ``8087.3`` -> ``8,087``; ``0.393512`` -> ``0.3935``; ``-0.00233333`` ->
    ``-0.002333``; ``2.912e-06`` -> ``0.000002912`` (never an exponent); NaN -> ``-``; -0 is ``0``.
    """
    if math.isnan(value):
        return "-"
    if math.isinf(value):
        return "∞" if value > 0 else "-∞"
    rounded = float(f"{value:.{DIGITS}g}")
    if rounded == 0:
        return "0"
    if abs(rounded) >= 1000:
        return f"{rounded:,.0f}"
    if abs(rounded) < 1e-4:  # where the g format turns to an exponent: the same digits after the zeros
        decimals = DIGITS - 1 - math.floor(math.log10(abs(rounded)))
        return f"{rounded:.{decimals}f}".rstrip("0").rstrip(".")
    return f"{rounded:.{DIGITS}g}"


def human_interval(low: float, high: float) -> str:
    """``[low, high]`` written for people (see :func:`human`): ``[3,851, 17,170]``."""
    return f"[{human(low)}, {human(high)}]"
