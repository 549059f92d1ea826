"""The same test episode whatever BLAS kernels the CPU gets (``OPENBLAS_CORETYPE`` stands in for another CPU).

Run as a script in a subprocess per setting, this file plays the protocol's first test episode with the
``default`` baseline and prints every reward and component exactly; the outputs must be equal. Before the
junctions' demands were summed with ``math.fsum`` (a BLAS dot product before), the DSR of that episode
differed in its last bit under the kernels of an AVX2 CPU (``Haswell``): its objective was 166.42189203393067
against the published 166.4218920339307.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ENV_ID = "gym4real/wds-v0"
SETTINGS = {"default": {}, "haswell": {"OPENBLAS_CORETYPE": "Haswell"}}


def _episode() -> list[dict[str, Any]]:
    """The protocol's first test episode under ``default``: each step's reward and components, exactly."""
    import gymnasium as gym

    import gym4real  # noqa: F401  (registers the ids)
    from gym4real.bench.benchmark import protocol
    from gym4real.bench.policies import make_policy
    from gym4real.core.registry import load_object

    spec = protocol(ENV_ID)
    first = load_object(spec.protocol)(dict(spec.env_kwargs))[0]
    env = gym.make(ENV_ID, **spec.env_kwargs)
    policy = make_policy(ENV_ID, "default", env)
    obs, _ = env.reset(seed=first["seed"], options=first["options"])
    steps, done = [], False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        components = {k: repr(float(v)) for k, v in sorted(info["reward_components"].items())}
        steps.append({"reward": repr(float(reward)), "components": components})
        done = terminated or truncated
    env.close()
    return steps


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="the setting names x86-64 kernels")
def test_a_test_episode_does_not_depend_on_the_blas_kernels() -> None:
    base = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    script = [sys.executable, str(Path(__file__).resolve())]
    runs = {}
    for name, setting in SETTINGS.items():
        done = subprocess.run(script, env={**base, **setting}, capture_output=True, text=True, timeout=600, check=False)
        assert done.returncode == 0, f"the episode under {setting} failed:\n{done.stderr[-3000:]}"
        runs[name] = json.loads(done.stdout.splitlines()[-1])
    assert len(runs["default"]) > 100
    for step, (a, b) in enumerate(zip(runs["default"], runs["haswell"], strict=True)):
        assert a == b, f"step {step}: default {a} != Haswell's kernels {b}"


if __name__ == "__main__":
    print(json.dumps(_episode()))
