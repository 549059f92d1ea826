"""The same episodes whatever kernels the CPU dispatches (issue 47, docs/robofeeder-determinism.md).

numpy's OpenBLAS picks its kernels for the CPU when it loads (``OPENBLAS_CORETYPE`` forces a set: Haswell's
are an AVX2 machine's, an AMD EPYC's; Sandybridge's an AVX machine's), and numpy sends ``exp``, ``arctan2``,
... to AVX-512 code where the CPU has it (``NPY_DISABLE_CPU_FEATURES`` turns that off). Each setting stands
in for another machine: this file, run as a script in a subprocess per setting, plays a short episode of
each RoboFeeder env and prints, after the reset and every step, the hashes of the physics state and the
observation and the exact reward; the outputs must be equal to the bit. Before the products, solves and
norms went through ``portable_math``, the inverse kinematics of the first pick already differed.

PyTorch picks its kernels too (``ATEN_CPU_CAPABILITY``, MKL's ``MKL_ENABLE_INSTRUCTIONS``, oneDNN's
``ONEDNN_MAX_CPU_ISA``): a PPO model file of picking-v0 and of planning-v0, loaded as the protocol scores
it, plays the same episodes. Before the robofeeder protocols declared ``portable_forward``, its actions
came from torch's kernels and the first pick already differed under AVX2-only dispatch.
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
    "haswell": {
        "OPENBLAS_CORETYPE": "Haswell",
        "ATEN_CPU_CAPABILITY": "avx2",
        "MKL_ENABLE_INSTRUCTIONS": "AVX2",
        "ONEDNN_MAX_CPU_ISA": "AVX2",
    },
    "sandybridge-numpy-without-avx512": {
        "OPENBLAS_CORETYPE": "Sandybridge",
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
        "ATEN_CPU_CAPABILITY": "default",
        "MKL_ENABLE_INSTRUCTIONS": "SSE4_2",
        "ONEDNN_MAX_CPU_ISA": "SSE41",
    },
}
#: The variables of the settings, taken out of the environment the subprocesses inherit.
DISPATCH = {key for setting in SETTINGS.values() for key in setting}
#: The envs a PPO model file plays, and the variable naming the model files' folder (the subprocesses').
AGENT_IDS = ["gym4real/robofeeder-picking-v0", "gym4real/robofeeder-planning-v0"]
MODELS = "GYM4REAL_TEST_MODELS"


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
    if os.environ.get(MODELS):
        out.update(_agent_episodes(Path(os.environ[MODELS])))
    return out


def _model_path(folder: Path, env_id: str) -> Path:
    return folder / f"{env_id.split('/')[1]}.zip"


def _write_models(folder: Path) -> None:
    """A seeded, untrained PPO of each of :data:`AGENT_IDS` with its paper policy (CnnPolicy), as a model file."""
    import gymnasium as gym
    from stable_baselines3 import PPO

    import gym4real  # noqa: F401  (registers the ids)

    for env_id in AGENT_IDS:
        env = gym.make(env_id, preset="test")
        kwargs = {"net_arch": [64, 32], "normalize_images": False}
        PPO("CnnPolicy", env, policy_kwargs=kwargs, seed=SEED, device="cpu").save(_model_path(folder, env_id))
        env.close()


def _agent_episodes(folder: Path) -> dict[str, list[dict[str, Any]]]:
    """``STEPS`` steps of each model of :func:`_write_models`, loaded as ``gym4real evaluate`` loads ``ppo:PATH``."""
    import gymnasium as gym

    from gym4real.rl.sb3 import load_model

    out: dict[str, list[dict[str, Any]]] = {}
    for env_id in AGENT_IDS:
        env = gym.make(env_id, preset="test")
        policy = load_model(env, _model_path(folder, env_id), "ppo")
        sim = env.unwrapped.sim  # type: ignore[attr-defined]
        obs, _ = env.reset(seed=SEED)
        events: list[dict[str, Any]] = []
        for _ in range(STEPS):
            action = policy(obs)
            obs, reward, terminated, truncated, _ = env.step(action)
            events.append({"action": _digest(action), "qpos": _digest(sim.data.qpos), "reward": repr(reward)})
            if terminated or truncated:
                break
        env.close()
        out[f"ppo:{env_id}"] = events
    return out


def _run_all(models: Path | None) -> dict[str, dict[str, list[dict[str, Any]]]]:
    """The episodes under each setting, in one subprocess per setting (run side by side); agents' with ``models``."""
    base = {k: v for k, v in os.environ.items() if k not in DISPATCH}
    if models is not None:
        base[MODELS] = str(models)
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
def test_episodes_do_not_depend_on_the_dispatched_kernels(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    _write_models(tmp_path)
    runs = _run_all(tmp_path)
    reference = runs["default"]
    assert set(reference) == {*IDS, *(f"ppo:{env_id}" for env_id in AGENT_IDS)}
    assert all(len(events) > 1 for events in reference.values())
    for name, run in runs.items():
        for key, events in reference.items():
            for step, (a, b) in enumerate(zip(events, run[key], strict=True)):
                assert a == b, f"{key}, event {step}: default {a} != {name} {b}"


if __name__ == "__main__":
    print(json.dumps(_episodes()))
