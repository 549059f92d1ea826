"""The JAX trainer fingerprint's version number is pinned to what the JAX PPO trainer trains.

``gym4real.results.fingerprints.JAX_TRAINER_VERSION`` says which JAX training code a ``-jax`` results
section's models came from, as ``TRAINER_VERSION`` does for SB3 (``tests/test_trainer_version.py``). A
fixed-seed guard run (microgrid, two copies, four iterations of 2 x 64 steps, two epochs of four minibatches,
one evaluation at the end: ``RUN`` of ``scripts/jax_trainer_golden.py``, through ``train(..., trainer="jax")``)
must train the final parameters and observation statistics recorded for that version in
``golden/jax_trainer_v{N}_microgrid.npz``. **When this test fails for an intended change of the training,
raise ``JAX_TRAINER_VERSION`` and record the new golden file** (``python scripts/jax_trainer_golden.py
--record``); a change that moves code without changing what it trains keeps the file, and every section current.

The tolerance is measured, not guessed (``python scripts/jax_trainer_golden.py`` re-measures it). On an Intel
Xeon with AVX-512 (jax/jaxlib 0.10.2, numba 0.68.1, numpy 2.4.6), the guard run was repeated in fresh processes
with each setting that makes this CPU run other code, and its arrays compared with the run's own:

- XLA's code generation limited to older instruction sets (``XLA_FLAGS=--xla_cpu_max_isa=...``): ``AVX512`` 0,
  ``AVX2`` 3.0e-8, ``AVX`` 6.0e-8, ``SSE4_2`` 1.2e-7 (without AVX2 there is no FMA, and XLA's float32 results
  change bit-wise; its matrix products run in a precompiled library that no flag changes);
- numba compiling the rollout and the env for other processors (``NUMBA_CPU_NAME=generic``, ``haswell``,
  ``nehalem``), OpenBLAS on older kernels (``OPENBLAS_CORETYPE=Haswell``, ``Prescott``), NumPy without its
  AVX2/AVX-512 loops (``NPY_DISABLE_CPU_FEATURES``), XLA's YNNPACK kernels, XLA on two threads: 0, bit for
  bit;
- all of the oldest at once: 1.2e-7.

So results are not bit-identical across instruction sets (XLA's are not), and the arrays are compared with
an absolute tolerance of 2e-6: 17 times the largest spread measured (1.2e-7: one float32 step of a value between 1
and 2). A change of the training moves them far more: the learning rate 3e-3 -> 3.03e-3 (1 %) by 3.4e-4, the
clip range 0.2 -> 0.19 by 6.7e-4, ``max_grad_norm`` 0.5 -> 0.45 by 6.7e-4, one more epoch by 1.7e-2, ``gamma``
0.99 -> 0.995 by 2.1e-2: the smallest 170 times the tolerance. (The guard's learning rate is ten times the
paper's so that the clipped surrogate and the gradient clipping act: at 3e-4 no ratio left [0.9, 1.1] and a
clip range of 0.19 or 0.1 changed no bit.) Version 1's file was recorded on that Xeon with the training code
of c03a9e9 (the code this guard was added to).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

pytest.importorskip("jax")

ROOT = Path(__file__).resolve().parents[1]
#: Largest absolute difference allowed between the guard run's arrays and the recorded ones (see above).
JAX_ATOL = 2e-6

STALE = (
    "the JAX trainer's output changed: if the change of training is intended, raise JAX_TRAINER_VERSION (now "
    "{version}) and record the golden file (`python scripts/jax_trainer_golden.py --record`); every published "
    "-jax section then shows as stale"
)


@pytest.fixture(scope="module")
def guard(load_script: Callable[[Path], ModuleType]) -> ModuleType:
    """``scripts/jax_trainer_golden.py``: the guard run, its golden file and the comparison."""
    return load_script(ROOT / "scripts" / "jax_trainer_golden.py")


@pytest.fixture(scope="module")
def recorded(guard: ModuleType) -> dict[str, np.ndarray]:
    from gym4real.results.fingerprints import JAX_TRAINER_VERSION

    with np.load(guard.golden(JAX_TRAINER_VERSION), allow_pickle=False) as archive:
        return {k: archive[k] for k in archive.files}


def test_the_guard_run_trains_the_parameters_and_statistics_of_the_jax_trainer_version(
    guard: ModuleType, recorded: dict[str, np.ndarray], tmp_path: Path
) -> None:
    from gym4real.results.fingerprints import JAX_TRAINER_VERSION

    arrays = guard.guard_run(tmp_path)
    assert {"param/pi/0/w", "param/vf/out/b", "param/log_std", "obs_mean", "obs_var"} <= set(arrays)
    difference = guard.largest_difference(arrays, recorded)
    assert difference <= JAX_ATOL, STALE.format(version=JAX_TRAINER_VERSION) + f" (largest difference {difference:.3g})"


def test_a_change_of_what_the_jax_trainer_trains_moves_its_arrays_beyond_the_tolerance(
    guard: ModuleType, recorded: dict[str, np.ndarray], tmp_path: Path
) -> None:
    """The tolerance that absorbs the CPU's rounding still sees a small change of the training: clip range 0.19."""
    changed = guard.guard_run(tmp_path, clip_range=0.19)
    assert guard.largest_difference(changed, recorded) > 10 * JAX_ATOL
