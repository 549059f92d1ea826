"""The multi-objective evaluation of ``gym4real/wds-mo-v0``: demand satisfaction against overflow risk.

Imports nothing heavier than :mod:`gym4real.core.mo_spec` (read by ``gym4real info`` and ``evaluate --mo``).
"""

from __future__ import annotations

from gym4real.core.mo_spec import MultiObjectiveSpec, Objective, Sweep

#: Pump combinations of Anytown's two pumps (P78, P79) as actions: 0 both off, 1 P79, 2 P78, 3 both on.
CONSTANT_PUMPS = Sweep(
    "constant_pumps",
    "gym4real.wds.baselines:constant_pumps",
    tuple({"action": a} for a in range(4)),
    "the same pump combination every hour, each of the four (p79 is action 1, p78 action 2)",
)
#: The tank-level rule with its 3 m band moved from 1-4 m to 7-10 m (``default`` is 5-8 m).
TANK_LEVEL = Sweep(
    "tank_level_rule",
    "gym4real.wds.baselines:tank_level_rule",
    tuple({"low": low, "high": low + 3.0} for low in (1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0)),
    "the network's tank-level rule (default: open below 5 m, close above 8 m) with its 3 m band moved from "
    "1-4 m to 7-10 m: a lower band keeps the tanks away from overflow at the cost of pressure",
)

SPECS = (
    MultiObjectiveSpec(
        env_id="gym4real/wds-mo-v0",
        objectives=(
            Objective(
                "dsr",
                ("dsr",),
                "demand satisfaction: the sum over the week's hours of the supplied over the expected demand "
                "(0 to 168)",
            ),
            Objective(
                "overflow",
                ("overflow",),
                "overflow risk: minus the sum over the hours of each tank's level above 95 % of its height, as a "
                "fraction of the last 5 % (0 to 1 per tank and hour), <= 0",
            ),
        ),
        sweeps=(CONSTANT_PUMPS, TANK_LEVEL),
    ),
)
