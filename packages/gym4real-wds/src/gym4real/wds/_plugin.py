"""Registration of the WDS domain (imports nothing heavier than the core's records)."""

from __future__ import annotations

from gym4real.core.datasets import upstream
from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, Claim, DatasetSpec, EnvSpec, TrainingSpec

#: The gym4real plugin API this module is written for (checked against gym4real-core's PLUGIN_API_VERSION).
plugin_api = "0.2"

ENV_ID = "gym4real/wds-v0"
BASE_URL = (
    "https://raw.githubusercontent.com/Daveonwave/gym4ReaL/774d5ceb1c218e09e5c6458ead7d4b0b10e2d8ac/gym4real/data/wds"
)

#: Demand profile files (``demand/datasets/<stem>.csv``) -> sha256 (from MANIFEST.sha256).
PROFILES = {
    "interval_0_01-0_1": "54a46e0957c6cddebd3c169e3d29f59f92de9335f8e5e336c0a2f7b0b066015a",
    "interval_0_01-0_3": "b26358ed4fb167c8b6b2422e7db84ba693194846a4064afd2de37262f5a2194a",
    "interval_0_01-0_5": "520039d45dd32fa4647ee3661bb5711ea790475034acb526a253674b075f0e04",
    "interval_0_01-0_55": "46c5af759cc2a0578274ec87fc6844d86125c67038cc26bad1451ebfc5e6b215",
    "interval_0_01-0_6": "1ad24e53f9d0205d0bad50ff8fea25c867447a73ce195a7a28ca6ede748ab7b4",
    "interval_0_01-1": "1e8d1a2a851adf944760ffc215fb6eb45e7328dcbd3e9ad7699384445633e672",
    "interval_0_025-0_1": "4c980d53b7c2d56e34b8bbebf92959986690cbfa9109d93cb7a82a25f97349a2",
    "interval_0_025-0_3": "c758cd3b99b16b5b69b71b11843d29f3b213b3291ae33c8da574742b8fb17984",
    "interval_0_025-0_5": "d007d677bae044ed919551bb7ebdaefc66d30fe8979447081b34e45f796efc53",
    "interval_0_025-0_55": "162a9ab9f7bdd576226fd58e9b1ed28df1c468faa1dff5e552b6cbfec3847f00",
    "interval_0_025-0_6": "2780e2455ec498917b700e41e3ea12188dca25e1cfece6dbee2d424321f5d224",
    "interval_0_025-1": "1c59c5f36ebe4b73e4aa778e67c80b0935e921bc139202a32568353f54e6539e",
    "interval_0_05-0_1": "32ea5238622ca4e17d6245124b6f2fb13e321bbc957fa91ed1b4bcbf0b92fb9f",
    "interval_0_05-0_3": "69cdc6eefe707c06ae223a0efc839e4b6fc7217090ce851ce3a92caa4e5e0891",
    "interval_0_05-0_5": "3aae696bc455e78ad9458dddb1a06e7fe88027e8dbf455dadb249177bc65a71b",
    "interval_0_05-0_55": "33c1a95ce9dd1a7893075026c62b770e0e0067ced147767f9ebdf10262460a9c",
    "interval_0_05-0_6": "4e46ef97306458a7cdf5b8e6e4f6e797c3b120adb5db4cb16f7a15a48d1ce569",
    "interval_0_05-1": "5bbc2458804c7e7dc4215fbc97ede707edf0367ac5d1145dd552bfb38dfbe68f",
    "interval_0_075-0_1": "2e35f2e3e9abc9478edfb49b2d30b4d2ac28065af6da602f29e5bf8e798ac0ce",
    "interval_0_075-0_3": "d7341ec17a57cc9ef8ebf9d7e3ebadc47db20a363fa2e4a375535a1e569b6318",
    "interval_0_075-0_5": "8bf98371e52e635fbd1690bc7afe7c6acfbd6176b2175bcc655886baa2d411f1",
    "interval_0_075-0_55": "1ab017e9f72d4466e457b0d83d86e27724f008b14f7a9614af92b5017eb46079",
    "interval_0_075-0_6": "ab7ed3cceb3271ffe0f7b0a49e27dec81b12c4cb55ab67da87f32e2256330dfd",
    "interval_0_075-1": "6d144c3c9bb7619d83feb52fb0974073c145652eafeda871afdb59c52a2be396",
    "interval_0_1-0_3": "3fde6ce466589f6258ac5743712a8f500a067162161bdd36f1946bb6dacd5bfa",
    "interval_0_1-0_5": "d54215915deae7a938a0c7f3a80c34fc68d01597d47d5258950810a216cfbd77",
    "interval_0_1-0_55": "a583ebc120c6b113454d8edcdb7d7f528efb2b9b18c2c4690e7e2d868dd7327f",
    "interval_0_1-0_6": "e8ff5eedc8a1edbb80100770d2110bb88724e1d89e1987c7896dc3efaba3aa70",
    "interval_0_1-1": "e9872df9e65cce4ecd0f52e565d2205d72051b87a06858e1753d22ef128e55da",
    "interval_0_3-0_5": "1e8b3ec92c2227b08c1ee60ca775a946bc32b25a9e1f94ad88f507ed02137fdc",
    "interval_0_3-0_55": "f391db4f952b8244067d5da2b6f88bec809a42aa0b60b0a2c430e699bb91efdb",
    "interval_0_3-0_6": "e6d61248bbe9cf91c1fc256765e2e13af6522e374b57b1aa6fe506025a9ff93b",
    "interval_0_3-1": "3f510acea26bce10e1b3c1e7ca04d028b4a34159fb34d3552273eaa2930da9c1",
    "test1000": "71defc2fe3263216213c327868b637c7db3d2bc0bedcbaac43b1c6249e60d4aa",
}


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The Anytown pump-scheduling environment."""
    return [
        EnvSpec(
            id=ENV_ID,
            entry_point="gym4real.wds.env:WDSEnv",
            description="Anytown water network on EPANET: switch 2 pumps hourly for a week (DSR vs tank overflow)",
            flags=frozenset({"continuous_states", "partially_controllable", "imitation_learning", "multi_objective"}),
            presets=("default", "hourly_hydraulics", "train", "validation", "test"),
            datasets=("wds/anytown", "wds/demand/catalogue", *(f"wds/demand/{s}" for s in PROFILES)),
            info_provider="gym4real.wds.engine:engine_info",
        )
    ]


@hookimpl
def gym4real_register_datasets() -> list[DatasetSpec]:
    """The Anytown network, the demand catalogue and the 34 demand-profile files."""
    files = {
        "anytown": ("towns/anytown_map.inp", "79a08afed2a2972da5bff5f41234e2afd637d61716e1613ac1227c63d52d76d5"),
        "demand/catalogue": (
            "demand/anytown_demands.yaml",
            "cce3e4c57424c75b1a6707a6294b17d913ba1622fabed867928caae9f4b85ebf",
        ),
    }
    network = upstream("wds", BASE_URL, {"anytown": files.pop("anytown")}, "Anytown benchmark network (public)")
    profiles = upstream(
        "wds",
        BASE_URL,
        {**files, **{f"demand/{s}": (f"demand/datasets/{s}.csv", h) for s, h in PROFILES.items()}},
        "CC BY 4.0 (Gym4ReaL Croissant metadata); generated with STREaM (GPL-3.0)",
    )
    return network + profiles


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """Random, the single-pump policies, the tank-level rule, the causal MPC and the non-causal hindsight planner."""
    return [
        BaselineSpec(ENV_ID, "random", "gym4real.core.policies:random_policy", "uniform random pump combinations"),
        BaselineSpec(ENV_ID, "p78", "gym4real.wds.baselines:p78", "P78 always on, P79 off (action 2)"),
        BaselineSpec(ENV_ID, "p79", "gym4real.wds.baselines:p79", "P79 always on, P78 off (action 1)"),
        BaselineSpec(
            ENV_ID,
            "default",
            "gym4real.wds.baselines:default",
            "the network's [CONTROLS] tank-level rule: pump on below 5 m, off above 8 m (the expert)",
        ),
        BaselineSpec(
            ENV_ID,
            "mpc",
            "gym4real.wds.mpc:mpc",
            "causal model-predictive control: every hour, the hindsight planner's beam search over the next 6 hours "
            "on forecast demand (the past days' same hour and the training profiles' daily shape)",
        ),
        BaselineSpec(
            ENV_ID,
            "hindsight",
            "gym4real.wds.hindsight:hindsight",
            "non-causal upper reference: knows the week's demand, beam search over pump schedules through EPANET",
            causal=False,
            bound="heuristic",
            gap=0.0015,
            bound_note="exact on the 15 of the 20 test weeks where it reaches the ceiling 168 (every hour scores at "
            "most 1); on the other five a search of width 32 instead of 8 gains at most 0.24 (week 12: 0.15 %)",
        ),
    ]


@hookimpl
def gym4real_register_benchmarks() -> list[BenchmarkSpec | TrainingSpec]:
    """The paper's 20 test episodes and the DQN presets."""
    return [
        BenchmarkSpec(
            env_id=ENV_ID,
            protocol="gym4real.wds.evaluation:test_episodes",
            env_kwargs={"preset": "test"},
            policies=("random", "p78", "p79", "default"),
            rule_based=("p78", "p79", "default"),
            objective=("dsr", "overflow"),
            description="test profiles 0..19 (the paper's 20 episodes); return = cumulative DSR - OVF",
            step_unit="hour",
            claims=(
                Claim(
                    "DQN achieves a higher resilience than the other baselines (Sec. 2.6: its rule-based "
                    "baselines Random, P78, P79 and Default)",
                    "dqn",
                    "above",
                    ("random", "p78", "p79", "default"),
                    section="2.6",
                ),
                Claim(
                    "DQN has a more consistent behaviour, with low variance (Sec. 2.6; the sentence names no "
                    "baselines: those of its figure, Random, P78, P79 and Default)",
                    "dqn",
                    "less_variable",
                    ("random", "p78", "p79", "default"),
                    section="2.6",
                ),
                Claim(
                    "DQN achieves a higher resilience than model-predictive control (`mpc`, the hindsight planner's "
                    "beam search on forecast demand) on the 20 test weeks (this suite's own check: the paper compares "
                    "rule-based strategies only)",
                    "dqn",
                    "above",
                    ("mpc",),
                    paper=False,
                ),
            ),
        ),
        *(TrainingSpec(ENV_ID, "dqn", preset, f"gym4real.wds:rl/dqn_{preset}.yaml") for preset in ("paper", "smoke")),
    ]
