"""The trainer fingerprint's version number is pinned to what the training code trains.

``gym4real.results.fingerprints.TRAINER_VERSION`` says which training code a results section's models came
from, so that a section trained by an older commit stays *current* while the training code's output is
unchanged. Two fixed-seed smoke runs (PPO through Stable-Baselines3 on dam, tabular Q-learning on elevator;
their settings are written here, not taken from the registered presets) must train exactly the weights whose
hashes are recorded for that version: a change of the training code's output fails this test until
``TRAINER_VERSION`` is raised and the new hashes recorded (``python tests/test_trainer_version.py`` prints
them). A change that moves code without changing what it trains keeps the hashes, and every section current.

Q-learning's table is pure NumPy arithmetic and the same on every CPU: its hash is of the table rounded to 6
decimals. PPO's weights are not: PyTorch's MKL picks its matrix kernels by processor, and the float32 sums
round differently. Measured on one Intel Xeon with AVX-512 by forcing MKL's paths (``MKL_CBWR=AVX2``,
``COMPATIBLE``, default AVX-512): the smoke run's parameters differ by at most 1.2e-7 between paths, and a
6-decimal hash of them changed with the machine (version 1's hash 3a1a23e5... came from CI's earlier machine,
4d039a26... from this Xeon, for the same code). A change of what the code trains moves them far more: one
more epoch by 5.4e-4, ``gamma`` 0.995 -> 0.99 by 4.4e-5. So PPO's recorded parameters
(``golden/trainer_v{N}_ppo.npz``, written by ``python tests/test_trainer_version.py --record ppo``) are
compared with an absolute tolerance of 2e-6: 17 times the measured CPU spread, 22 times below the smallest
change measured. Version 1's file was recorded at 4ea5252 on the Xeon; c4f5a59 (the commit whose CI passed
with the hash) trains the same parameters there bit for bit.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

#: TRAINER_VERSION -> SHA-256 of the Q-learning smoke run's rounded table.
QLEARNING_SHA256 = {1: "f17fc4783fc1312c9e0797b412c1a106998b6d36bbd743f0d9e909db718178de"}
#: Largest absolute difference allowed between PPO's trained parameters and the recorded ones (see above).
PPO_ATOL = 2e-6
GOLDEN_DIR = Path(__file__).parent / "golden"
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


def ppo_golden(version: int) -> Path:
    """The recorded PPO smoke-run parameters of a trainer version."""
    return GOLDEN_DIR / f"trainer_v{version}_ppo.npz"


def load_parameters(model: Path) -> dict[str, np.ndarray]:
    """A trained model's parameters by name: a Q-table's ``q``, an SB3 policy's state dict."""
    if model.suffix == ".npz":
        with np.load(model, allow_pickle=False) as archive:
            return {"q": archive["q"]}
    from stable_baselines3.common.save_util import load_from_zip_file

    _, params, _ = load_from_zip_file(model, device="cpu")
    state: dict[str, Any] = dict(params["policy"])  # the policy's state dict: name -> tensor
    return {name: tensor.numpy() for name, tensor in state.items()}


def parameters_sha256(parameters: dict[str, np.ndarray]) -> str:
    """SHA-256 of parameters rounded to 6 decimals, in name order."""
    digest = hashlib.sha256()
    for name, array in sorted(parameters.items()):
        digest.update(name.encode())
        digest.update(np.round(np.asarray(array, dtype=np.float64), 6).tobytes())
    return digest.hexdigest()


def smoke_run(algo: str, folder: Path, **hyperparams: Any) -> dict[str, np.ndarray]:
    """Train the smoke run of ``algo`` in ``folder`` (``hyperparams`` override the run's); its parameters."""
    from gym4real.rl.train import train

    env_id, seed, settings = RUNS[algo]
    if hyperparams:
        base: dict[str, Any] = settings["hyperparams"]  # type: ignore[assignment]  # a run's hyperparams are a mapping
        settings = {**settings, "hyperparams": {**base, **hyperparams}}
    preset = folder / f"{algo}.yaml"
    preset.write_text(yaml.safe_dump(settings))
    run = train(env_id, algo, str(preset), seed, folder / "run")
    return load_parameters(run.model_path)


def largest_difference(parameters: dict[str, np.ndarray], golden: Path) -> float:
    """Largest absolute difference between ``parameters`` and a recorded file's (which must hold the same names)."""
    with np.load(golden, allow_pickle=False) as recorded:
        assert sorted(recorded.files) == sorted(parameters), "the policy's parameter names changed"
        return max(float(np.max(np.abs(parameters[name] - recorded[name]))) for name in recorded.files)


STALE = (
    "the training code's output changed: raise TRAINER_VERSION (now {version}) and record the new values "
    "(`python tests/test_trainer_version.py --record ppo qlearning`); every published section then shows as stale"
)


def test_the_qlearning_smoke_run_trains_the_table_of_the_trainer_version(tmp_path: Path) -> None:
    from gym4real.results.fingerprints import TRAINER_VERSION

    table = smoke_run("qlearning", tmp_path)
    assert parameters_sha256(table) == QLEARNING_SHA256[TRAINER_VERSION], STALE.format(version=TRAINER_VERSION)


@pytest.fixture(scope="module")
def ppo_parameters(tmp_path_factory: pytest.TempPathFactory) -> dict[str, np.ndarray]:
    pytest.importorskip("stable_baselines3")
    return smoke_run("ppo", tmp_path_factory.mktemp("ppo"))


def test_the_ppo_smoke_run_trains_the_weights_of_the_trainer_version(ppo_parameters: dict[str, np.ndarray]) -> None:
    from gym4real.results.fingerprints import TRAINER_VERSION

    difference = largest_difference(ppo_parameters, ppo_golden(TRAINER_VERSION))
    assert difference <= PPO_ATOL, STALE.format(version=TRAINER_VERSION) + f" (largest difference {difference:.3g})"


def test_a_change_of_what_ppo_trains_moves_its_weights_beyond_the_tolerance(
    ppo_parameters: dict[str, np.ndarray], tmp_path: Path
) -> None:
    """The tolerance that absorbs the CPU's rounding still sees a small change of the training: gamma 0.995 -> 0.99."""
    from gym4real.results.fingerprints import TRAINER_VERSION

    changed = smoke_run("ppo", tmp_path, gamma=0.99)
    assert largest_difference(changed, ppo_golden(TRAINER_VERSION)) > 10 * PPO_ATOL


if __name__ == "__main__":  # print (or with --record, write) the values of this checkout's training code
    import tempfile

    from gym4real.results.fingerprints import TRAINER_VERSION

    record = "--record" in sys.argv[1:]
    for name in [arg for arg in sys.argv[1:] if arg != "--record"] or sorted(RUNS):
        with tempfile.TemporaryDirectory() as tmp:
            parameters = smoke_run(name, Path(tmp))
        if name == "ppo" and record:
            np.savez(ppo_golden(TRAINER_VERSION), allow_pickle=False, **parameters)
            print(name, "recorded in", ppo_golden(TRAINER_VERSION))
        else:
            print(name, parameters_sha256(parameters))
