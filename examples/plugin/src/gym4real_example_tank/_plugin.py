"""Registration of the tank example (imports nothing heavier than the core's records)."""

from __future__ import annotations

from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, EnvSpec

#: The gym4real plugin API this module is written for.
plugin_api = "0.2"

ENV_ID = "gym4real/tank-v0"


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The tank environment (imported only when it is made)."""
    return [
        EnvSpec(
            id=ENV_ID,
            entry_point="gym4real_example_tank.env:TankEnv",
            description="Example plugin: keep the level of a tank at its target",
            max_episode_steps=100,
        )
    ]


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """A random policy and a rule that refills what the mean outflow drains."""
    return [
        BaselineSpec(ENV_ID, "random", "gym4real.core.policies:random_policy", "uniform random inflow"),
        BaselineSpec(ENV_ID, "refill", "gym4real_example_tank.env:refill", "inflow = gap to target + mean outflow"),
    ]
