"""Measure the choices of wds-v0's ``mpc`` baseline on non-test weeks (never the test protocol's profiles 0-19).

``python scripts/measure_wds_mpc.py forecast`` prints the error of the controller's demand forecast
(:func:`gym4real.wds.mpc.forecast`) and of simpler ones, 1 to ``--ahead`` hours ahead of every hour of the
validation weeks (profiles 500-999 of ``test1000.csv``) and of the training weeks.

``python scripts/measure_wds_mpc.py returns 6,1 12,2 ...`` runs the controller with each ``horizon,cadence``
pair on the validation weeks ``--weeks`` (default 500-519, weights 1 / 1 as the test preset), the plan cache
off, and prints per pair the mean and IQM of the return and the CPU seconds per week; ``--forecast`` swaps the
controller's forecast for one of the simpler ones. docs/headroom.md (wds) reports both tables.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import gym4real  # noqa: F401  (registers the ids)
from gym4real.bench.benchmark import run_episode
from gym4real.bench.stats import iqm
from gym4real.wds import demand, mpc

ENV_ID = "gym4real/wds-v0"
DAY = 24
Forecast = Callable[[np.ndarray, int, np.ndarray], np.ndarray]


def _scaled_shape(past: np.ndarray, hours: int, shape: np.ndarray) -> np.ndarray:
    level = past.sum() / shape[np.arange(len(past)) % DAY].sum()
    return np.asarray(level * shape[(len(past) + np.arange(hours)) % DAY])


def _yesterday(past: np.ndarray, hours: int, shape: np.ndarray) -> np.ndarray:
    out = _scaled_shape(past, hours, shape)
    for i in range(hours):
        if len(past) + i >= DAY:
            out[i] = past[len(past) + i - DAY]
    return out


def _past_days(past: np.ndarray, hours: int, shape: np.ndarray) -> np.ndarray:
    out = _scaled_shape(past, hours, shape)
    for i in range(hours):
        same = past[(len(past) + i) % DAY :: DAY]
        if len(same) and len(past) + i >= DAY:
            out[i] = same.mean()
    return out


FORECASTS: dict[str, Forecast] = {
    "mpc": mpc.forecast,
    "past_days": _past_days,
    "scaled_shape": _scaled_shape,
    "yesterday": _yesterday,
    "persistence": lambda past, hours, shape: np.full(hours, past[-1]),
}


def forecast_errors(ahead: int) -> None:
    """RMSE of each forecast over the next ``ahead`` hours, on validation and on training weeks."""
    profiles = demand.load()
    shape = mpc.training_shape(profiles, DAY)
    sets = {
        "validation 500-999": profiles.test[:, 500:],
        "training": np.concatenate([profiles.train[n] for names in profiles.buckets.values() for n in names], axis=1),
    }
    print(f"| forecast | {' | '.join(f'RMSE, {name}' for name in sets)} |")
    print("|---|" + "---|" * len(sets))
    for name, fn in FORECASTS.items():
        cells = []
        for weeks in sets.values():
            squares = [
                np.mean((fn(w[: h + 1], ahead, shape) - w[h + 1 : h + 1 + ahead]) ** 2)
                for w in weeks.T
                for h in range(len(w) - ahead)
            ]
            cells.append(f"{np.sqrt(np.mean(squares)):.4f}")
        print(f"| {name} | {' | '.join(cells)} |")


def returns(pairs: list[tuple[int, int]], weeks: list[int], forecast: str) -> None:
    """Mean and IQM of the return, CPU s per week, of each (horizon, cadence) on the validation ``weeks``."""
    # the controller's forecast, or a simpler one in its place (a measurement, not an option of the baseline)
    mpc.forecast = FORECASTS[forecast]  # type: ignore[assignment]
    print("| horizon | cadence | forecast | mean | IQM | CPU s / week |")
    print("|---|---|---|---|---|---|")
    for horizon, cadence in pairs:
        env = gym.make(ENV_ID, preset="test")
        policy = mpc.WDSMPC(env, horizon=horizon, cadence=cadence, cache=False)
        start = time.process_time()
        scores = [
            float(run_episode(env, policy, None, {"profile_index": k}, objective=("dsr", "overflow"))["rewards"].sum())
            for k in weeks
        ]
        cpu = (time.process_time() - start) / len(weeks)
        policy.close()
        env.close()
        mean, middle = np.mean(scores), iqm(scores)
        print(f"| {horizon} | {cadence} | {forecast} | {mean:.3f} | {middle:.3f} | {cpu:.1f} |")


def main() -> None:
    """Command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="what", required=True)
    errors = sub.add_parser("forecast", help="forecast errors")
    errors.add_argument("--ahead", type=int, default=5, help="hours ahead (the default horizon's 5 forecast hours)")
    run = sub.add_parser("returns", help="validation returns of horizon,cadence pairs")
    run.add_argument("pairs", nargs="+", help="horizon,cadence (for example 6,1)")
    run.add_argument("--weeks", default="500-519", help="validation profiles, first-last (never 0-19)")
    run.add_argument("--forecast", choices=sorted(FORECASTS), default="mpc")
    args = parser.parse_args()
    if args.what == "forecast":
        forecast_errors(args.ahead)
        return
    first, last = (int(x) for x in args.weeks.split("-"))
    if first < 20:
        parser.error("--weeks must avoid the test protocol's profiles 0-19")
    pairs = [(int(h), int(c)) for h, c in (p.split(",") for p in args.pairs)]
    returns(pairs, list(range(first, last + 1)), args.forecast)


if __name__ == "__main__":
    main()
