"""Every installed plugin loads; registration is cheap; ids work in a fresh process."""

from __future__ import annotations

import json
import subprocess
import sys
from importlib import metadata as importlib_metadata

import gym4real
from gym4real.core.registry import CANONICAL_IDS, ENTRY_POINT_GROUP, registry

HEAVY = ["mujoco", "epanet", "torch", "pandas", "cv2", "onnxruntime", "stable_baselines3", "matplotlib"]


def test_every_entry_point_loads_and_registers() -> None:
    eps = {ep.name: ep for ep in importlib_metadata.entry_points(group=ENTRY_POINT_GROUP)}
    assert "elevator" in eps
    assert gym4real.plugin_errors() == []
    reg = registry()
    for name in eps:
        owned = [i for i, p in reg.owners.items() if p == name and i.startswith("gym4real/")]
        assert owned, f"plugin {name} registers no environment"
    assert set(gym4real.list_envs()) <= set(reg.envs)
    assert gym4real.list_envs() == sorted(gym4real.list_envs())


def test_installed_ids_are_canonical_and_have_protocols_and_baselines() -> None:
    reg = registry()
    for env_id in gym4real.list_envs():
        if env_id in CANONICAL_IDS:
            assert env_id in reg.benchmarks, env_id
            assert "random" in reg.baselines.get(env_id, {}) or reg.baselines.get(env_id), env_id
        for name in reg.baselines.get(env_id, {}):
            assert name == name.lower()


def test_env_info_reports_table_one_flags() -> None:
    info = gym4real.env_info("gym4real/elevator-v0")
    assert info.distribution == "gym4real-elevator"
    assert info.version == importlib_metadata.version("gym4real-elevator")
    assert info.flags["provably_efficient"] and info.flags["partially_controllable"]
    assert not info.flags["continuous_states"]
    assert {"longest_first", "shortest_first", "random"} <= set(info.baselines)
    assert len(info.flags) == 12


def test_import_is_cheap_and_make_works_in_a_fresh_process() -> None:
    code = f"""
import json, sys, gymnasium as gym
import gym4real
heavy = [m for m in {HEAVY!r} if m in sys.modules]
env = gym.make("gym4real:gym4real/elevator-v0")
obs, _ = env.reset(seed=0)
print(json.dumps({{"heavy": heavy, "ids": gym4real.list_envs()}}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    data = json.loads(out.stdout.strip().splitlines()[-1])
    assert data["heavy"] == []
    assert "gym4real/elevator-v0" in data["ids"]


def test_gymnasium_module_prefix_form_works_without_prior_import() -> None:
    code = 'import gymnasium as gym; e = gym.make("gym4real:gym4real/elevator-v0"); e.reset(seed=1); print("ok")'
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().endswith("ok")
