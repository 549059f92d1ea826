"""The JAX trainer's guard run: record its golden file, and measure how far CPUs and changes of training move it.

``tests/test_jax_trainer_version.py`` pins :data:`gym4real.results.fingerprints.JAX_TRAINER_VERSION` to what
the JAX PPO trainer (:mod:`gym4real.rl.jax_ppo`) trains: a short fixed-seed run (:data:`RUN`) must train the
parameters and observation statistics recorded in ``tests/golden/jax_trainer_v{N}_microgrid.npz``.

- ``python scripts/jax_trainer_golden.py --record`` trains the run here and writes the golden file of the
  installed ``JAX_TRAINER_VERSION``.
- ``python scripts/jax_trainer_golden.py`` (no option) measures: the run in a fresh process once as this CPU
  runs it, then under each of :data:`VARIANTS` (XLA's code generation limited to older instruction sets, XLA
  on two threads, numba compiling for a generic or older processor, OpenBLAS and NumPy on older kernels,
  XLA's YNNPACK kernels), and prints the largest absolute difference of each from the first (the CPU spread)
  and of each change of the training in :data:`CHANGES` (what the guard must see), and each run's difference
  from the golden file. ``--variants NAME ...`` and ``--changes NAME ...`` measure a subset.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
GOLDEN_DIR = ROOT / "tests" / "golden"
ENV_ID = "gym4real/microgrid-v0"
SEED = 7
#: The guard run: microgrid's smoke settings made smaller (two copies, four iterations of 2 x 64 steps, two
#: epochs of four minibatches), one evaluation at the end, so that the model file holds the final policy. The
#: learning rate is ten times the paper's so that the clipped surrogate and the gradient clipping act (at
#: 3e-4 neither a clip range of 0.19 nor of 0.1 changed a bit of the run: no ratio left [0.9, 1.1]).
RUN: dict[str, Any] = {
    "algo": "ppo",
    "total_timesteps": 512,
    "n_envs": 2,
    "normalize_obs": True,
    "normalize_reward": False,
    "clip_obs": 10.0,
    "policy": "MlpPolicy",
    "policy_kwargs": {"net_arch": [16, 16], "log_std_init": -1.0},
    "hyperparams": {
        "learning_rate": {"schedule": "cosine", "initial": 3.0e-3, "final": 0.0},
        "n_steps": 64,
        "batch_size": 32,
        "n_epochs": 2,
        "gamma": 0.99,
        "gae_lambda": 0.95,
        "clip_range": 0.2,
    },
    "env_kwargs": {"preset": "default"},
    "eval_env_kwargs": {"preset": "test", "max_steps": 24},
    "eval_freq": 512,
    "eval_episodes": 2,
}
#: Changes of the training the guard must see (hyperparameter overrides).
CHANGES: dict[str, dict[str, Any]] = {
    "gamma 0.99 -> 0.995": {"gamma": 0.995},
    "n_epochs 2 -> 3": {"n_epochs": 3},
    "clip_range 0.2 -> 0.19": {"clip_range": 0.19},
    "max_grad_norm 0.5 -> 0.45": {"max_grad_norm": 0.45},
    "learning rate 3e-3 -> 3.03e-3": {"learning_rate": {"schedule": "cosine", "initial": 3.03e-3, "final": 0.0}},
}
#: Environment settings that make this CPU run other code paths, each applied to a fresh process.
VARIANTS: dict[str, dict[str, str]] = {
    "XLA max ISA AVX512": {"XLA_FLAGS": "--xla_cpu_max_isa=AVX512"},
    "XLA max ISA AVX2": {"XLA_FLAGS": "--xla_cpu_max_isa=AVX2"},
    "XLA max ISA AVX": {"XLA_FLAGS": "--xla_cpu_max_isa=AVX"},
    "XLA max ISA SSE4_2": {"XLA_FLAGS": "--xla_cpu_max_isa=SSE4_2"},
    "XLA on two threads": {"XLA_FLAGS": "--xla_cpu_multi_thread_eigen=true intra_op_parallelism_threads=2"},
    "numba generic CPU": {"NUMBA_CPU_NAME": "generic"},
    "numba haswell (AVX2)": {"NUMBA_CPU_NAME": "haswell"},
    "numba nehalem (SSE4.2)": {"NUMBA_CPU_NAME": "nehalem"},
    "OpenBLAS Haswell kernels": {"OPENBLAS_CORETYPE": "Haswell"},
    "OpenBLAS Prescott kernels": {"OPENBLAS_CORETYPE": "Prescott"},
    "NumPy without AVX2/AVX-512": {"NPY_DISABLE_CPU_FEATURES": "AVX2 FMA3 AVX512F AVX512CD AVX512_SKX AVX512_ICL"},
    "XLA through YNNPACK (other kernels)": {"XLA_FLAGS": "--xla_cpu_experimental_ynn_fusion_type=dot,reduce,eltwise"},
    "all at SSE4.2/generic": {
        "XLA_FLAGS": "--xla_cpu_max_isa=SSE4_2",
        "NUMBA_CPU_NAME": "generic",
        "OPENBLAS_CORETYPE": "Prescott",
        "NPY_DISABLE_CPU_FEATURES": "AVX2 FMA3 AVX512F AVX512CD AVX512_SKX AVX512_ICL",
    },
}


def golden(version: int) -> Path:
    """The golden file of a ``JAX_TRAINER_VERSION``."""
    return GOLDEN_DIR / f"jax_trainer_v{version}_microgrid.npz"


def guard_run(folder: Path, **hyperparams: Any) -> dict[str, np.ndarray]:
    """Train :data:`RUN` (``hyperparams`` override its) in ``folder``; its model's parameters and statistics.

    The run goes through ``train`` as ``gym4real train --trainer jax`` does, its evaluation in-line.
    """
    from gym4real.rl.train import train

    settings = {**RUN, "hyperparams": {**RUN["hyperparams"], **hyperparams}}
    preset = folder / "guard.yaml"
    preset.write_text(yaml.safe_dump(settings))
    run = train(ENV_ID, "ppo", str(preset), SEED, folder / "run", trainer="jax", eval_beside=False)
    with np.load(run.model_path, allow_pickle=False) as model:
        return {k: model[k] for k in model.files if k.startswith("param/") or k in ("obs_mean", "obs_var")}


def largest_difference(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """Largest absolute difference between two runs' arrays (which must have the same names)."""
    assert sorted(a) == sorted(b), f"the model's arrays changed: {sorted(a)} != {sorted(b)}"
    return max(float(np.max(np.abs(a[k].astype(np.float64) - b[k].astype(np.float64)))) for k in a)


