"""Accuracy and cost of WDSEnv's hydraulic step: tank levels and weekly returns against a converged run.

EPANET integrates tank levels with explicit Euler steps of ``hydraulic_step`` seconds. For each test profile
and each step, one week of the same open-loop actions (random, seeded by the profile; or both pumps on) is
run and compared with a 60 s run: the largest tank-level difference over the week's 168 decisions (m), the
difference of the weekly return (weights 1 / 1) and the wall time of the episode (median of the profiles).

    python benchmarks/bench_wds_hydraulic_step.py [--steps 3600,600,300] [--profiles 0-9]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from gym4real.wds import WDSEnv

REFERENCE_STEP = 60


def _week(step: int, actions: np.ndarray, profile: int) -> tuple[np.ndarray, float, float]:
    env = WDSEnv(hydraulic_step=step, reward={"dsr_coeff": 1.0, "overflow_coeff": 1.0})
    try:
        env.reset(options={"profile_index": profile})
        levels, ret = [], 0.0
        t0 = time.perf_counter()
        for a in actions:
            _, reward, _, _, info = env.step(int(a))
            levels.append(list(info["tanks"].values()))
            ret += reward
        return np.array(levels), ret, time.perf_counter() - t0
    finally:
        env.close()


def main() -> None:
    """Print one line per (policy, step): level and return errors against 60 s, episode time."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", default="3600,600,300,120")
    parser.add_argument("--profiles", default="0-9", help="test profiles, `a-b` (inclusive) or `a,b,c`")
    args = parser.parse_args()
    steps = [int(s) for s in args.steps.split(",")]
    if "-" in args.profiles:
        lo, hi = (int(x) for x in args.profiles.split("-"))
        profiles = list(range(lo, hi + 1))
    else:
        profiles = [int(x) for x in args.profiles.split(",")]
    print(f"{'actions':8s} {'step':>5s} {'level err (m)':>15s} {'return err':>13s} {'episode (ms)':>13s}")
    for policy in ("random", "both_on"):
        errors: dict[int, list[tuple[float, float, float]]] = {s: [] for s in steps}
        for k in profiles:
            rng = np.random.default_rng(k)
            actions = rng.integers(0, 4, size=168) if policy == "random" else np.full(168, 3)
            ref_levels, ref_return, _ = _week(REFERENCE_STEP, actions, k)
            for s in steps:
                levels, ret, seconds = _week(s, actions, k)
                errors[s].append((float(np.abs(levels - ref_levels).max()), abs(ret - ref_return), seconds))
        for s in steps:
            lv, rt, sec = zip(*errors[s], strict=True)
            print(
                f"{policy:8s} {s:5d} {min(lv):7.3f}-{max(lv):5.3f} {min(rt):6.2f}-{max(rt):5.2f} "
                f"{statistics.median(sec) * 1e3:13.1f}"
            )


if __name__ == "__main__":
    main()
