"""RoboFeeder picking speed: env-steps/s of picking-v1 on random actions, the first ``make``, and a check
that the reachable-window shortcut reports what the full plan does.

Random actions aim anywhere in the 300x300 image: about a fifth of them lie outside the reachable window,
where the pick is unfeasible whatever the inverse kinematics finds. Before that shortcut the whole plan
(pre-pick, pick and place poses) was solved for them; now only the pick pose is, whose gripper yaw and IK
error the outcome reports. ``--verify N`` draws N random targets outside the window, times ``pick`` there
and counts the outcomes that differ from the full plan's (0 expected). The first ``make`` is timed in a
fresh interpreter (imports included; SciPy is imported only by the upstream mode's planner). Compare two
commits by running the script in each checkout, on the same machine, back to back: on a loaded machine the
ratios hold better than the absolute figures.

    python benchmarks/bench_robofeeder.py [--steps 40] [--repeats 3] [--verify 100] [--json out.json]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np
from report import report  # benchmarks/report.py (the script's folder is on sys.path)

import gym4real  # noqa: F401  (registers the ids)

ID = "gym4real/robofeeder-picking-v1"


def steps_per_second(steps: int, seed: int) -> tuple[float, float]:
    """Env-steps/s of seeded random actions, and the share of targets outside the reachable window."""
    env = gym.make(ID).unwrapped
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    outside = sum(not env.sim.reachable(env._target_pixel(np.asarray(a, dtype=float))) for a in actions)
    t0 = time.perf_counter()
    for a in actions:
        *_, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    elapsed = time.perf_counter() - t0
    env.close()
    return steps / elapsed, outside / steps


def first_make_seconds() -> float:
    """Seconds to import gym4real and make picking-v1 in a fresh interpreter."""
    code = (
        "import time; t0 = time.perf_counter(); import gymnasium as gym, gym4real; "
        f"gym.make({ID!r}); print(time.perf_counter() - t0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1])


def unreachable_targets(targets: int, seed: int) -> tuple[float, int]:
    """Median milliseconds of ``pick`` at random targets outside the window, and how many of their outcomes
    (feasibility, gripper yaw, IK error) differ from the full plan's (checked where the shortcut exists)."""
    env = gym.make(ID).unwrapped
    env.reset(seed=seed)
    sim, rng = env.sim, np.random.default_rng(seed)
    times, bad = [], 0
    while len(times) < targets:
        pixel = rng.uniform(0.0, env.size, 2)
        if sim.reachable(pixel):
            continue
        xy, theta = sim.camera.pixel_to_world(pixel), float(rng.uniform(0.0, np.pi))
        t0 = time.perf_counter()
        outcome = sim.pick(xy, theta, pixel)
        times.append(time.perf_counter() - t0)
        if hasattr(sim, "_gripper_yaw"):  # a checkout without the shortcut plans whole: nothing to compare
            _, ik_error, yaw, _ = sim.plan(xy, theta)
            bad += (outcome.feasible, outcome.gripper_yaw, outcome.ik_error) != (False, yaw, ik_error)
    env.close()
    return 1000 * statistics.median(times), bad


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=40, help="random-action steps per timed run")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs (seeds 0, 1, ...); the median is kept")
    parser.add_argument("--verify", type=int, default=100, help="random targets outside the window to time and check")
    parser.add_argument("--json", default=None, help="also save the rows as JSON here")
    args = parser.parse_args()
    runs = [steps_per_second(args.steps, seed) for seed in range(args.repeats)]
    makes = [first_make_seconds() for _ in range(args.repeats)]
    row = {
        "env": ID,
        "env_steps_per_s": statistics.median(r[0] for r in runs),
        "outside_window": statistics.median(r[1] for r in runs),
        "first_make_s": statistics.median(makes),
    }
    row["unreachable_pick_ms"], row["mismatches"] = unreachable_targets(args.verify, 0)
    row["verified_targets"] = args.verify
    report([row], list(row), 3, args.json)


if __name__ == "__main__":
    main()