def _in_process(env: dict[str, str], out: Path, hyperparams: dict[str, Any]) -> dict[str, np.ndarray]:
    """:func:`guard_run` in a fresh process with ``env`` added (jax, numba and numpy read them at start)."""
    code = (
        "import json, sys, numpy as np; from pathlib import Path;"
        f"sys.path.insert(0, {str(Path(__file__).parent)!r}); import jax_trainer_golden as g;"
        "a = g.guard_run(Path(sys.argv[1]), **json.loads(sys.argv[2]));"
        "np.savez(Path(sys.argv[1]) / 'arrays.npz', **a)"
    )
    full = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"} | env
    out.mkdir(parents=True)
    subprocess.run([sys.executable, "-c", code, str(out), json.dumps(hyperparams)], check=True, env=full)
    with np.load(out / "arrays.npz") as arrays:
        return {k: arrays[k] for k in arrays.files}


def measure(variants: Sequence[str], changes: Sequence[str]) -> None:
    """Print each variant's and each change's largest difference from this CPU's run (and from the golden file)."""
    from gym4real.results.fingerprints import JAX_TRAINER_VERSION

    path = golden(JAX_TRAINER_VERSION)
    recorded = dict(np.load(path)) if path.exists() else None
    with tempfile.TemporaryDirectory() as tmp:
        base = _in_process({}, Path(tmp) / "base", {})
        rows: list[tuple[str, dict[str, str], dict[str, Any]]] = [("this CPU (again)", {}, {})]
        rows += [(v, VARIANTS[v], {}) for v in variants] + [(c, {}, CHANGES[c]) for c in changes]
        if recorded is not None:
            print(f"{'this CPU':40s} golden {largest_difference(base, recorded):.3g}")
        spread = 0.0
        for i, (name, env, hyperparams) in enumerate(rows):
            arrays = _in_process(env, Path(tmp) / str(i), hyperparams)
            difference = largest_difference(arrays, base)
            if not hyperparams:
                spread = max(spread, difference)
            versus = f" golden {largest_difference(arrays, recorded):.3g}" if recorded is not None else ""
            print(f"{name:40s} {difference:.3g}{versus}", flush=True)
        print(f"CPU spread (largest over the variants): {spread:.3g}")


def main(argv: Sequence[str] | None = None) -> int:
    """Record the golden file (``--record``) or measure the spread and the changes (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", action="store_true", help="write the golden file of this checkout's training")
    parser.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS), metavar="NAME")
    parser.add_argument("--changes", nargs="*", default=list(CHANGES), choices=list(CHANGES), metavar="NAME")
    args = parser.parse_args(argv)
    if args.record:
        from gym4real.results.fingerprints import JAX_TRAINER_VERSION

        with tempfile.TemporaryDirectory() as tmp:
            arrays = guard_run(Path(tmp))
        np.savez(golden(JAX_TRAINER_VERSION), allow_pickle=False, **arrays)
        print("recorded in", golden(JAX_TRAINER_VERSION))
        return 0
    measure(args.variants, args.changes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
