"""The multi-objective evaluation of ``gym4real/dam-mo-v0``: water shortage against flooding.

Imports nothing heavier than :mod:`gym4real.core.mo_spec` (read by ``gym4real info`` and ``evaluate --mo``).
"""

from __future__ import annotations

from gym4real.core.mo_spec import MultiObjectiveSpec, Objective, Sweep

#: A constant release, from nothing to the top of the action box (``mean`` is 0.5, ``max`` 1).
CONSTANT_RELEASE = Sweep(
    "constant_release",
    "gym4real.dam.baselines:constant_release",
    tuple({"fraction": f / 10} for f in range(11)),
    "the same release every day, low + fraction (high - low) of the action box: mean is 0.5, max is 1",
)
#: The EAD rule's release scaled, from half to twice the exponential average of demand (``ead`` is 1).
SCALED_EAD = Sweep(
    "scaled_ead",
    "gym4real.dam.baselines:scaled_ead",
    tuple({"scale": s} for s in (0.5, 0.75, 1.0, 1.25, 1.5, 2.0)),
    "release scale times the exponential average of past demand: ead is scale 1; below 1 the lake holds water "
    "back, above 1 it releases ahead of demand",
)

SPECS = (
    MultiObjectiveSpec(
        env_id="gym4real/dam-mo-v0",
        objectives=(
            Objective(
                "shortage",
                ("deficit", "starving"),
                "water shortage: the seasonally weighted supply deficit (m3/s per day) plus the starvation penalty "
                "(250 per day the lake ends below -0.45 m), <= 0",
            ),
            Objective(
                "flooding",
                ("overflow",),
                "flooding: the overflow penalty, 1000 per day the lake ends above the flood level 1.24 m, <= 0",
            ),
        ),
        left_out="the paper's objective is deficit + overflow + starving (Sec. 2.1); of the five reward entries "
        "`wasted_water` (release above demand) and `clipping` (an infeasible release) are shaping terms of the "
        "training reward and are left out. Starvation (too little water in the lake) is counted with the deficit "
        "as shortage: both are the cost of releasing water the lake then lacks, against the flood risk of keeping it",
        sweeps=(CONSTANT_RELEASE, SCALED_EAD),
    ),
)
