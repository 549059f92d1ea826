"""Registration of the microgrid domain (imports nothing heavier than the core's records)."""

from __future__ import annotations

from gym4real.core.datasets import upstream
from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, Claim, DatasetSpec, EnvSpec, TrainingSpec

#: The gym4real plugin API this module is written for (checked against gym4real-core's PLUGIN_API_VERSION).
plugin_api = "0.2"

ENV_ID = "gym4real/microgrid-v0"
DOMAIN = "microgrid"
COMMIT = "774d5ceb1c218e09e5c6458ead7d4b0b10e2d8ac"
REPO = f"https://raw.githubusercontent.com/Daveonwave/gym4ReaL/{COMMIT}/gym4real"

# name suffix -> (path under microgrid/, sha256); demand/train is absent from the reference snapshot but
# published upstream (checksum from the Croissant metadata metadata_MG.json).
DATA = {
    "demand/train": (
        "demand/profiles_train.csv",
        "86d05e2784e3a22005e37fd8622d1eccc7582b688a5b98b78778192cc40fb312",
    ),
    "demand/test": ("demand/profiles_test.csv", "410a54ad7c5d7ee05b34d1037b0001c0d59b869d65983e4fe2d2c605b84a80e2"),
    "generation/train": (
        "generation/pv_ninja_2015-2019_3kW_train.csv",
        "3fc0907da7feefbe1949538800a6d5f65cd9df90e0eb12a405f5b511cde9b67e",
    ),
    "generation/test": (
        "generation/pv_ninja_2019-2020_3kW_test.csv",
        "f8141412ce5f958457dca88ff6e611f9a347c5645b4f1138650f0aeaa0b82022",
    ),
    "market/train": (
        "market/gme_2015-2019_train.csv",
        "22c761c0dc3942badf65eea4f5c3ea7e1735123e863c3b86fb5b16d5de8daa94",
    ),
    "market/test": (
        "market/gme_2019-2020_test.csv",
        "810fb3e258098d28612ab0d93f6c5be97c487f25766176105946cb160106f265",
    ),
    "temp_amb/train": (
        "temp_amb/temp_amb_2015-2019_train.csv",
        "8c6383ea662a9c7eb628ddd1dc30d40654291d843711ec4d907d752ad2df5e21",
    ),
    "temp_amb/test": (
        "temp_amb/temp_amb_2019-2020_test.csv",
        "c8b266fd915b27add596d40db1618a6527fda301aaecd21bda447c7f16c040d5",
    ),
    "metadata": ("metadata_MG.json", "834904081b55478cb0fa9c1cd48c4fc6f7a83242267df944c1cf97cdd4faa8fe"),
}

# upstream these live under envs/microgrid/simulator/energy_storage/configuration/, here under microgrid/battery/
BATTERY = {
    "battery/pack": ("battery_pack.yaml", "39cddef39aaef910cc73102e6ca1cf5c68074ef28e4cfad954321d2ae7280871"),
    "battery/electrical": (
        "models/electrical.yaml",
        "a61ebe7e3fd0c54514a61de444831af28f36329bfbe6daed9c0e9e97810a5dd9",
    ),
    "battery/thermal": ("models/thermal.yaml", "e414d176613b031c81aa95fc0795890e59874eb812ebe9120a31ed2e90fe5ce5"),
    "battery/aging": ("models/aging.yaml", "1f4d59da281c055f96354af2c23981275f61e53c2b3aae3354b21fefd89c40e3"),
    "battery/r0": ("params/r0_pack.csv", "ae8b4ddb87933dd1ae5d77a22068ac03f9e4b78d32373f43c51aefc67e62aceb"),
    "battery/r1": ("params/r1_pack.csv", "b92bc5ae917523217c7241366099d9d6eea312263210c7ed2cad252994a6ded3"),
    "battery/c": ("params/c_pack.csv", "426e9c1c370eec242b15e8a46464987084a1c36929c7202e8ef948f89b8e13df"),
    "battery/voc": ("params/voc_pack.csv", "68aa2909e793e91251feadf7849eaae87a44ed93e8daa2725317c12e2a348d06"),
}

