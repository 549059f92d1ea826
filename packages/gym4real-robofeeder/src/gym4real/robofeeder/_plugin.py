"""Registration of the RoboFeeder domain (imports nothing heavier than the core's records)."""

from __future__ import annotations

import warnings

from gym4real.core.datasets import upstream
from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, Claim, DatasetSpec, EnvSpec, TrainingSpec

#: The gym4real plugin API this module is written for (checked against gym4real-core's PLUGIN_API_VERSION).
plugin_api = "0.2"

DOMAIN = "robofeeder"
PICKING_V0 = "gym4real/robofeeder-picking-v0"
PICKING_V1 = "gym4real/robofeeder-picking-v1"
PLANNING_V0 = "gym4real/robofeeder-planning-v0"

# picking-v0 and picking-v1 are two tasks of the paper (one object; several), not two versions of one task:
# Gymnasium's "picking-v0 is out of date, consider upgrading to v1" is wrong for them.
warnings.filterwarnings("ignore", message=f".*{PICKING_V0} is out of date", category=DeprecationWarning)

_COMMIT = "774d5ceb1c218e09e5c6458ead7d4b0b10e2d8ac"
_REPO = f"https://raw.githubusercontent.com/Daveonwave/gym4ReaL/{_COMMIT}/gym4real/envs/robofeeder"
_LICENCE = "Apache-2.0"

_V = "meshes/tx2_60/visual/"

#: Every file the MJCF scene reads: path below upstream `src/staubli/` -> sha256 (MANIFEST.sha256).
MODEL_FILES: dict[str, str] = {
    "urdf/tx2_60.xml": "b113f4677f9560b1e86aff133af085baadc25a361866ac0b02241e5c5560475b",
    "urdf/box.xml": "e405d846b3d7ea3c565935f22c2f9666cb833b014a1fee8434009c22d8b2f239",
    "urdf/object_v2pattern.xml": "748e3714500f1b806669747fd082a56130399678574c169205b93a34628d9b0d",
    f"{_V}base_link.stl": "81d52c78e09c6d75b487233067f0d8397f0ba508f8d5f1e64e1097f1ab14d874",
    f"{_V}link_1.stl": "6f7f96a9b87a920548fb1ddca1891cd79828a39411d0e12b726b37047275d05c",
    f"{_V}link_2.stl": "f88ced00e62f30280df1e339c962a2b851988cf017fe90e3a9ca43b8426cb92a",
    f"{_V}link_3.stl": "bf8e165b6a250c090d0662233081b89a957d5ce1b71b521fa0e10730028c030c",
    f"{_V}link_4.stl": "83b1e63549650b533e9ba362e8f199e478681ae501f83bae23ab22caebd3dbb8",
    f"{_V}link_5.stl": "e06ad46842d07a48f5a1f1d8fa83ef966631ce242270d619c053c1750de83827",
    f"{_V}link_6.stl": "575dd1dccaea40c028df5d3b7165a300a9530f80d7d9320c44f5c6961096c076",
    f"{_V}hand.stl": "5311cc63f501976d496b580ef51f7f73ff765c4279c704bf6fd172adb7708b8d",
    f"{_V}LeftFinger.stl": "becd6705701040e9c3b9d20e0445a75440fdfe5c309714b0adb8922e8134a75d",
    f"{_V}RightFinger.stl": "63af9eaa626079cafb420710d0526773d5506fa3c14556c0cb12e76e034c7fd3",
    f"{_V}box_sopra.obj": "9042894036fdae76ed6c021a551d5a5b60e2237356e1b1761b31a8670f2762b9",
    f"{_V}box_sopra_collision_0.obj": "334e909185c7b2c4897376befb51ebfb0c3be5d1e309d547d21208b0a9c4e4d1",
    f"{_V}box_sopra_collision_1.obj": "0291d9f8bc9f96bbe9d1ec40fbd003ef6850312b28e7abe47e55ab6f7f93ec9a",
    f"{_V}box_sopra_collision_3.obj": "bea6fe9de68dce406f6e5e7aa8bb94fa0dcdf26eed8bac82aeb7c4947a97f186",
    f"{_V}box_sopra_collision_5.obj": "fe034ec13b0293b4523cc6f97a146f04098211b7a8becc8176c2b075d66712b5",
    f"{_V}box_sopra_collision_6.obj": "7fc4e889faf7a80d7d5613ae9ccf5b02972bfd17128efbf130965bc7de13a944",
    f"{_V}box_sopra_collision_7.obj": "07f509512916e7288fb2eb398b6d609f70257d5f6363dfdb06dcc6d4e3603807",
    f"{_V}box_sopra_collision_8.obj": "5742e0f55afc31135aad426e7fd788ae3681e1af3207c237c50f49f8e2ed5005",
    f"{_V}box_sopra_collision_9.obj": "17b6b262a1e6147df5211602241c5825c08e8ee729dc4491b1a62438a937ca2f",
    f"{_V}piatto.obj": "2eeaf7de67b9a0a869c616710f6c6930ad0401047c4921f6e784859df7b42ac9",
    f"{_V}robot_base.obj": "ae857e8e790c5566dd3e4fc7ca03c18eec7dada3aa8cfd93e6bd8c6759066414",
    f"{_V}object.obj": "60ea0eaead0daf7a675ef56d82259d0ed62ab92d3994902901aa35c95362920b",
    f"{_V}object_collision_0.obj": "ef6e378203eb52732faf8cac88cb11c0d797b10f04e80c4bf074a5910e14599b",
    f"{_V}object_collision_1.obj": "8360797af4bae3041be00b3606813fa57e7a3c115306b90a7849ff05b96b0e0c",
    f"{_V}object_collision_2.obj": "68e453b5a4bec0c5d54ab64ad0c20c22b9c11625882b2fdfad1e343bd3ffe112",
    f"{_V}object_collision_3.obj": "9f4cbc3a3064ba9fc953834f17993b6313fe7bb0d9ac86000c58987b0bd4fb7c",
    f"{_V}object_collision_4.obj": "2fdd00d253e5e67a068fe31db4804e66d8dceadd8091f05038a4c01f6c1fc1bf",
}

