"""The same episodes whatever kernels the CPU dispatches (issue 47, docs/robofeeder-determinism.md).

numpy's OpenBLAS picks its kernels for the CPU when it loads (``OPENBLAS_CORETYPE`` forces a set: Haswell's
are an AVX2 machine's, an AMD EPYC's; Sandybridge's an AVX machine's), and numpy sends ``exp``, ``arctan2``,
... to AVX-512 code where the CPU has it (``NPY_DISABLE_CPU_FEATURES`` turns that off). Each setting stands
in for another machine: this file, run as a script in a subprocess per setting, plays a short episode of
each RoboFeeder env and prints, after the reset and every step, the hashes of the physics state and the
observation and the exact reward; the outputs must be equal to the bit. Before the products, solves and
norms went through ``portable_math``, the inverse kinematics of the first pick already differed.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

IDS = ["gym4real/robofeeder-picking-v0", "gym4real/robofeeder-picking-v1", "gym4real/robofeeder-planning-v0"]
SEED = 1000
STEPS = 2
#: Dispatch settings that stand in for other machines (the first: this machine's own choice).
SETTINGS: dict[str, dict[str, str]] = {
    "default": {},
    "openblas-haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "openblas-sandybridge-numpy-without-avx512": {
        "OPENBLAS_CORETYPE": "Sandybridge",
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
    },
}


def _digest(array: Any) -> str:
    a = np.ascontiguousarray(array)
    return hashlib.sha256(f"{a.dtype}{a.shape}".encode() + a.tobytes()).hexdigest()[:16]


def _episodes() -> dict[str, list[dict[str, Any]]]:
    """Reset with ``SEED`` and ``STEPS`` steps of each env (seeded actions; planning: crop 1); what each produced."""
    import gymnasium as gym

    import gym4real  # noqa: F401  (registers the ids)

    out: dict[str, list[dict[str, Any]]] = {}
    for env_id in IDS:
        env = gym.make(env_id, preset="test")
        sim = env.unwrapped.sim  # type: ignore[attr-defined]
        obs, _ = env.reset(seed=SEED)
        env.action_space.seed(SEED)
        events: list[dict[str, Any]] = [{"qpos": _digest(sim.data.qpos), "obs": _digest(obs)}]
        for _ in range(STEPS):
            action = 1 if "planning" in env_id else env.action_space.sample()
            obs, reward, terminated, truncated, info = env.step(action)
            components = {k: repr(float(v)) for k, v in sorted(info["reward_components"].items())}
            events.append(
                {"qpos": _digest(sim.data.qpos), "obs": _digest(obs), "reward": repr(reward), "components": components}
            )
            if terminated or truncated:
                break
        env.close()
        out[env_id] = events
    return out


def _run_all() -> dict[str, dict[str, list[dict[str, Any]]]]:
    """The episodes under each setting, in one subprocess per setting (run side by side)."""
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    script = [sys.executable, str(Path(__file__).resolve())]
    pipes: dict[str, Any] = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    running = {name: subprocess.Popen(script, env={**base, **setting}, **pipes) for name, setting in SETTINGS.items()}
    runs = {}
    for name, process in running.items():
        stdout, stderr = process.communicate(timeout=600)
        assert process.returncode == 0, f"the episodes under {SETTINGS[name]} failed:\n{stderr[-3000:]}"
        runs[name] = json.loads(stdout.splitlines()[-1])
    return runs


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="the dispatch settings name x86-64 kernels")
def test_episodes_do_not_depend_on_the_dispatched_kernels() -> None:
    runs = _run_all()
    reference = runs["default"]
    assert all(len(events) > 1 for events in reference.values())
    for name, run in runs.items():
        for env_id in IDS:
            for step, (a, b) in enumerate(zip(reference[env_id], run[env_id], strict=True)):
                assert a == b, f"{env_id}, event {step}: default {a} != {name} {b}"


if __name__ == "__main__":
    print(json.dumps(_episodes()))
