"""Training presets refuse NaN and infinities, at any depth, naming the field (issue 12 section 2)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from gym4real.core.errors import ConfigError
from gym4real.rl.presets import load_preset

TABULAR: dict[str, Any] = {
    "algo": "qlearning",
    "episodes": 10,
    "alpha": 0.1,
    "gamma": 0.9,
    "epsilon": {"start": 1.0, "decay": 0.99, "min": 0.01},
    "eval_every": 2,
    "patience": 3,
}
SB3: dict[str, Any] = {"algo": "ppo", "total_timesteps": 100, "hyperparams": {"learning_rate": 3e-4}}


def _load(tmp_path: Path, env_id: str, preset: dict[str, Any]) -> dict[str, Any]:
    path = tmp_path / "preset.yaml"
    path.write_text(yaml.safe_dump(preset))
    return load_preset(env_id, preset["algo"], str(path))


@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
@pytest.mark.parametrize(
    ("env_id", "base", "path", "named"),
    [
        ("gym4real/elevator-v0", TABULAR, ("min_improvement",), "min_improvement"),
        ("gym4real/elevator-v0", TABULAR, ("epsilon", "decay"), "epsilon.decay"),
        ("gym4real/dam-v0", SB3, ("hyperparams", "learning_rate"), "hyperparams.learning_rate"),
        (
            "gym4real/dam-v0",
            SB3,
            ("hyperparams", "replay_buffer_kwargs", "alpha"),
            "hyperparams.replay_buffer_kwargs.alpha",
        ),
        ("gym4real/dam-v0", SB3, ("policy_kwargs", "net_arch"), "policy_kwargs.net_arch"),
    ],
)
def test_a_non_finite_preset_value_is_refused_and_named(
    tmp_path: Path, env_id: str, base: dict[str, Any], path: tuple[str, ...], named: str, value: float
) -> None:
    preset = yaml.safe_load(yaml.safe_dump(base))
    node = preset
    for key in path[:-1]:
        node = node.setdefault(key, {})
    node[path[-1]] = [64, value] if path[-1] == "net_arch" else value
    with pytest.raises(ConfigError, match=named.replace(".", r"\W*") + r".*finite"):
        _load(tmp_path, env_id, preset)


def test_the_finite_presets_still_load(tmp_path: Path) -> None:
    assert _load(tmp_path, "gym4real/elevator-v0", TABULAR)["min_improvement"] == 0.0
    assert _load(tmp_path, "gym4real/dam-v0", SB3)["hyperparams"] == {"learning_rate": 3e-4}