#: The pretrained PPO agents of the reference (ONNX, SB3 CnnPolicy exports).
PRETRAINED_FILES: dict[str, str] = {
    "robofeeder-picking.onnx": "0fa18b7c2f1f10a596e1c0e8494a7f51d685eda54eec45acff8c6ed84c874ce8",
    "robofeeder-planning.onnx": "f0217db42a2e0fa7f27e768666420ccbc687715a5d170f7623fcf7ddac197a24",
}

#: Dataset name of a model file (``robofeeder/model/<path>``) and of a pretrained agent.
MODEL_DATASETS = tuple(f"{DOMAIN}/model/{path}" for path in MODEL_FILES)
PICKING_AGENT = f"{DOMAIN}/pretrained/robofeeder-picking.onnx"
PLANNING_AGENT = f"{DOMAIN}/pretrained/robofeeder-planning.onnx"

_FLAGS = frozenset({"continuous_states", "visual_input", "hierarchical"})


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The two picking environments and the planning environment."""
    info = "gym4real.robofeeder.rendering:engine_info"
    picking = (
        (PICKING_V0, "RoboFeederPickingEnv", "grasp a detected hinge from a 50x50 crop (grasp point and yaw)"),
        (PICKING_V1, "RoboFeederPickingImageEnv", "grasp a hinge from the full 300x300 top-down image"),
    )
    return [
        *(
            EnvSpec(
                id=env_id,
                entry_point=f"gym4real.robofeeder.env:{cls}",
                description=f"MuJoCo robot cell: {what}",
                flags=_FLAGS | {"continuous_actions"},
                presets=("default", "test"),
                datasets=MODEL_DATASETS,
                max_episode_steps=2,
                info_provider=info,
            )
            for env_id, cls, what in picking
        ),
        EnvSpec(
            id=PLANNING_V0,
            entry_point="gym4real.robofeeder.planning:RoboFeederPlanningEnv",
            description="MuJoCo robot cell: choose which of N detected hinges a pretrained picking agent grasps next",
            flags=_FLAGS,
            presets=("default", "test"),
            datasets=(*MODEL_DATASETS, PICKING_AGENT),
            max_episode_steps=5,
            info_provider=info,
        ),
    ]


@hookimpl
def gym4real_register_datasets() -> list[DatasetSpec]:
    """The MJCF scene with its meshes, and the two pretrained ONNX agents."""
    model = upstream(
        DOMAIN,
        f"{_REPO}/src/staubli",
        {f"model/{path}": (path, sha) for path, sha in MODEL_FILES.items()},
        _LICENCE,
        subdir="model",
    )
    agents = upstream(
        DOMAIN,
        f"{_REPO}/utils/Pretrained",
        {f"pretrained/{name}": (name, sha) for name, sha in PRETRAINED_FILES.items()},
        _LICENCE,
        subdir="pretrained",
    )
    return model + agents


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """`random` everywhere, `fixed` (picking), plus an `oracle` reading the true pose everywhere.

    The `oracle` is robofeeder's upper reference (``causal=False``, as the other domains' ``hindsight``): it is
    handed the simulator's ground truth, which no agent observes.
    """
    oracle = "gym4real.robofeeder.baselines:oracle"
    return [
        *(
            spec
            for env_id in (PICKING_V0, PICKING_V1)
            for spec in (
                BaselineSpec(
                    env_id,
                    "fixed",
                    "gym4real.robofeeder.baselines:fixed",
                    "the reference baseline: action (0, 0, 0) (crop or image centre, yaw pi/2)",
                ),
                BaselineSpec(env_id, "random", "gym4real.core.policies:random_policy", "uniform random grasp action"),
                BaselineSpec(
                    env_id,
                    "oracle",
                    oracle,
                    "upper reference: grasps the nearest object at its true grasp point and yaw (reads the simulator's "
                    "ground truth, which the agent must infer from the camera)",
                    causal=False,
                    bound="not a bound",
                    bound_note="one fixed choice (the nearest object at its true grasp point), not a search over the "
                    "grasps: nothing shows that a controller cannot pick more",
                ),
            )
        ),
        BaselineSpec(
            PICKING_V0,
            "pretrained",
            "gym4real.robofeeder.baselines:pretrained",
            "the reference's pretrained PPO picking agent (ONNX), its deterministic mean, clipped",
        ),
        BaselineSpec(PLANNING_V0, "random", "gym4real.core.policies:random_policy", "uniform random crop or idle"),
        BaselineSpec(
            PLANNING_V0,
            "pretrained",
            "gym4real.robofeeder.baselines:pretrained",
            "the reference's pretrained PPO planning agent (ONNX), argmax of its logits; the model ignores its "
            "input (saturated first tanh layer: the same logits for every observation), so it always picks crop 1 "
            "and never idles",
        ),
        BaselineSpec(
            PLANNING_V0,
            "oracle",
            oracle,
            "upper reference: picks a crop holding a graspable object, idles when none is left (reads the "
            "simulator's ground truth)",
            causal=False,
            bound="not a bound",
            bound_note="a rule reading the ground truth, not a search: the published PPO scores more on 17 of the 50 "
            "test episodes (by up to 5)",
        ),
    ]


#: The picking claims: the paper's on picking-v0 (Sec. 2.4.1 evaluates picking-v0 only), this suite's own on v1.
PICKING_CLAIMS = {
    PICKING_V0: Claim(
        "PPO achieves higher success rates than the fixed-action rule-based baseline on picking-v0 (Sec. 2.4.1; "
        'the paper\'s "more evenly distributed" refers to its workspace heatmaps, drawn in this section)',
        "ppo",
        "above",
        ("fixed",),
        quantity="success",
        section="2.4.1",
    ),
    PICKING_V1: Claim(
        "PPO achieves a higher success rate than the fixed-action baseline on picking-v1 (this suite's own check: "
        "the paper evaluates picking-v0 only)",
        "ppo",
        "above",
        ("fixed",),
        quantity="success",
        paper=False,
    ),
}


@hookimpl
def gym4real_register_benchmarks() -> list[BenchmarkSpec | TrainingSpec]:
    """Seeded evaluation episodes per environment and the PPO presets of the paper's appendix."""
    picking = [
        BenchmarkSpec(
            env_id=env_id,
            protocol="gym4real.robofeeder.evaluation:test_episodes",
            env_kwargs={"preset": "test"},
            policies=("random", "fixed", "oracle"),
            rule_based=("fixed",),  # `oracle` reads the simulator's true pose
            final_info=("objects_picked",),
            figures="gym4real.robofeeder.figures:bench_heatmap" if env_id == PICKING_V0 else None,
            placements="gym4real.robofeeder.evaluation:test_placements" if env_id == PICKING_V0 else None,
            description="100 seeded episodes (seeds 1000..1099), one object uniformly placed in the spawn area",
            step_unit="grasp attempt",
            claims=(PICKING_CLAIMS[env_id],),
            portable_forward=True,  # the contacts turn an action's last bit into another grasp
        )
        for env_id in (PICKING_V0, PICKING_V1)
    ]
    planning = BenchmarkSpec(
        env_id=PLANNING_V0,
        protocol="gym4real.robofeeder.evaluation:planning_test_episodes",
        env_kwargs={"preset": "test"},
        policies=("random", "oracle"),
        final_info=("objects_picked",),
        figures="gym4real.robofeeder.figures:bench_planning",
        description="50 seeded episodes (seeds 1000..1049), three objects",
        step_unit="planning decision (one object chosen, or idle)",
        portable_forward=True,
        claims=(
            Claim(
                "PPO picks more efficiently than the Random strategy (Sec. 2.4.2: the average return of its planning "
                "comparison)",
                "ppo",
                "above",
                ("random",),
                section="2.4.2",
            ),
        ),
    )
    trainings = [
        TrainingSpec(env_id, "ppo", preset, f"gym4real.robofeeder:rl/{kind}_ppo_{preset}.yaml")
        for env_id, kind in ((PICKING_V0, "picking"), (PICKING_V1, "picking"), (PLANNING_V0, "planning"))
        for preset in ("paper", "smoke")
    ]
    return [*picking, planning, *trainings]
