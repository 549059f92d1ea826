"""Registration of the dam domain (imports nothing heavier than the core's records)."""

from __future__ import annotations

from gym4real.core.datasets import upstream
from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, Claim, DatasetSpec, EnvSpec, TrainingSpec

#: The gym4real plugin API this module is written for (checked against gym4real-core's PLUGIN_API_VERSION).
plugin_api = "0.2"

ENV_ID = "gym4real/dam-v0"
BASE_URL = (
    "https://raw.githubusercontent.com/Daveonwave/gym4ReaL/774d5ceb1c218e09e5c6458ead7d4b0b10e2d8ac/gym4real/data/dam"
)
#: Name suffix -> (path under the upstream data folder, SHA-256 from ../shared/data/MANIFEST.sha256).
FILES = {
    "mef": ("MEF.csv", "3fc243fb75e481aae48dfce95a2608c6f990af6928b1282d6d8fee41300ade99"),
    "demand/train": (
        "demand/water_demand_train.csv",
        "c929f1ff1d8d60d36c5f9de01ad9564725b96c3b963f07b152c3efb42efdacac",
    ),
    "demand/test": ("demand/water_demand_test.csv", "2b824db632c6ce3a26d4c5ab9984f64ed2cd7ba1ff09c119d59ed5226d831234"),
    "inflow/train": (
        "inflow/water_inflow_train.csv",
        "bd35bbdf8df16db112400d4880724dd6d329c549948b0125bde7a453fa0ecd96",
    ),
    "inflow/test": ("inflow/water_inflow_test.csv", "e056c505479a73995eb2d84c00cfcbfca25c9709e2861267e25c8a4b5f236418"),
    "level/train": ("level/water_level_train.csv", "1fad371c8c4d4e489f03e5b7882fc933db71f8e142443fd1f48820e09a8fe2d1"),
    "level/test": ("level/water_level_test.csv", "e193d6bff44158661a74d34ca4b5c5665e742a2e53ba4d1374c3222e10401818"),
}
DATASETS = tuple(f"dam/{key}" for key in FILES)


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The dam environment."""
    return [
        EnvSpec(
            id=ENV_ID,
            entry_point="gym4real.dam.env:DamEnv",
            vector_entry_point="gym4real.dam.vector:DamVectorEnv",
            description="Lake Como daily release: 365 daily decisions, hourly mass balance, 1946-2010 data",
            flags=frozenset(
                {
                    "continuous_states",
                    "continuous_actions",
                    "partially_controllable",
                    "imitation_learning",
                    "multi_objective",
                }
            ),
            presets=("default", "train", "validation", "test"),
            datasets=DATASETS,
        )
    ]


@hookimpl
def gym4real_register_datasets() -> list[DatasetSpec]:
    """Lake Como 1946-2010 (demand, inflow, level per day; minimum environmental flow)."""
    return upstream("dam", BASE_URL, FILES, "CC BY-NC 4.0")


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """Random, mean, max and average-demand releases; historical operators; model-predictive control; hindsight."""
    return [
        BaselineSpec(ENV_ID, "random", "gym4real.core.policies:random_policy", "uniform random release"),
        BaselineSpec(ENV_ID, "mean", "gym4real.dam.baselines:mean", "constant release at the middle of the box"),
        BaselineSpec(ENV_ID, "max", "gym4real.dam.baselines:max_release", "constant release at the top of the box"),
        BaselineSpec(ENV_ID, "ead", "gym4real.dam.baselines:ead", "release the exponential average of demand"),
        BaselineSpec(
            ENV_ID,
            "historical",
            "gym4real.dam.baselines:historical",
            "historical operators: mass balance inverted towards the next recorded level",
        ),
        BaselineSpec(
            ENV_ID,
            "historical_replay",
            "gym4real.dam.baselines:historical_replay",
            "replay of the historical releases reconstructed from the recorded levels",
        ),
        BaselineSpec(
            ENV_ID,
            "mpc",
            "gym4real.dam.mpc:mpc",
            "model-predictive control: the hindsight planner's programme on forecasts from the training years",
        ),
        BaselineSpec(
            ENV_ID,
            "hindsight",
            "gym4real.dam.hindsight:hindsight",
            "upper reference: dynamic programming over the lake level knowing the year's inflows and demand, then a "
            "local search through the env",
            causal=False,
            bound="heuristic",
            gap=0.0001,
            bound_note="a DP on a 2.5 mm level grid, then a local search through the env's days; a further search "
            "(transfers up to 30 days apart, finer changes, random moves) gained at most 0.0076 % on a test year "
            "(2010)",
        ),
    ]


@hookimpl
def gym4real_register_benchmarks() -> list[BenchmarkSpec | TrainingSpec]:
    """The paper's 13 test years and the PPO presets."""
    return [
        BenchmarkSpec(
            env_id=ENV_ID,
            protocol="gym4real.dam.evaluation:test_episodes",
            env_kwargs={"preset": "test"},
            policies=("random", "mean", "max", "ead", "historical"),
            rule_based=("mean", "max", "ead"),  # `historical` steers towards the recorded levels: not a rule
            objective=("deficit", "overflow", "starving"),
            final_info=("recorded_level_rmse",),
            description="the 13 test years in file order, one one-year episode each, from 0.35 m",
            step_unit="day",
            claims=(
                Claim(
                    "PPO performs better than the rule-based strategies on the 13 test years (Sec. 2.1: its four "
                    "rule-based baselines Random, Mean, Max and EAD)",
                    "ppo",
                    "above",
                    ("random", "mean", "max", "ead"),
                    section="2.1",
                ),
                Claim(
                    "PPO performs better than model-predictive control (`mpc`, the hindsight planner's programme on "
                    "forecasts) on the 13 test years (this suite's own check: the paper compares rule-based "
                    "strategies only)",
                    "ppo",
                    "above",
                    ("mpc",),
                    paper=False,
                ),
            ),
        ),
        *(TrainingSpec(ENV_ID, "ppo", preset, f"gym4real.dam:rl/ppo_{preset}.yaml") for preset in ("paper", "smoke")),
    ]
