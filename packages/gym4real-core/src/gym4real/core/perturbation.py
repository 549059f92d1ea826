"""The contract of perturbable environments, for :class:`gym4real.wrappers.ExogenousPerturbation`.

An env that supports perturbation lists the names of its scalable domain parameters in a class attribute
``perturbable`` and has ``perturb(scales)``: multipliers of the nominal values that apply from the next
``reset()`` and replace the previous call's (they never compound). :func:`check_scales` is the common
validation of ``scales``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping


def check_scales(scales: Mapping[str, object], perturbable: Iterable[str]) -> dict[str, float]:
    """Return a scale for every perturbable parameter: the given ones, 1.0 for the others.

    Raises:
        ValueError: A name not in ``perturbable``, or a scale that is not a finite number > 0.
    """
    names = list(perturbable)
    unknown = sorted(set(scales) - set(names))
    if unknown:
        raise ValueError(f"unknown perturbation parameters {unknown}; expected some of {names}")
    out = dict.fromkeys(names, 1.0)
    for name, value in scales.items():
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0 < float(value) < math.inf:
            raise ValueError(f"perturbation scale `{name}` must be a finite number > 0, not {value!r}")
        out[name] = float(value)
    return out
