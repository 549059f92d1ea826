"""The dam's ``mpc`` baseline: its score and cost under each setting, on the validation years (never the test years).

Each row runs :class:`gym4real.dam.mpc.DamMPC` with the defaults but one setting changed (the first row: the
defaults) on the 13 years of the ``validation`` preset (training years; the controller leaves an episode's own
year out of its forecasts, so each is forecast as a held-out year would be), and gives the IQM and the mean of the
protocol's objective (deficit + overflow + starving) over the years, the IQM's difference from the first row's
with its 95 % paired bootstrap interval over the years (:func:`gym4real.bench.stats.difference_ci`: an interval
holding 0 is a difference the 13 years do not resolve), and the CPU seconds of the 13 episodes (the decision
cache off). ``docs/headroom.md`` tables the rows that chose the defaults; the JSON holds each year's score.

    python benchmarks/bench_dam_mpc.py [--rows 'default;horizon=7;margins=[0.2,0.05]'] [--preset validation]
        [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import gymnasium as gym
import numpy as np
from report import report  # benchmarks/report.py (the script's folder is on sys.path)

import gym4real  # noqa: F401  (registers the ids)
from gym4real.bench import stats
from gym4real.dam.mpc import DamMPC

OBJECTIVE = ("deficit", "overflow", "starving")
#: The settings measured by default: each changes one default (``name=value``, the value as JSON).
ROWS = (
    "default",
    "statistic=0.5",
    "statistic=0.75",
    "margins=[0.0,0.0]",
    "margins=[0.3,0.05]",
    "margins=[0.4,0.05]",
    "margins=[0.6,0.05]",
    "margins=[0.8,0.05]",
    "margins=[0.5,0.0]",
    "margins=[0.5,0.1]",
    "horizon=7",
    "horizon=30",
    "horizon=60",
    "cadence=1",
    "cadence=15",
    "step=0.005",
)


def _episode(env: gym.Env, policy: DamMPC, year: int) -> float:
    obs, _ = env.reset(options={"year": year})
    policy.reset(None)
    total, done = 0.0, False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        total += sum(info["reward_components"][c] for c in OBJECTIVE)
        done = terminated or truncated
    return total


def _setting(row: str) -> dict[str, Any]:
    if row == "default":
        return {}
    name, _, value = row.partition("=")
    parsed = json.loads(value)
    return {name: tuple(parsed) if isinstance(parsed, list) else parsed}


def main() -> None:
    """Print one line per setting: IQM and mean objective over the preset's years, the difference, CPU seconds."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default=";".join(ROWS), help="settings separated by `;`")
    parser.add_argument("--preset", default="validation")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    env = gym.make("gym4real/dam-v0", preset=args.preset)
    years = env.unwrapped.years
    rows: list[dict[str, Any]] = []
    for row in args.rows.split(";"):
        policy = DamMPC(env, cache=False, **_setting(row))
        start = time.process_time()
        scores = np.array([[_episode(env, policy, year) for year in years]])
        seconds = time.process_time() - start
        first = np.array([rows[0]["scores"]]) if rows else scores
        difference, low, high = stats.difference_ci(scores, first, False, False)
        rows.append(
            {
                "setting": row,
                "iqm": stats.iqm(scores),
                "mean": float(scores.mean()),
                "vs_first": f"{difference:+.0f} [{low:+.0f}, {high:+.0f}]",
                "cpu_s": seconds,
                "scores": scores[0].tolist(),
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    report(rows, ("setting", "iqm", "mean", "vs_first", "cpu_s"), 5, args.json)


if __name__ == "__main__":
    main()
