"""Regenerate the golden fixtures ``tests/golden/<domain>.json`` from the reference implementation.

Not run in CI. It runs the reference (Daveonwave/gym4ReaL, commit 774d5ce) from an already extracted
copy, in a Python environment holding the reference's pinned dependencies, and records what the
reference itself produces: per-episode returns and reward components of the rule-based baselines on the
evaluation protocol, and the first steps of one trajectory under a fixed action sequence. It never
downloads, installs or copies the reference.

Setup (outside this repository)::

    # every file of commit 774d5ce into /tmp/ref (the snapshot lacks a few binary blobs: trained models,
    # Q-tables, the detector; `git archive` stops at the first, so copy blob by blob and skip those)
    python3.12 -m venv /tmp/ref-venv
    /tmp/ref-venv/bin/pip install gymnasium==1.1.1 numpy==2.2.4 PyYAML==6.0.2 pandas==2.2.3 scipy==1.15.2 \\
        tqdm==4.67.1 rich==14.0.0 matplotlib==3.10.1 scikit-learn==1.6.1 epynet==1.1 pygame owa-epanet==2.3.5

The reference reads its data from ``gym4real/data/`` relative to its root: point that folder at the shared
data (``dam``, ``microgrid``, ``wds/demand`` and ``wds/towns/anytown_map.inp`` as symlinks; keep ``wds/towns``
a real folder, the reference writes ``anytown_map.rpt`` next to the network file). Then::

    /tmp/ref-venv/bin/python tests/golden/regen.py --reference /tmp/ref --domain dam

WDS: ``--epanet-lib`` names the EPANET shared library the reference's vendored epynet loads instead of its
own ``lib/libepanet.so`` (EPANET 2.2.0). The fixture uses owa-epanet's library (EPANET 2.3.05, the engine
of our package; ``/tmp/ref-venv/lib/python3.12/site-packages/epanet/libepanet2.so``), so that the
comparison isolates the env's logic from the engine version. A WDS episode of the reference takes minutes:
``--wds-episodes`` (default 3) runs the first episodes of the protocol for each policy.

Trading: the reference ships no market data; both sides read the synthetic HistData tick files written
by ``synthetic_ticks.py``.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import importlib.util
import io
import json
import math
import os
import platform
import sys
import tempfile
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
DOMAINS = ("dam", "elevator", "microgrid", "trading", "wds")


def _load_sibling(name: str) -> Any:
    spec = importlib.util.spec_from_file_location(f"golden_{name}", HERE / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _versions(*dists: str) -> dict[str, str]:
    out = {"python": platform.python_version()}
    for d in dists:
        with contextlib.suppress(metadata.PackageNotFoundError):
            out[d] = metadata.version(d)
    return out


def _seq_sum(values: list[float]) -> float:
    """Sum in step order, as an episode loop accumulates (``total += x``)."""
    total = 0.0
    for v in values:
        total += float(v)
    return total


def _episode_record(rewards: list[float], components: dict[str, list[float]], **extra: Any) -> dict[str, Any]:
    return {
        "steps": len(rewards),
        "return": math.fsum(rewards),
        "components": {k: _seq_sum(v) for k, v in components.items()},
        **extra,
    }


def _floats(x: Any) -> list[float]:
    return [float(v) for v in list(x)]


# -- dam -------------------------------------------------------------------------------------------


def dam() -> dict[str, Any]:
    import gymnasium as gym
    import numpy as np

    from gym4real.envs.dam.utils import parameter_generator

    def make() -> Any:
        params = parameter_generator(
            world_options="gym4real/envs/dam/world_test.yaml", lake_params="gym4real/envs/dam/lake.yaml"
        )
        return gym.make("gym4real/dam-v0", settings=params)

    env = make()
    low, high = env.action_space.low, env.action_space.high
    policies: dict[str, Callable[[dict[str, Any]], Any]] = {
        "mean": lambda info: (high + low) / 2,
        "max": lambda info: high,
        "ead": lambda info: info["exponential_average_demand"],
    }
    baselines: dict[str, list[dict[str, Any]]] = {}
    for name, policy in policies.items():
        episodes = []
        for ep in range(13):
            _, info = env.reset(options={"rewind_profiles": ep == 0})
            year = int(env.unwrapped.curr_year_data)
            rewards, comps, done = [], {}, False
            while not done:
                _, reward, terminated, truncated, info = env.step(policy(info))
                rewards.append(float(reward))
                for k, v in info["weighted_reward"].items():
                    comps.setdefault(k, []).append(float(v))
                done = terminated or truncated
            episodes.append(_episode_record(rewards, comps, year=year))
        baselines[name] = _columns(episodes)

    actions = [0.0, 100.0, 245.805, 491.61, 600.0, -10.0, 5.0, 300.0, 1000.0, 50.0, 150.0, 20.0]
    env = make()
    obs, _ = env.reset(options={"rewind_profiles": True})
    steps = []
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.array([a], dtype=np.float64))
        steps.append(_step(_floats(obs), reward, terminated, truncated, release=float(info["release"])))
    t = len(actions)
    while not (terminated or truncated):  # the last step: its observation reports day 0 and the initial level
        obs, reward, terminated, truncated, info = env.step(np.array([245.805]))
        t += 1
    last = {"step": t - 1, **_step(_floats(obs), reward, terminated, truncated)}
    return {
        "protocol": "world_test.yaml; 13 episodes, one per test year in file order (rewind_profiles at the "
        "first); components: per-episode sums of info['weighted_reward'] in step order; return: fsum of rewards",
        "versions": _versions("gymnasium", "numpy", "pandas", "PyYAML"),
        "baselines": baselines,
        "trajectory": {
            "year": int(env.unwrapped.curr_year_data),
            "actions": actions,
            "after_prefix_action": 245.805,
            "steps": steps,
            "last": last,
        },
    }


def _step(obs: Any, reward: Any, terminated: Any, truncated: Any, **extra: Any) -> dict[str, Any]:
    return {"obs": obs, "reward": float(reward), "terminated": bool(terminated), "truncated": bool(truncated), **extra}


# -- elevator --------------------------------------------------------------------------------------


def _queue_first(longest: bool) -> Callable[[dict[str, Any], dict[str, Any]], int]:
    """The notebooks' longest-first / shortest-first dispatching (the spec's working version)."""

    def policy(obs: dict[str, Any], info: dict[str, Any]) -> int:
        metres = obs["current_position"] * info["movement_speed"]
        if obs["n_passengers"] > 0:
            return 1 if metres / info["floor_height"] == info["goal_floor"] else 0
        waiting = [(int(q), floor) for floor, q in enumerate(obs["floor_queues"], start=1) if q > 0]
        if not waiting:
            return 1
        _, target = max(waiting) if longest else min(waiting)
        target_m = target * info["floor_height"]
        return 1 if metres == target_m else (2 if metres < target_m else 0)

    return policy


def elevator() -> dict[str, Any]:
    import gymnasium as gym

    from gym4real.envs.elevator.utils import parameter_generator

    seed = 1234

    def make() -> Any:
        params = parameter_generator(world_options="gym4real/envs/elevator/world.yaml", seed=seed)
        env = gym.make("gym4real/elevator-v0", settings=params)
        # The reference draws the initial position from this sub-space, which it never seeds; seeding it
        # (Gymnasium's space API) makes the start positions, and so the returns, reproducible.
        env.unwrapped.observation_space["current_position"].seed(seed)
        return env

    baselines: dict[str, list[dict[str, Any]]] = {}
    for name, longest in (("longest_first", True), ("shortest_first", False)):
        env, policy, episodes = make(), _queue_first(longest), []
        for _ in range(30):
            obs, info = env.reset()
            start = float(info["vertical_position"])
            arrivals = [sum(len(v) for v in q.arrivals.values()) for q in env.unwrapped._elevator.queues if q.floor]
            rewards, comps, done = [], {"delivery": [], "waiting": []}, False
            while not done:
                obs, reward, terminated, truncated, info = env.step(policy(obs, info))
                rewards.append(float(reward))
                comps["delivery" if reward > 0 else "waiting"].append(float(reward))
                done = terminated or truncated
            episodes.append(_episode_record(rewards, comps, start_position_m=start, arrivals_per_floor=arrivals))
        baselines[name] = _columns(episodes)

    env = make()
    obs, info = env.reset()
    actions = [2, 2, 1, 1, 0, 0, 0, 1, 1, 2, 2, 2, 2, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0, 1, 1, 2, 1, 2, 2, 1]
    steps = [{"obs": _elevator_obs(obs)}]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        steps.append(_step(_elevator_obs(obs), reward, terminated, truncated))
    return {
        "protocol": "world.yaml with seed 1234; a fresh env per policy, 30 consecutive resets; the reference's "
        "unseeded current_position space seeded with 1234; components: positive rewards (delivery) and the "
        "rest (waiting), summed in step order",
        "versions": _versions("gymnasium", "numpy"),
        "baselines": baselines,
        "trajectory": {"actions": actions, "steps": steps},
    }


def _elevator_obs(obs: dict[str, Any]) -> dict[str, Any]:
    return {
        "current_position": int(obs["current_position"]),
        "n_passengers": int(obs["n_passengers"]),
        "floor_queues": [int(v) for v in obs["floor_queues"]],
        "arrivals": [int(v) for v in obs["arrivals"]],
    }


# -- microgrid -------------------------------------------------------------------------------------


def microgrid() -> dict[str, Any]:
    import gymnasium as gym
    import numpy as np

    from gym4real.envs.microgrid.utils import parameter_generator

    def make() -> Any:
        return gym.make(
            "gym4real/microgrid-v0",
            settings=parameter_generator(world_options="gym4real/envs/microgrid/world_test.yaml"),
        )

    env = make()
    actions = {"only_market": np.array([0]), "battery_first": np.array([1]), "fifty_fifty": np.array([0.5])}
    baselines: dict[str, list[dict[str, Any]]] = {}
    for name, action in actions.items():
        episodes = []
        for profile in range(370, 398):
            env.reset(options={"eval_profile": str(profile)})
            rewards, comps, done = [], {}, False
            while not done:
                _, reward, terminated, truncated, info = env.step(action)
                rewards.append(float(reward))
                for k, v in info["pure_rewards"].items():
                    comps.setdefault(k, []).append(float(v))
                done = terminated or truncated
            episodes.append(_episode_record(rewards, comps, profile=str(profile), soh=float(info["battery"]["soh"])))
            print(name, profile, episodes[-1]["return"], flush=True)
        baselines[name] = _columns(episodes)

    env = make()
    obs, _ = env.reset(options={"eval_profile": "370"})
    prefix = [0.0, 1.0, 0.5, 0.25, 1.0, 1.0, 0.0, 0.75, 1.0, 0.1, 0.9, 1.0]
    steps = [{"obs": _floats(obs)}]
    for a in prefix:
        obs, reward, terminated, truncated, info = env.step(np.array([a]))
        steps.append(
            _step(
                _floats(obs), reward, terminated, truncated, pure={k: float(v) for k, v in info["pure_rewards"].items()}
            )
        )
    return {
        "protocol": "world_test.yaml; 28 episodes, test profiles 370..397 (reset option eval_profile); components: "
        "per-episode sums of info['pure_rewards'] (unweighted, unnormalised) in step order; return: fsum of the "
        "(normalised, weighted) rewards; soh: the battery's at the last step",
        "versions": _versions("gymnasium", "numpy", "pandas", "scipy", "PyYAML"),
        "baselines": baselines,
        "trajectory": {"profile": "370", "actions": prefix, "steps": steps},
    }


# -- trading ---------------------------------------------------------------------------------------


def trading() -> dict[str, Any]:
    import numpy as np

    from gym4real.envs.trading.env import TradingEnv
    from gym4real.envs.trading.utils import parameter_generator

    ticks = _load_sibling("synthetic_ticks")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "histdata"
        ticks.write(folder)

        def make(persistence: int) -> Any:
            params = parameter_generator(
                world_options="gym4real/envs/trading/world_test.yaml",
                data_directory=str(folder),
                years=[ticks.YEAR],
                persistence=persistence,
            )
            with contextlib.redirect_stdout(io.StringIO()):  # the loader prints every month
                env = TradingEnv(params)
            # The reference caches the processed minutes as a CSV in the data folder and later reads that
            # back with pandas' default float parser, which is not correctly rounded: mid prices would move
            # by an ulp from one construction to the next. Every env here processes the tick files.
            (folder / f"dataset_1_min_{params['years']}.csv").unlink()
            return env

        runs: dict[str, Any] = {}
        for persistence in (5, 1):
            env = make(persistence)
            days = [int(d) for d in env.get_days_list()]
            dates = [str(env._data.loc[env._data["day_number"] == d, "datetime"].iloc[0].date()) for d in days]
            baselines: dict[str, list[dict[str, Any]]] = {}
            for name, action in (("buy_and_hold", 2), ("sell_and_hold", 0)):
                env = make(persistence)
                episodes = []
                for date in dates:
                    env.reset()
                    rewards, done = [], False
                    while not done:
                        _, reward, terminated, truncated, _ = env.step(action)
                        rewards.append(float(reward))
                        done = terminated or truncated
                    episodes.append(_episode_record(rewards, {}, day=date))
                baselines[name] = _columns(episodes)
            runs[f"persistence_{persistence}"] = {"days": dates, "baselines": baselines}

        env = make(5)
        obs, _ = env.reset()
        pattern = [2, 2, 1, 0, 0, 2, 1, 1, 0, 2]
        actions = [pattern[k % len(pattern)] for k in range(117)] + [0]  # a reversal at the forced close
        trajectory: dict[str, Any] = {"day": runs["persistence_5"]["days"][0], "actions": actions}
        trajectory["obs"] = [_floats(obs)]  # at the reset, after the first step and after the last
        flags: dict[str, list[Any]] = {"reward": [], "terminated": [], "truncated": []}
        for k, a in enumerate(actions):
            obs, reward, terminated, truncated, _ = env.step(a)
            for key, value in zip(flags, (float(reward), bool(terminated), bool(truncated)), strict=True):
                flags[key].append(value)
            if k == 0 or terminated or truncated:
                trajectory["obs"].append(_floats(obs))
        assert terminated and len(trajectory["obs"]) == 3
        scaler = env.get_scaler()
        trajectory.update(flags)
        trajectory["scaler_min_first"] = float(np.asarray(scaler.data_min_)[0])
        trajectory["scaler_max_first"] = float(np.asarray(scaler.data_max_)[0])
    return {
        "protocol": "synthetic_ticks.py files of 2022; world_test.yaml with years [2022] (sequential days) at "
        "persistence 5 (train/validation/test configs) and 1 (benchmark config); the env fits its own scaler "
        "(scaler=None); every kept day once, in order; return: fsum of the day's rewards",
        "versions": _versions("gymnasium", "numpy", "pandas", "scikit-learn", "PyYAML"),
        **runs,
        "trajectory": trajectory,
    }


# -- wds -------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _epanet_library(path: str | None) -> Iterator[None]:
    """Make the vendored epynet load ``path`` instead of its own ``lib/libepanet.so``."""
    if path is None:
        yield
        return
    original = ctypes.CDLL

    def cdll(name: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(name, str) and name.endswith("lib/libepanet.so"):
            name = path
        return original(name, *args, **kwargs)

    ctypes.CDLL = cdll  # type: ignore[misc]
    try:
        yield
    finally:
        ctypes.CDLL = original  # type: ignore[misc]


def _engine_version(env: Any) -> int:
    lib = env.unwrapped._wn.ep._lib
    v = ctypes.c_int()
    lib.EN_getversion(ctypes.byref(v))
    return int(v.value)


def _parse_offsets(demand: Any, columns: list[str]) -> dict[str, dict[str, list[int]]]:
    """Where the reference's reading of ``test1000.csv`` departs from the correctly rounded values.

    The reference reads the profiles with pandas' default float parser, which is not correctly rounded:
    per column, the hours whose multiplier differs and by how many ulps (the difference of the float64
    bit patterns, parsed minus correctly rounded).
    """
    import numpy as np
    import pandas as pd

    path = Path(demand._data_path, demand._data_config["test"])
    parsed = pd.read_csv(path, index_col=None)  # as WaterDemandPattern.draw_pattern reads it
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    out = {}
    for c in columns:
        k = header.index(c)
        exact = np.array([float(line.split(",")[k]) for line in lines[1:]])
        ulps = parsed[c].to_numpy(dtype=np.float64).view(np.int64) - exact.view(np.int64)
        hours = np.flatnonzero(ulps)
        out[c] = {"hours": hours.tolist(), "ulps": ulps[hours].tolist()}
    return out


class _TankRule:
    """The benchmark notebook's 'Default' rule from the observation (the spec's working version).

    For (P78, T41) and (P79, T42): level < 5 m switches the pump on, level > 8 m off, otherwise it keeps its
    last status; both pumps start open (the network file's initial status); action = 2 P78 + P79.
    """

    def __init__(self) -> None:
        self.pumps = [1, 1]

    def __call__(self, obs: Any) -> int:
        for i in range(2):
            if obs[i] < 5.0:
                self.pumps[i] = 1
            elif obs[i] > 8.0:
                self.pumps[i] = 0
        return 2 * self.pumps[0] + self.pumps[1]


def wds(episodes_per_policy: int, epanet_lib: str | None) -> dict[str, Any]:
    import gymnasium as gym
    import pandas as pd

    from gym4real.envs.wds.utils import parameter_generator

    def make(**kw: Any) -> Any:
        with contextlib.redirect_stdout(io.StringIO()):
            return gym.make("gym4real/wds-v0", settings=parameter_generator(**kw))

    evaluation = {"hydraulic_step": 3600, "duration": 3600 * 24 * 7, "seed": 1234}
    baselines: dict[str, list[dict[str, Any]]] = {}
    version = 0
    with _epanet_library(epanet_lib):
        for name in ("only_78", "only_79", "default"):
            env = make(**evaluation)
            version = _engine_version(env)
            episodes = []
            for _ in range(episodes_per_policy):
                with contextlib.redirect_stdout(io.StringIO()):
                    obs, info = env.reset(options={"is_evaluation": True})
                column = str(info["profile"].name)
                rule = _TankRule()
                rewards, comps, done = [], {}, False
                while not done:
                    action = {"only_78": 2, "only_79": 1}.get(name) or rule(obs)
                    obs, reward, terminated, truncated, info = env.step(action)
                    rewards.append(float(reward))
                    for k, v in info["pure_rewards"].items():
                        comps.setdefault(k, []).append(float(v))
                    done = terminated or truncated
                episodes.append(
                    _episode_record(rewards, comps, test_column=column, elapsed_time=int(info["elapsed_time"]))
                )
                print(name, episodes[-1], flush=True)
            baselines[name] = _columns(episodes)

        # the protocol's ten evaluation columns (the same for every policy: each env reseeds the global state)
        env = make(**evaluation)
        columns = []
        for _ in range(10):
            with contextlib.redirect_stdout(io.StringIO()):
                columns.append(str(env.reset(options={"is_evaluation": True})[1]["profile"].name))

        # training draws (no options) from the constructor's global seed: bucket, file, week column, pattern
        env = make(**evaluation)
        demand = env.unwrapped._demand
        draws = []
        for _ in range(6):
            with contextlib.redirect_stdout(io.StringIO()):
                env.reset()
            pattern = demand.pattern
            files = [
                f
                for f in demand._data_config["train"][demand.pattern_type]
                if pattern.name in (df := pd.read_csv(demand._data_path + f, index_col=0))
                and df[pattern.name].equals(pattern)
            ]
            draws.append(
                {
                    "bucket": str(demand.pattern_type),
                    "files": files,
                    "column": str(pattern.name),
                    "first_values": _floats(pattern.iloc[:6]),
                    "sum": math.fsum(_floats(pattern)),
                }
            )

        # a trajectory on the first evaluation column, fixed actions
        env = make(**evaluation)
        with contextlib.redirect_stdout(io.StringIO()):
            obs, info = env.reset(options={"is_evaluation": True})
        pattern = info["profile"]
        actions = [3, 3, 2, 1, 0, 3, 2, 2, 1, 3, 0, 0, 3, 3, 3, 1, 2, 3]
        steps = [{"obs": _floats(obs)}]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            steps.append(
                _step(
                    _floats(obs),
                    reward,
                    terminated,
                    truncated,
                    elapsed_time=int(info["elapsed_time"]),
                    pure={k: float(v) for k, v in info["pure_rewards"].items()},
                )
            )
    return {
        "protocol": "parameter_generator(hydraulic_step=3600, duration=604800, seed=1234); a fresh env per policy, "
        f"the first {episodes_per_policy} of the protocol's 10 episodes (all 10 take hours on two shared cores), "
        "each reset(options={'is_evaluation': True}) (random test1000 columns from the global NumPy state seeded "
        "by the constructor; evaluation_columns: all ten); default: the notebook's tank-level rule read from the "
        "observation; components: per-episode sums of info['pure_rewards'] in step order; return: fsum of the "
        "rewards (dsr - 0.25 overflow)",
        "versions": {
            **_versions("gymnasium", "numpy", "pandas", "epynet"),
            "epanet_engine": version,
            "epanet_library": epanet_lib or "vendored lib/libepanet.so",
        },
        "evaluation_columns": columns,
        "parsed_multipliers": _parse_offsets(
            demand, sorted({str(pattern.name), *columns[:episodes_per_policy]}, key=int)
        ),
        "baselines": baselines,
        "training_draws": {"settings": "same env, reset() without options, six times", "draws": draws},
        "trajectory": {
            "test_column": str(pattern.name),
            "actions": actions,
            "steps": steps,
        },
    }


# -- output ----------------------------------------------------------------------------------------


def _columns(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """Per-episode records as columns: one list per field (components: one list per component)."""
    out: dict[str, Any] = {}
    for key in episodes[0]:
        if key == "components" and not episodes[0][key]:
            continue
        if key == "components":
            out[key] = {c: [e[key][c] for e in episodes] for c in episodes[0][key]}
        else:
            out[key] = [e[key] for e in episodes]
    return out


def _flat(value: Any) -> bool:
    """A scalar, a list of scalars, or a dict of those: written on one line."""
    if isinstance(value, list):
        return all(not isinstance(v, dict | list) for v in value)
    if isinstance(value, dict):
        return all(not isinstance(v, dict | list) or (isinstance(v, list) and _flat(v)) for v in value.values())
    return True


def _dump(value: Any, indent: int = 0) -> str:
    """JSON with one line per flat container (floats as shortest round-trip repr, so they read back exactly)."""
    if _flat(value) or not value:
        return json.dumps(value, allow_nan=False)
    pad = " " * (indent + 1)
    if isinstance(value, dict):
        items = [f"{pad}{json.dumps(k)}: {_dump(v, indent + 1)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    return "[\n" + ",\n".join(pad + _dump(v, indent + 1) for v in value) + "\n" + " " * indent + "]"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reference", required=True, type=Path, help="root of the extracted reference")
    parser.add_argument("--domain", required=True, choices=DOMAINS)
    parser.add_argument("--commit", default="774d5ce", help="the reference commit, recorded in the fixture")
    parser.add_argument("--epanet-lib", help="wds: EPANET shared library to load instead of the vendored one")
    parser.add_argument("--wds-episodes", type=int, default=3, help="wds: episodes per policy (protocol: 10)")
    parser.add_argument("--out", type=Path, default=HERE, help="folder of the fixtures")
    args = parser.parse_args()

    root = args.reference.resolve()
    sys.path.insert(0, str(root))
    os.chdir(root)  # the reference opens its configs and data by paths relative to its root
    import gym4real  # noqa: F401  (registers the reference's ids)

    if args.domain == "wds":
        data = wds(args.wds_episodes, args.epanet_lib)
    else:
        data = {"dam": dam, "elevator": elevator, "microgrid": microgrid, "trading": trading}[args.domain]()
    record = {"reference": f"Daveonwave/gym4ReaL@{args.commit}", "domain": args.domain, **data}
    path = args.out / f"{args.domain}.json"
    path.write_text(_dump(record) + "\n", encoding="utf-8")
    print(f"wrote {path} ({path.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
