"""What a reproduce plan will cost, before it starts (``gym4real reproduce --plan``).

Each run's CPU time comes from, in this order: its finished run (nothing left to do); the finished runs of
the same env, algorithm and preset in the output folder (their mean wall time); the preset's budget times a
step rate measured in the output folder (any run of the same env and algorithm); the preset's budget times
the step rate recorded in :data:`RECORDED_S_PER_UNIT`. A budget is counted in the preset's unit: timesteps
(PPO, DQN) or episodes (tabular), its validation included in the rate. The wall time of ``jobs`` workers is
that of the longest-processing-time-first schedule of the runs, which the longest single run bounds below.
"""

from __future__ import annotations

import heapq
import json
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from gym4real.core.errors import Gym4RealError
from gym4real.bench.seeds import SeedRequest, check_request
from gym4real.core.registry import slug
from gym4real.results.plan import Item, plan
from gym4real.rl.presets import load_preset
from gym4real.rl.train import finished_run


def _per_unit(minutes: float, runs: int, units: int) -> float:
    """Seconds per budget unit of ``runs`` runs of ``units`` each that took ``minutes`` in all."""
    return minutes * 60 / (runs * units)


#: Seconds of one CPU per budget unit (timestep or episode), validation included: the paper-budget runs of
#: docs/results (code e4bd47b, microgrid 503cc61; two runs at a time on a 2-core machine, picking-v1 partly
#: three; minutes summed over the seeds). Trading's DQN rate is that of its e4bd47b runs, which
#: ``benchmarks/bench_training.py`` measured again idle at c6ab6b9 (2,820 steps per CPU s); the section's
#: retrained runs were trained three at a time beside other work and took 7.6 times as long.
RECORDED_S_PER_UNIT = {
    ("gym4real/dam-v0", "ppo"): _per_unit(28.7, 5, 200_000),
    ("gym4real/elevator-v0", "qlearning"): _per_unit(9.3, 5, 100_000),
    ("gym4real/elevator-v0", "sarsa"): _per_unit(5.2, 5, 100_000),
    ("gym4real/trading-v0", "dqn"): _per_unit(8.1, 6, 185_136),
    ("gym4real/trading-v0", "ppo"): _per_unit(143.5, 6, 185_136),
    ("gym4real/wds-v0", "dqn"): _per_unit(9.5, 5, 134_400),
    ("gym4real/robofeeder-picking-v0", "ppo"): _per_unit(74.3, 5, 15_000),
    ("gym4real/robofeeder-planning-v0", "ppo"): _per_unit(43.7, 5, 10_000),
    ("gym4real/robofeeder-picking-v1", "ppo"): _per_unit(358.9, 5, 15_000),
    ("gym4real/microgrid-v0", "ppo"): _per_unit(371.4, 5, 28_051_200),
}


@dataclass(frozen=True)
class Estimate:
    """The CPU seconds one run of a plan still needs (None: unknown) and where the figure comes from."""

    item: Item
    cpu_s: float | None
    source: str


def budget_units(env_id: str, algo: str, preset: str) -> int:
    """A preset's training budget in its unit: timesteps (PPO, DQN) or episodes (tabular)."""
    hp = load_preset(env_id, algo, preset)
    return int(hp.get("total_timesteps") or hp["episodes"])


def _measured(out: Path) -> tuple[dict[tuple[str, str, str], list[float]], dict[tuple[str, str], list[float]]]:
    """The finished runs in ``out``: wall times by (env, algo, preset), seconds per budget unit by (env, algo)."""
    walls: dict[tuple[str, str, str], list[float]] = defaultdict(list)
    rates: dict[tuple[str, str], list[float]] = defaultdict(list)
    for record in sorted(out.glob("*/*/runs/*/*/run.json")):
        try:
            data = json.loads(record.read_text())
            env_id, algo, preset, wall = data["env_id"], data["algo"], data["preset"], float(data["wall_time_s"])
            units = budget_units(env_id, algo, preset)
        except (OSError, ValueError, KeyError, Gym4RealError):  # a foreign or stale record: no measure
            continue
        walls[env_id, algo, preset].append(wall)
        rates[env_id, algo].append(wall / units)
    return walls, rates


def estimate(items: Sequence[Item], out: Path) -> list[Estimate]:
    """The CPU time each run of a plan still needs."""
    walls, rates = _measured(out)
    found = []
    for item in items:
        key = (item.env_id, item.algo)
        if finished_run(item.folder, item.env_id, item.algo, item.preset, item.seed, item.trainer) is not None:
            found.append(Estimate(item, 0.0, "finished"))
        elif same := walls.get((*key, item.preset)):
            found.append(Estimate(item, sum(same) / len(same), f"mean of {len(same)} run(s) measured in {out}"))
        elif rate := rates.get(key):
            units = budget_units(item.env_id, item.algo, item.preset)
            found.append(Estimate(item, units * sum(rate) / len(rate), "budget x step rate measured in the out folder"))
        elif key in RECORDED_S_PER_UNIT:
            units = budget_units(item.env_id, item.algo, item.preset)
            found.append(Estimate(item, units * RECORDED_S_PER_UNIT[key], "budget x recorded step rate"))
        else:
            found.append(Estimate(item, None, "unknown: no measured or recorded step rate"))
    return found


def wall_time(cpu_s: Sequence[float], workers: int) -> float:
    """The wall time of runs of ``cpu_s`` seconds on ``workers`` workers, longest first to the least loaded."""
    loads = [0.0] * max(1, min(workers, len(cpu_s)))
    for cost in sorted(cpu_s, reverse=True):
        heapq.heapreplace(loads, loads[0] + cost)
    return max(loads)


def duration(seconds: float) -> str:
    """``42 s``, ``3.5 min``, ``2.1 h``."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def plan_report(env_ids: Sequence[str], budget: str, n_seeds: SeedRequest, out: Path, jobs: int) -> str:
    """The plan of ``gym4real reproduce`` with each run's estimated CPU time and the expected wall time."""
    check_request(env_ids, budget, n_seeds)
    lines = [f"{'run':44s} {'CPU time':>9s}  source"]
    items: list[Item] = []
    for env_id in env_ids:
        try:
            items += plan(env_id, budget, n_seeds, out)
        except Gym4RealError as exc:
            lines.append(f"{slug(env_id):44s} {'-':>9s}  not run: {' '.join(str(exc).split())}")
    estimates = estimate(items, out)
    for e in estimates:
        name = f"{slug(e.item.env_id)} {e.item.algo}/{e.item.preset} seed {e.item.seed}"
        cost = "?" if e.cpu_s is None else duration(e.cpu_s)
        lines.append(f"{name:44s} {cost:>9s}  {e.source}")
    known = [e for e in estimates if e.cpu_s is not None]
    cpu = [e.cpu_s for e in known if e.cpu_s is not None]
    lines.append("")
    lines.append(f"{len(items)} runs, {len(items) - len(known)} of unknown cost; CPU time {duration(sum(cpu))}")
    if cpu:
        longest = max(known, key=lambda e: e.cpu_s or 0.0)
        lines.append(
            f"expected training wall time with {jobs} job(s): {duration(wall_time(cpu, jobs))}, no less than its "
            f"longest run ({slug(longest.item.env_id)} {longest.item.algo} seed {longest.item.seed}: "
            f"{duration(max(cpu))}); each environment's tests follow its runs (not estimated)"
        )
    return "\n".join(lines)
