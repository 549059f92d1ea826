"""Choose the microgrid MPC's forecasts, horizon and cadence on training data, never on the test protocol.

``python scripts/measure_microgrid_mpc.py OUT.csv [HOUSEHOLDS [POLICIES]]`` runs, on validation episodes,
:class:`gym4real.microgrid.mpc.MicrogridMPC` at the search's starting point (:data:`START`), each
variant of it (one setting changed), the shipped settings (``mpc``), the controller with the perfect
forecast (the episode's own series: what forecasting costs), the rule-based ``only_market`` and
``battery_first`` and the non-causal ``hindsight``; ``POLICIES`` (comma-separated names) runs only
those. The validation episodes are the first ``HOUSEHOLDS`` (default 4) stand-in training households
(``gym4real data synthesize microgrid``; the real training file where present) on the training years 2016
and 2018 (PV, prices and temperatures of the ``train`` preset), each a year of 8,759 hours from its first,
scored as the test protocol scores (trading plus degradation in EUR). The CSV has one row per policy and
episode (objective, CPU seconds); the summary printed per policy is the IQM and the mean over the
episodes, and the CPU time per episode.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench.benchmark import run_episode
from gym4real.bench.stats import iqm
from gym4real.microgrid import MicrogridEnv
from gym4real.microgrid.hindsight import MicrogridHindsight, _episode_data
from gym4real.microgrid.mpc import DAY, WEEK, MicrogridMPC, Profile

OBJECTIVE = ("trading", "degradation")
#: First data row of each validation year in the training series (2015-01-01 00:00 is row 0).
YEARS = {2016: 8760, 2018: 26304}
HOURS = 8759
#: The protocol's scoring (the ``test`` preset's reward) on the training data.
ENV: dict[str, Any] = {
    "preset": "train",
    "max_steps": HOURS,
    "profile_order": "sequential",
    "reward": {"trading": 1.0, "degradation": 1.0, "clipping": 0.0, "normalize": False},
}


class PerfectForecast(MicrogridMPC):
    """The controller handed the episode's own series as its forecast (non-causal: the cost of forecasting)."""

    def forecast(self, k: int, n: int) -> dict[str, np.ndarray]:
        """The episode's true net power and prices of hours ``k .. k + n - 1``."""
        return {key: value[:n] for key, value in _episode_data(self.env).items()}


#: The search's starting point: demand by the hour of the past four weeks, PV of the past three days, prices
#: of yesterday, 48-hour plans every 24 hours.
START: dict[str, Any] = {
    "demand": Profile(WEEK, 4),
    "generation": Profile(DAY, 3),
    "prices": Profile(DAY, 1),
    "horizon": 48,
    "cadence": 24,
}


def _variants() -> dict[str, Callable[[Any], Any]]:
    """Each policy measured, by name: the starting point, one change at a time, the shipped MPC, the references."""
    changes: dict[str, dict[str, Any]] = {
        "start": {},
        "demand_persistence": {"demand": Profile(1, 1)},
        "demand_yesterday": {"demand": Profile(DAY, 1)},
        "demand_days7": {"demand": Profile(DAY, 7)},
        "pv_yesterday": {"generation": Profile(DAY, 1)},
        "pv_days7": {"generation": Profile(DAY, 7)},
        "prices_days7": {"prices": Profile(DAY, 7)},
        "horizon24": {"horizon": 24},
        "horizon72": {"horizon": 72},
        "cadence6": {"cadence": 6},
    }
    policies: dict[str, Callable[[Any], Any]] = {
        name: partial(MicrogridMPC, cache=False, **{**START, **change}) for name, change in changes.items()
    }
    policies["mpc"] = partial(MicrogridMPC, cache=False)
    policies["perfect_forecast"] = lambda env: PerfectForecast(env, cache=False)
    policies["only_market"] = lambda env: lambda obs: np.zeros(1, np.float32)
    policies["battery_first"] = lambda env: lambda obs: np.ones(1, np.float32)
    policies["hindsight"] = MicrogridHindsight
    return policies


def main(argv: Sequence[str] | None = None) -> int:
    """Write every policy's validation episodes to the CSV named by the first argument; print the summary."""
    args = list(argv if argv is not None else sys.argv[1:])
    if not 1 <= len(args) <= 3:
        print("usage: measure_microgrid_mpc.py OUT.csv [HOUSEHOLDS [POLICIES]]", file=sys.stderr)
        return 2
    env = MicrogridEnv(**ENV)
    households = env.profiles[: int(args[1]) if len(args) >= 2 else 4]
    variants = _variants()
    names = args[2].split(",") if len(args) == 3 else list(variants)
    unknown = sorted(set(names) - set(variants))
    if unknown:
        print(f"unknown policies {unknown}; measured: {', '.join(variants)}", file=sys.stderr)
        return 2
    rows = []
    for name in names:
        factory = variants[name]
        policy = factory(env)
        for year, start in YEARS.items():
            for household in households:
                began = time.process_time()
                run = run_episode(env, policy, 0, {"profile": household, "start": start}, objective=OBJECTIVE)
                seconds = time.process_time() - began
                objective = float(run["objective_rewards"].sum())
                row = {"policy": name, "year": year, "household": household, "objective": objective}
                rows.append({**row, "cpu_s": seconds})
        done = pd.DataFrame([r for r in rows if r["policy"] == name])
        print(f"{name:20s} IQM {iqm(done['objective'].to_numpy()):9.2f}  mean {done['objective'].mean():9.2f}  "
              f"CPU {done['cpu_s'].mean():6.1f} s/episode", flush=True)  # fmt: skip
        pd.DataFrame(rows).to_csv(args[0], index=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
