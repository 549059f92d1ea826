"""Measure how far the dam's and the microgrid's hindsight planners are from a better plan, per test episode.

``python scripts/measure_planner_gaps.py dam|microgrid [EPISODE ...] [--csv OUT.csv]`` plans each test
episode of the domain's protocol with the registered planner (its DP, then its local search; the plan cache
off), and then runs a **further search** from the planner's plan, through the same env, with moves the
planner's search does not make:

- dam: :func:`gym4real.dam.hindsight_kernel.improve` with transfers up to 30 days apart (the planner: 5) and
  changes from 16 down to 1/256 grid quanta (the planner: 8 to 1/64), then 20,000 random moves (a block of
  1 to 30 days' releases raised or lowered, or release moved between two days up to 60 days apart, by up to
  two quanta), each played through the env's days and kept when the year scores more;
- microgrid: :func:`gym4real.microgrid.hindsight_kernel.improve` with other changes of the SoC targets
  (0.004, 0.001, 0.00025, 0.0000625; the planner: 0.002, 0.0005, 0.000125), longer spans (1, the run, 2, 3,
  6, 12 hours; the planner: up to 6) and a 48-hour window (the planner: 24).

Every objective printed is the env's: the dam's plans re-integrated by ``Lake.day`` (what ``DamEnv.step``
calls), the microgrid's replayed through the twin (``MicrogridHindsight._replay``). Per episode it prints the
DP's objective, the planner's, the gain of the planner's search, its CPU seconds (DP and search), the further
search's objective and its gain over the planner's: the planner's measured distance to a better plan, which
``BaselineSpec.gap`` of the domain's ``hindsight`` declares (the largest over the test episodes) and
``docs/headroom.md`` tables.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd

from gym4real.bench.mo_reference import test_plan

#: Random moves of the dam's further search, and its seed.
RANDOM_MOVES = 20_000
SEED = 0


def _dam_random_moves(planner: Any, c: dict[str, Any], plan: np.ndarray, quantum: float) -> np.ndarray:
    """Random block and transfer moves of the daily releases, each kept when the year (as the env plays it) gains."""
    from gym4real.dam import hindsight_kernel as kernel

    exogenous, (a_low, a_high) = c["exogenous"], c["box"]
    low = np.minimum(np.maximum(exogenous[:, 2], a_low), a_high)
    days = exogenous.shape[0]
    storages, rewards = np.empty(days + 1), np.empty(days)
    args = (exogenous, c["lake"], c["evaporates"], c["substeps"], c["costs"], storages, rewards)
    best = kernel.rollout(c["storage"], plan, 0, *args)
    rng = np.random.default_rng(SEED)
    for _ in range(RANDOM_MOVES):
        trial = plan.copy()
        amount = rng.uniform(-2.0, 2.0) * quantum
        t = int(rng.integers(days))
        if rng.random() < 0.5:  # a block of days raised or lowered
            trial[t : t + int(rng.integers(1, 31))] += amount
        else:  # release moved from day t to a day up to 60 days later
            s = min(days - 1, t + int(rng.integers(1, 61)))
            trial[t] += amount
            trial[s] -= amount
        if np.any(trial < low) or np.any(trial > a_high):
            continue
        value = kernel.rollout(c["storage"], trial, 0, *args)
        if value > best:
            plan, best = trial, value
    return plan


def dam(episode: dict[str, Any]) -> dict[str, Any]:
    """One test year: the planner's objectives and the further search's."""
    from gym4real.dam import hindsight_kernel as kernel
    from gym4real.dam.hindsight import STEP, DamHindsight
    from gym4real.dam.lake import SECONDS_PER_DAY

    env = gym.make("gym4real/dam-v0", **test_plan("gym4real/dam-v0")[1])
    env.reset(seed=episode["seed"], options=episode["options"])
    planner = DamHindsight(env, cache=False)
    start = time.process_time()
    plan = np.array(planner.plan())
    cpu = time.process_time() - start
    c = planner._constants()
    quantum = planner.env.lake.surface * STEP / SECONDS_PER_DAY
    exogenous, (a_low, a_high) = c["exogenous"], c["box"]
    low = np.minimum(np.maximum(exogenous[:, 2], a_low), a_high)
    high = np.full(exogenous.shape[0], a_high)
    further = plan.copy()
    kernel.improve(
        further, c["storage"], exogenous, c["lake"], c["evaporates"], c["substeps"], c["costs"], low, high,
        quantum * 2.0 ** -np.arange(-4, 9), 30, 1e-7,
    )  # fmt: skip
    further = _dam_random_moves(planner, c, further, quantum)
    return {
        "episode": episode["options"]["year"],
        "dp": planner.dp_objectives[-1],
        "planner": planner.forward_objectives[-1],
        "cpu_s": cpu,
        "further": max(planner._forward(c, [float(d) for d in further]), planner.forward_objectives[-1]),
    }


def microgrid(episode: dict[str, Any]) -> dict[str, Any]:
    """One test household: the planner's objectives and the further search's."""
    from gym4real.microgrid.hindsight import MicrogridHindsight, twin_copies

    env = gym.make("gym4real/microgrid-v0", **test_plan("gym4real/microgrid-v0")[1])
    env.reset(seed=episode["seed"], options=episode["options"])
    planner = MicrogridHindsight(env)
    start = time.process_time()
    planner._plan()
    cpu = time.process_time() - start
    assert planner.targets is not None
    changes, spans = np.array([0.004, 0.001, 0.00025, 0.0000625]), np.array([1, 0, 2, 3, 6, 12], dtype=np.int64)
    twin = twin_copies(planner.env, 3 + 2 * changes.size * spans.size)
    assert twin is not None
    state, args, obs_size = twin
    targets = planner.targets.copy()
    p = planner.env.battery.params
    weights = (planner._trade_weight, planner._degradation_weight)
    planner._kernel.improve(targets, p.soc_min, p.soc_max, changes, spans, 48, 1e-6, state, args, weights, obs_size)
    return {
        "episode": episode["options"]["profile"],
        "dp": planner.dp_objective,
        "planner": planner.replayed_objective,
        "cpu_s": cpu,
        "further": max(planner._replay(targets).objective, planner.replayed_objective),
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Measure and print the table; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("domain", choices=("dam", "microgrid"))
    parser.add_argument("episodes", nargs="*", type=int, help="indices of the test episodes (default: all)")
    parser.add_argument("--csv", default=None, help="also write the table here")
    args = parser.parse_args(argv)
    plan, _ = test_plan(f"gym4real/{args.domain}-v0")
    measure = dam if args.domain == "dam" else microgrid
    rows = []
    for i in args.episodes or range(len(plan)):
        row = measure(plan[i])
        row["search_gain_pct"] = 100 * (row["planner"] - row["dp"]) / abs(row["dp"])
        row["further_gain_pct"] = 100 * (row["further"] - row["planner"]) / abs(row["planner"])
        rows.append(row)
        print(
            f"{row['episode']}: DP {row['dp']:,.2f}, planner {row['planner']:,.2f} "
            f"(search +{row['search_gain_pct']:.3f} %, {row['cpu_s']:.1f} s CPU), "
            f"further search {row['further']:,.2f} (+{row['further_gain_pct']:.4f} %)",
            flush=True,
        )
    table = pd.DataFrame(rows)
    if args.csv:
        table.to_csv(args.csv, index=False)
    print(f"largest further gain: {table['further_gain_pct'].max():.4f} %; planning CPU {table['cpu_s'].sum():.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
