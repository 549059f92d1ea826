"""Configuration: presets per environment family, fix switches, validation errors, registration."""

from __future__ import annotations

import pytest

from gym4real.core.config import PresetRenamedWarning
from gym4real.core.errors import ConfigError
from gym4real.core.registry import registry
from gym4real.robofeeder.config import FIX_NAMES, PickingConfig, PlanningConfig


def test_presets_are_split_by_family() -> None:
    assert PickingConfig.presets() == ["default", "test"]
    assert PlanningConfig.presets() == ["default", "test"]
    assert PlanningConfig.build().n_objects == 3 and PlanningConfig.build().max_steps == 5
    assert PickingConfig.build().n_objects == 1 and PickingConfig.build().max_steps == 2
    with pytest.raises(ConfigError, match="unknown preset"):
        PickingConfig.build(preset="planning_test")


def test_the_former_planning_preset_names_warn_and_name_the_new_ones() -> None:
    for old, new in (("planning", "default"), ("planning_test", "test")):
        with pytest.warns(PresetRenamedWarning, match=f"preset `{old}` of PlanningConfig is now called `{new}`"):
            assert PlanningConfig.build(preset=old) == PlanningConfig.build(preset=new)


def test_fixes_follow_fidelity_unless_set() -> None:
    corrected, upstream = PickingConfig.build(), PickingConfig.build(fidelity="upstream")
    assert all(corrected.fix(n) for n in FIX_NAMES)
    assert not any(upstream.fix(n) for n in FIX_NAMES)
    mixed = PickingConfig.build(fidelity="upstream", fixes={"crop_clamp": True})
    assert mixed.fix("crop_clamp") and not mixed.fix("grasp_angle")
    with pytest.raises(ConfigError, match="unknown fix"):
        corrected.fix("nope")


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"bogus": 1}, "unknown field"),
        ({"image_size": 10}, "image_size"),
        ({"crop_size": 400}, "crop_size"),
        ({"spawn": {"x_range": [0.5, 0.1]}}, "x_range"),
        ({"render_camera": "nope"}, "render_camera"),
        ({"controller": {"close_gripper": 0.009, "open_gripper": 0.008}}, "close_gripper"),
    ],
)
def test_validation_errors(overrides: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        PickingConfig.build(**overrides)


def test_reference_constants() -> None:
    c = PickingConfig.build()
    assert (c.controller.long_pause, c.controller.short_pause) == (0.025, 0.016)
    gripper = (c.controller.delta_gripper, c.controller.open_gripper, c.controller.close_gripper)
    assert gripper == (0.00355, 0.008, 0.00125)
    assert (c.reward.distance_weight, c.reward.delta_d, c.reward.delta_theta) == (0.85, 0.012, 0.35)
    assert (c.settle_steps, c.post_pick_steps, c.success_radius) == (900, 400, 0.12)


def test_registration() -> None:
    reg = registry()
    ids = ("gym4real/robofeeder-picking-v0", "gym4real/robofeeder-picking-v1", "gym4real/robofeeder-planning-v0")
    assert set(ids) <= set(reg.envs)
    assert set(reg.baselines[ids[0]]) == {"random", "fixed", "oracle", "pretrained"}
    assert set(reg.baselines[ids[2]]) == {"random", "oracle", "pretrained"}
    assert all(reg.datasets[name].sha256 for name in reg.envs[ids[2]].datasets)
    assert {(e, a, p) for (e, a, p) in reg.trainings if e in ids} == {
        (i, "ppo", p) for i in ids for p in ("paper", "smoke")
    }


def test_making_picking_v0_does_not_call_it_out_of_date() -> None:
    """v0 and v1 are different tasks of the paper: Gymnasium's "consider upgrading to v1" must not show."""
    import subprocess
    import sys

    code = "import gymnasium as gym, gym4real; gym.make('gym4real/robofeeder-picking-v0').close()"
    done = subprocess.run([sys.executable, "-W", "default", "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "out of date" not in done.stderr
