"""Registration of the elevator domain (imports nothing heavier than the core's records)."""

from __future__ import annotations

from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, Claim, DatasetSpec, EnvSpec, TrainingSpec

#: The gym4real plugin API this module is written for (checked against gym4real-core's PLUGIN_API_VERSION).
plugin_api = "0.2"

ENV_ID = "gym4real/elevator-v0"


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The elevator environment."""
    return [
        EnvSpec(
            id=ENV_ID,
            entry_point="gym4real.elevator.env:ElevatorEnv",
            description="Single elevator, peak-down traffic, discrete (tabular) states and actions",
            flags=frozenset({"partially_controllable", "provably_efficient"}),
            presets=("default", "test"),
            vector_entry_point="gym4real.elevator.vector:ElevatorVectorEnv",
        )
    ]


@hookimpl
def gym4real_register_datasets() -> list[DatasetSpec]:
    """None: arrivals are synthetic."""
    return []


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """Random, longest-first and shortest-first dispatching; the hindsight planner (a non-causal upper reference)."""
    return [
        BaselineSpec(ENV_ID, "random", "gym4real.core.policies:random_policy", "uniform random actions"),
        BaselineSpec(
            ENV_ID, "longest_first", "gym4real.elevator.baselines:longest_first", "serve the longest queue first"
        ),
        BaselineSpec(
            ENV_ID,
            "shortest_first",
            "gym4real.elevator.baselines:shortest_first",
            "serve the shortest non-empty queue first",
        ),
        BaselineSpec(
            ENV_ID,
            "hindsight",
            "gym4real.elevator.hindsight:hindsight",
            "upper reference: exact dynamic programming over cabin, load and queues knowing the episode's arrivals",
            causal=False,
            bound="exact",
            bound_note="the arrivals do not depend on the actions, so dynamic programming over the full state is the "
            "optimum; a test finds it equal to the best of every action sequence of a short episode",
        ),
    ]


@hookimpl
def gym4real_register_benchmarks() -> list[BenchmarkSpec | TrainingSpec]:
    """The paper's 30 evaluation episodes and the tabular RL presets."""
    return [
        BenchmarkSpec(
            env_id=ENV_ID,
            protocol="gym4real.elevator.evaluation:test_episodes",
            env_kwargs={"preset": "test"},
            policies=("random", "longest_first", "shortest_first"),
            rule_based=("longest_first", "shortest_first"),
            description="30 episodes of the seed-1234 evaluation sequence",
            step_unit="second",
            claims=(
                Claim(
                    "Q-learning consistently outperforms the rule-based solutions (Sec. 2.2: its rule-based strategies "
                    "Random, Longest-First and Shortest-First)",
                    "qlearning",
                    "above",
                    ("random", "longest_first", "shortest_first"),
                    consistently=True,
                    section="2.2",
                ),
                Claim(
                    "SARSA consistently outperforms the rule-based solutions (Sec. 2.2: its rule-based strategies "
                    "Random, Longest-First and Shortest-First)",
                    "sarsa",
                    "above",
                    ("random", "longest_first", "shortest_first"),
                    consistently=True,
                    section="2.2",
                ),
                Claim(
                    "Q-learning shows higher performance than SARSA (Sec. 2.2)",
                    "qlearning",
                    "above",
                    ("sarsa",),
                    section="2.2",
                ),
            ),
        ),
        *(
            TrainingSpec(ENV_ID, algo, preset, f"gym4real.elevator:rl/{algo}_{preset}.yaml")
            for algo in ("qlearning", "sarsa")
            for preset in ("paper", "smoke")
        ),
    ]
