"""Speed relative to Gymnasium's CartPole, measured interleaved in one process (the regression guard).

Two measures, each timed over ``--rounds`` rounds of one block of the reference and one of the env back
to back (so a machine whose load changes slows both alike); reported: the median of the rounds' ratios
with its quartiles, and the ratio of the fastest blocks (``best``, the least disturbed by other load):

* ``step_time``: seconds per step of ``gymnasium.make(id)`` over those of ``gymnasium.make("CartPole-v1")``,
  random actions drawn beforehand, resetting at episode ends (lower is faster);
* ``native_throughput``: steps per second of the env's native batched ``VectorEnv`` with ``--copies`` copies
  (``vector_entry_point``, autoresetting) over those of Gymnasium's ``CartPoleVectorEnv`` with as many
  (higher is faster).

Each row gives the goal of issue 25 where there is one and whether the median meets it. On a loaded machine
the ratios move from run to run: compare medians of repeated runs, and the ``best`` column.

    python benchmarks/bench_ratios.py [--ids gym4real/dam-v0,...] [--rounds 31] [--steps 500] [--json out.json]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv
from report import report  # benchmarks/report.py (the script's folder is on sys.path)

import gym4real

# issue 25: the single-env step time at most, the native batch's throughput at least (ratios to CartPole)
STEP_TIME_GOALS = {"gym4real/elevator-v0": 0.35, "gym4real/dam-v0": 1.2}
NATIVE_THROUGHPUT_GOALS = {
    "gym4real/elevator-v0": 1.0,
    "gym4real/trading-v0": 1.0,
    "gym4real/dam-v0": 0.3,
    "gym4real/microgrid-v0": 0.25,
}


def interleaved(reference: Callable[[], Any], candidate: Callable[[], Any], rounds: int) -> tuple[list[float], list[float]]:
    """The times of ``rounds`` blocks of the reference and of the candidate, each round timing one of each back to back."""
    ref, cand = [], []
    for _ in range(rounds):
        t0 = time.perf_counter()
        reference()
        t1 = time.perf_counter()
        candidate()
        t2 = time.perf_counter()
        ref.append(t1 - t0)
        cand.append(t2 - t1)
    return ref, cand


def _stepper(env: gym.Env[Any, Any], steps: int, seed: int) -> Callable[[], None]:
    """A block of ``steps`` random steps of ``env``, resetting at episode ends (actions drawn beforehand)."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]

    def run() -> None:
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()

    return run


def _vector_stepper(env: gym.vector.VectorEnv[Any, Any, Any], steps: int, seed: int) -> Callable[[], None]:
    """A block of ``steps`` random batched steps of an autoresetting vector env (actions drawn beforehand)."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]

    def run() -> None:
        for a in actions:
            env.step(a)

    return run


def _row(
    env_id: str, measure: str, times: tuple[list[float], list[float]], goal: float | None, higher_is_better: bool
) -> dict[str, Any]:
    """The ratios of one measure: the median of the rounds' ratios and the ratio of the fastest blocks."""
    ref, cand = times
    ratios = [r / c if higher_is_better else c / r for r, c in zip(ref, cand, strict=True)]  # per round
    median = statistics.median(ratios)
    best = min(ref) / min(cand) if higher_is_better else min(cand) / min(ref)  # the least disturbed blocks
    return {
        "env": env_id,
        "measure": measure,
        "median": median,
        "q1": statistics.quantiles(ratios, n=4)[0],
        "q3": statistics.quantiles(ratios, n=4)[2],
        "best": best,
        "goal": "" if goal is None else (">= " if higher_is_better else "<= ") + f"{goal:g}",
        "met": "" if goal is None else str(median >= goal if higher_is_better else median <= goal),
    }


def step_time_ratio(env_id: str, steps: int, rounds: int) -> dict[str, Any]:
    """The ``step_time`` row of ``env_id``: its ``make`` env's time per step over CartPole-v1's."""
    cartpole, env = gym.make("CartPole-v1"), gym.make(env_id)
    reference, candidate = _stepper(cartpole, steps, 0), _stepper(env, steps, 0)
    candidate()  # warm: caches filled, first episodes drawn
    times = interleaved(reference, candidate, rounds)
    cartpole.close()
    env.close()
    return _row(env_id, "step_time", times, STEP_TIME_GOALS.get(env_id), higher_is_better=False)


def native_throughput_ratio(env_id: str, copies: int, steps: int, rounds: int) -> dict[str, Any] | None:
    """The ``native_throughput`` row of ``env_id`` (None without a native batched env)."""
    if not gym.spec(env_id).vector_entry_point:
        return None
    cartpole = CartPoleVectorEnv(num_envs=copies)
    native = gym.make_vec(env_id, num_envs=copies, vectorization_mode="vector_entry_point")
    reference, candidate = _vector_stepper(cartpole, steps, 0), _vector_stepper(native, steps, 0)
    candidate()  # warm
    times = interleaved(reference, candidate, rounds)
    cartpole.close()
    native.close()
    return _row(env_id, f"native_throughput ({copies} copies)", times, NATIVE_THROUGHPUT_GOALS.get(env_id), True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ids", default="", help="comma-separated ids (default: every installed env)")
    parser.add_argument("--rounds", type=int, default=31, help="interleaved rounds; the median is reported")
    parser.add_argument("--steps", type=int, default=500, help="single-env steps per timed block")
    parser.add_argument("--copies", type=int, default=1024, help="copies of the native batched envs")
    parser.add_argument("--batch-steps", type=int, default=20, help="batched steps per timed block")
    parser.add_argument("--no-single", action="store_true", help="only the native batched envs")
    parser.add_argument("--no-native", action="store_true", help="only the single envs")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    args = parser.parse_args()
    ids = [i for i in args.ids.split(",") if i] or gym4real.list_envs(multi_objective=False)
    rows = []
    for env_id in ids:
        if not args.no_single:
            rows.append(step_time_ratio(env_id, args.steps, args.rounds))
        native = None if args.no_native else native_throughput_ratio(env_id, args.copies, args.batch_steps, args.rounds)
        if native is not None:
            rows.append(native)
    report(rows, ["env", "measure", "median", "q1", "q3", "best", "goal", "met"], 3, args.json)


if __name__ == "__main__":
    main()
