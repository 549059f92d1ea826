"""Measure microgrid-mo-v0's constant-fraction sweep on the 28 test episodes with the batched env.

``python scripts/measure_microgrid_sweep.py OUT.csv`` runs each fraction of the sweep
(:data:`gym4real.microgrid.multi_objective.CONSTANT_FRACTION`) on the 28 test households at once in
:class:`~gym4real.microgrid.vector.MicrogridVectorEnv` (with numba, bit for bit the single env's numbers;
a single-env episode takes about a minute, the 28 copies together about 15 s per fraction once compiled):
copy ``i`` reset with seed 0 is test episode ``i`` (profile ``370 + i``, seed ``i``), which the script
checks. The CSV is the ``--measured`` input of ``scripts/export_mo_references.py``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

import numpy as np
import pandas as pd

from gym4real.bench.mo_reference import test_plan
from gym4real.core.mo_spec import mo_spec
from gym4real.microgrid.multi_objective import CONSTANT_FRACTION
from gym4real.microgrid.vector import MicrogridVectorEnv

ENV_ID = "gym4real/microgrid-mo-v0"


def measure(fraction: float) -> np.ndarray:
    """Per test episode, the sums of the reward components of the constant fraction, ``(episodes, components)``."""
    plan, kwargs = test_plan(ENV_ID)
    env = MicrogridVectorEnv(len(plan), **kwargs)
    _, info = env.reset(seed=plan[0]["seed"])
    expected = [str(e["options"]["profile"]) for e in plan]
    if [str(p) for p in info["profile"]] != expected or [e["seed"] for e in plan] != list(range(len(plan))):
        raise RuntimeError(f"the batched copies' households {list(info['profile'])} are not the test episodes'")
    names = env.single.reward_component_names
    sums = np.zeros((len(plan), len(names)))
    done = np.zeros(len(plan), dtype=bool)
    action = np.full((len(plan), 1), fraction, dtype=np.float32)
    while not done.all():
        _, _, terminated, truncated, info = env.step(action)
        live = ~done
        for k, name in enumerate(names):
            sums[live, k] += np.asarray(info["reward_components"][name])[live]
        done |= terminated | truncated
    env.close()
    return sums


def main(argv: Sequence[str] | None = None) -> int:
    """Write the sweep's per-episode objectives to the CSV named by the first argument."""
    args = list(argv if argv is not None else sys.argv[1:])
    if len(args) != 1:
        print("usage: measure_microgrid_sweep.py OUT.csv", file=sys.stderr)
        return 2
    spec = mo_spec(ENV_ID)
    names = MicrogridVectorEnv(1, preset="test").single.reward_component_names
    rows = []
    for policy in CONSTANT_FRACTION.policies:
        sums = measure(float(policy.params["fraction"]))
        for episode, row in enumerate(sums):
            values = spec.values(dict(zip(names, row, strict=True)))
            rows.append(
                {"env_id": ENV_ID, "policy": f"{CONSTANT_FRACTION.name}:{policy.label}", "episode": episode}
                | dict(zip(spec.names, values, strict=True))
            )
        print(f"measured {CONSTANT_FRACTION.name}:{policy.label}", flush=True)
    pd.DataFrame(rows).to_csv(args[0], index=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