BASELINES = {
    "only_market": "a = 0: trade all the net power, never use the battery",
    "battery_first": "a = 1: the battery first, the market for what it cannot take or give",
    "fifty_fifty": "a = 0.5: half of the net power to the battery, half to the market",
}


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The microgrid environment."""
    return [
        EnvSpec(
            id=ENV_ID,
            entry_point="gym4real.microgrid.env:MicrogridEnv",
            vector_entry_point="gym4real.microgrid.vector:MicrogridVectorEnv",
            description="Household PV + battery (digital twin) + day-ahead market, hourly, continuous action",
            flags=frozenset(
                {
                    "continuous_states",
                    "continuous_actions",
                    "partially_controllable",
                    "frequency_adaptation",
                    "multi_objective",
                }
            ),
            presets=("default", "train", "test"),
            datasets=tuple(f"{DOMAIN}/{k}" for k in (*DATA, *BATTERY) if k != "metadata"),
        )
    ]


@hookimpl
def gym4real_register_datasets() -> list[DatasetSpec]:
    """The hourly series, the Croissant metadata and the battery configuration."""
    battery_url = f"{REPO}/envs/microgrid/simulator/energy_storage/configuration"
    return [
        *upstream(DOMAIN, f"{REPO}/data/microgrid", DATA, "CC BY 4.0 (demand), CC BY-NC 4.0 (PV, market, temperature)"),
        *upstream(DOMAIN, battery_url, BATTERY, "Apache-2.0", subdir="battery"),
    ]


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """Random, only-market, battery-first, 50-50, the causal MPC and the non-causal hindsight planner."""
    return [
        BaselineSpec(ENV_ID, "random", "gym4real.core.policies:random_policy", "uniform random fraction"),
        *(BaselineSpec(ENV_ID, name, f"gym4real.microgrid.baselines:{name}", text) for name, text in BASELINES.items()),
        BaselineSpec(
            ENV_ID,
            "mpc",
            "gym4real.microgrid.mpc:mpc",
            "causal model-predictive control: each day forecasts the next 24 h (demand and PV: the hour's mean "
            "over the past 7 days; prices: the coming hour's as shown, then yesterday's), plans the SoC on them "
            "with the hindsight planner's DP and tracks the plan through the twin",
        ),
        BaselineSpec(
            ENV_ID,
            "hindsight",
            "gym4real.microgrid.hindsight:hindsight",
            "non-causal upper reference: knows the household-year's demand, PV, prices and weather, plans the SoC "
            "by dynamic programming, then a local search through the twin",
            causal=False,
            bound="heuristic",
            gap=0.001,
            bound_note="a DP of a model of the twin on a 0.001 SoC grid, then a local search through the twin; a "
            "further search (other changes, longer spans, a 48-hour window) gained at most 0.095 % on a test "
            "household (373)",
        ),
    ]


@hookimpl
def gym4real_register_benchmarks() -> list[BenchmarkSpec | TrainingSpec]:
    """The 28 test households of 2019 and the PPO presets."""
    return [
        BenchmarkSpec(
            env_id=ENV_ID,
            protocol="gym4real.microgrid.evaluation:test_episodes",
            env_kwargs={"preset": "test"},
            policies=("random", "only_market", "battery_first", "fifty_fifty"),
            rule_based=("only_market", "battery_first", "fifty_fifty"),
            objective=("trading", "degradation"),
            final_info=("soh",),
            description="one 2019 episode (8759 h) per test household 370..397; objective in EUR",
            step_unit="hour",
            claims=(
                Claim(
                    "PPO achieves higher profit than the rule-based strategies (Sec. 2.3: its rule-based policies "
                    "Random, Only-market, Battery-first and 50-50)",
                    "ppo",
                    "above",
                    ("random", "only_market", "battery_first", "fifty_fifty"),
                    section="2.3",
                ),
                Claim(
                    "PPO achieves higher profit than model-predictive control (`mpc`, the hindsight planner's "
                    "programme on forecasts) on the 28 test households (this suite's own check: the paper compares "
                    "rule-based strategies only)",
                    "ppo",
                    "above",
                    ("mpc",),
                    paper=False,
                ),
            ),
        ),
        *(
            TrainingSpec(ENV_ID, "ppo", preset, f"gym4real.microgrid:rl/ppo_{preset}.yaml")
            for preset in ("paper", "smoke")
        ),
    ]
