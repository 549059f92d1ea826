"""The trainer fingerprint's version number is pinned to what the training code trains.

``gym4real.results.fingerprints.TRAINER_VERSION`` says which training code a results section's models came
from, so that a section trained by an older commit stays *current* while the training code's output is
unchanged. Two fixed-seed smoke runs (PPO through Stable-Baselines3 on dam, tabular Q-learning on elevator;
their settings are written here, not taken from the registered presets) must train exactly the weights whose
hashes are recorded for that version: a change of the training code's output fails this test until
``TRAINER_VERSION`` is raised and the new hashes recorded (``python tests/test_trainer_version.py`` prints
them). A change that moves code without changing what it trains keeps the hashes, and every section current.

The hashes are of the trained parameters rounded to 6 decimals (float32 weights, CPU, one thread).
Version 1 gives the same hashes at e4bd47b (the commit that trained the published sections; checked with
e4bd47b's packages first on ``PYTHONPATH``, SB3 2.9.2, PyTorch 2.13.0+cpu) as at the commit that introduced
this test.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

#: TRAINER_VERSION -> algo -> SHA-256 of the smoke run's rounded parameters.
GOLDEN = {
    1: {
        "ppo": "3a1a23e535caf990aeb7f1ac2a8683c7ed61a0c59e5e0b73f63e37f5715f1ce6",
        "qlearning": "f17fc4783fc1312c9e0797b412c1a106998b6d36bbd743f0d9e909db718178de",
    },
}
#: The smoke runs: env, seed and settings (the registered smoke presets of dam and elevator at e4bd47b).
RUNS = {
    "ppo": (
        "gym4real/dam-v0",
        7,
        {
            "algo": "ppo",
            "total_timesteps": 2048,
            "n_envs": 1,
            "normalize_obs": True,
            "normalize_reward": False,
            "clip_obs": 5.0,
            "value_scaler": True,
            "policy": "MlpPolicy",
            "policy_kwargs": {"net_arch": [16, 16], "log_std_init": -0.5},
            "hyperparams": {
                "learning_rate": {"schedule": "kl_adaptive", "initial": 8.0e-6, "kl_threshold": 0.008},
                "n_steps": 1024,
                "batch_size": 32,
                "n_epochs": 2,
                "gamma": 0.995,
                "gae_lambda": 0.95,
            },
            "env_kwargs": {"preset": "train", "years": [1959, 1997, 2008, 2004, 1962, 1983]},
            "eval_env_kwargs": {"preset": "validation", "sim_horizon": 60},
            "eval_freq": 1024,
            "eval_episodes": 2,
        },
    ),
    "qlearning": (
        "gym4real/elevator-v0",
        7,
        {
            "algo": "qlearning",
            "episodes": 6,
            "alpha": 0.1,
            "gamma": 1.0,
            "epsilon": {"start": 1.0, "decay": 0.9, "min": 0.05},
            "eval_every": 3,
            "eval_episodes": 2,
            "patience": 10,
            "min_improvement": 0.1,
            "eval_seed": 10000,
            "env_kwargs": {"duration": 600},
            "eval_env_kwargs": {"duration": 600},
        },
    ),
}


def parameters_sha256(model: Path) -> str:
    """SHA-256 of a trained model's parameters rounded to 6 decimals (name order; a Q-table's ``q``)."""
    digest = hashlib.sha256()
    if model.suffix == ".npz":
        with np.load(model, allow_pickle=False) as archive:
            arrays = [("q", archive["q"])]
    else:
        from stable_baselines3.common.save_util import load_from_zip_file

        _, params, _ = load_from_zip_file(model, device="cpu")
        state: dict[str, Any] = dict(params["policy"])  # the policy's state dict: name -> tensor
        arrays = [(name, tensor.numpy()) for name, tensor in sorted(state.items())]
    for name, array in arrays:
        digest.update(name.encode())
        digest.update(np.round(np.asarray(array, dtype=np.float64), 6).tobytes())
    return digest.hexdigest()


def smoke_run(algo: str, folder: Path) -> str:
    """Train the smoke run of ``algo`` in ``folder``; the hash of its parameters."""
    from gym4real.rl.train import train

    env_id, seed, settings = RUNS[algo]
    preset = folder / f"{algo}.yaml"
    preset.write_text(yaml.safe_dump(settings))
    run = train(env_id, algo, str(preset), seed, folder / "run")
    return parameters_sha256(run.model_path)


@pytest.mark.parametrize("algo", sorted(RUNS))
def test_the_smoke_run_trains_the_weights_of_the_trainer_version(algo: str, tmp_path: Path) -> None:
    from gym4real.results.fingerprints import TRAINER_VERSION

    if algo == "ppo":
        pytest.importorskip("stable_baselines3")
    assert smoke_run(algo, tmp_path) == GOLDEN[TRAINER_VERSION][algo], (
        f"the training code's output changed: raise TRAINER_VERSION (now {TRAINER_VERSION}) and record the new "
        "hashes (`python tests/test_trainer_version.py`); every published section then shows as stale"
    )


if __name__ == "__main__":  # print the hashes of this checkout's training code
    import tempfile

    for name in sys.argv[1:] or sorted(RUNS):
        with tempfile.TemporaryDirectory() as tmp:
            print(name, smoke_run(name, Path(tmp)))
