"""The multi-objective evaluation of ``gym4real/microgrid-mo-v0``: trading profit against battery degradation.

Imports nothing heavier than :mod:`gym4real.core.mo_spec` (read by ``gym4real info`` and ``evaluate --mo``).
"""

from __future__ import annotations

from gym4real.core.mo_spec import MultiObjectiveSpec, Objective, Sweep

#: The constant fraction of the net power sent to the battery, from 0 (only_market) to 1 (battery_first).
CONSTANT_FRACTION = Sweep(
    "constant_fraction",
    "gym4real.microgrid.baselines:constant_fraction",
    tuple({"fraction": f} for f in (0.0, 0.01, 0.02, 0.05, 0.1, 0.25, 0.5, 0.75, 1.0)),
    "the same fraction of the net power to the battery every hour: only_market is 0, fifty_fifty 0.5, battery_first 1",
)

SPECS = (
    MultiObjectiveSpec(
        env_id="gym4real/microgrid-mo-v0",
        objectives=(
            Objective("trading", ("trading",), "profit: energy sold minus energy bought over the year (EUR)"),
            Objective(
                "degradation",
                ("degradation",),
                "battery aging: the replacement cost of the state of health lost over the year (EUR, <= 0)",
            ),
        ),
        left_out="`clipping` penalises a fraction the battery cannot follow (the paper's lambda r_clip): a "
        "shaping term of the training reward, not part of the paper's objective (trading + degradation)",
        sweeps=(CONSTANT_FRACTION,),
    ),
)
