"""Where RL training time goes: the environment or the learner, per training preset; end-to-end throughput.

For each preset, a short training run (the preset's settings, ``--steps`` environment steps, no evaluation
until the end) is timed, and the same number of steps of the training environment alone (the trainer's
vector env for PPO/DQN, one env for Q-learning/SARSA, random actions). Times are CPU seconds of this
process (``time.process_time``), so that a shared machine's load does not count; both are reported as
environment steps per CPU second, with the environment's share of the training time. For the tabular
presets the compiled loop (after its compilation) and the Python loop are both timed.

With ``--end-to-end``: a short training run with the preset's settings, evaluation included, as a ratio to
the single env's raw step rate (``gymnasium.make``, random actions), all in one process (CPU seconds,
interleaved after an untimed warm-up run: raw, now, before, raw again). The run trains ``--steps`` steps
(PPO's rollouts shortened to fit, ``n_steps * n_envs <= --steps``: the cost a step of the update does not
depend on it) and evaluates at the preset's cadence (``eval_episodes *`` episode length ``/ eval_freq``
evaluation steps per training step, ``eval_freq`` counted in steps of all envs, as the trainer does): every
``eval_freq`` steps, or, where the run is shorter, once at its end with the episodes cut in proportion.
"before" runs the
same with the harness before issue 22 (SB3's ``DummyVecEnv``, one evaluation episode after the other
through ``predict``). Microgrid trains and evaluates on the ``default`` preset (the paper preset's
training households are not in the offline data folder).

With ``--trainers``: PPO's two trainers side by side, SB3 (``--trainer sb3``) and JAX (``--trainer jax``,
:mod:`gym4real.rl.jax_ppo`), on each PPO preset of an env with a native vector env: the rollout and the update
seconds of an iteration (``n_steps * n_envs`` steps; the mean of ``--iterations`` after an untimed one that
compiles), in CPU seconds of this process and in wall seconds, and the ratio of the training steps per CPU
second to the single env's raw step rate (``gymnasium.make``, random actions). Evaluation is left out (the
trainers share it). Microgrid runs on the ``default`` data and trading on its ``hourly`` preset (the paper
presets' data are not in the offline data folder).

With ``--evaluations``: what the JAX trainer's checkpoint evaluations beside training
(:mod:`gym4real.rl.checkpoint_evaluations`) save. For each PPO preset of ``--trainers``, a round is one
evaluation of a snapshot of the policy and the preset's training iterations between two evaluations
(``eval_freq / (n_steps * n_envs)``, rounded); the wall and this process's CPU seconds of a round are timed
in-line (the evaluation, then the iterations) and beside (the snapshot sent to the worker, the iterations,
then its results taken, waiting if they are not in), the mean of ``--iterations`` rounds after an untimed one
(the worker's start, the first calls). The saving per iteration is the difference of a round's seconds
over its iterations: in wall time, and in CPU time of this process (the training process's own work, which
a loaded machine does not inflate). Beside needs a second idle core: on a loaded machine the worker competes
with the other processes and the wall time saves less.
Measured on 2 cores loaded by other jobs (load average 8-15), two rounds each: microgrid's paper preset
(default data; an evaluation, 10 episodes of 8,760 steps, every 4 iterations of 65,536 steps) costs the
training process 3.2-6.6 CPU s per evaluation in-line, 0.8-1.65 CPU s per iteration, of 12-14 CPU s per
round (two runs: in-line 12.1 and 13.9, beside 8.9 and 7.3 CPU s per round); the wall time per round fell
from 60-72 s to 30-37 s (7.6-8.6 s per iteration, inflated by the load). dam's paper preset (13 year-long
episodes every 5 iterations of 2,048 steps) saves nothing measurable: 0.013 CPU s per iteration of about 0.25.

With ``--full-run ENV:ALGO:PRESET``: one whole training run, as ``gym4real train --trainer T`` runs it (its
checkpoint evaluations beside training where the process may use two cores), in a temporary folder: the
wall seconds, and the CPU seconds of this process and of its children (the evaluation worker). Measure on an
idle machine: another process on the second core slows the run. Microgrid's paper preset trains on the
training households' stand-in (``gym4real data synthesize microgrid``) where the real ones are not found.
Measured here (2-core Intel Xeon KVM guest, AVX-512, the other jobs paused), microgrid's paper preset with
``--trainer jax``, seed 42 (28,114,944 steps in 429 iterations, 100 evaluations of 10 year-long episodes
beside), wall time: 11 min 34 s at ``0932e39``; 10 min 4 s at ``89ef46e`` (the epochs' permutations drawn
outside the compiled update); 9 min 58 s and 10 min 56 s at ``aa340a9`` (the learning-curve figure drawn
once; the second with this option: 677 CPU s of training, 330 of evaluations); 11 min 40 s at ``ee4d779``
and 11 min 32 s at ``fc59b5c`` (evaluations in the native batched env: 735 and 173 CPU s); 9 min 22 s at ``65c51fb``
with this option (the rollout's env steps without their ``info``, ``core.vector.step_arrays``: 595 and 164 CPU s;
8 min 3 s as ``gym4real train`` timed alone). Every run before ``65c51fb`` trained
the same model and curve, file for file; the spread is this shared machine's, whose speed moved by about 20 %
within the hour (one idle iteration: 1.05 s, rollout 0.55 and update 0.46, at 00:40; 1.25 s at 02:05). One
iteration alone is about 1.05-1.25 s: the 429 take 450-540 s; the rest is the evaluation worker on the second
core and the start.

    python benchmarks/bench_training.py [--presets gym4real/dam-v0:ppo:paper,...] [--steps 20000]
    python benchmarks/bench_training.py --end-to-end [--steps 16384] [--json out.json]
    python benchmarks/bench_training.py --trainers [--presets gym4real/microgrid-v0:ppo:paper] [--iterations 2]
    python benchmarks/bench_training.py --evaluations [--presets gym4real/dam-v0:ppo:paper] [--iterations 2]
    python benchmarks/bench_training.py --full-run gym4real/microgrid-v0:ppo:paper [--trainer jax] [--seed 42]
"""

from __future__ import annotations

import argparse
import contextlib
import math
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from report import report  # benchmarks/report.py (the script's folder is on sys.path)

import gym4real
from gym4real.bench.seeds import presets
from gym4real.rl.presets import load_preset

DEFAULT = (
    "gym4real/elevator-v0:qlearning:paper,gym4real/elevator-v0:sarsa:paper,gym4real/dam-v0:ppo:paper,"
    "gym4real/trading-v0:ppo:hourly,gym4real/trading-v0:dqn:hourly"
)


def _env_only(env_id: str, hp: dict[str, Any], steps: int) -> float:
    """CPU seconds of ``steps`` environment steps as the trainer makes its env (random actions)."""
    if hp["algo"] in ("qlearning", "sarsa"):
        env = gym.make(env_id, **hp["env_kwargs"])
        env.reset(seed=0)
        actions = np.random.default_rng(0).integers(env.action_space.n, size=steps)
        start = time.process_time()
        for a in actions:
            *_, terminated, truncated, _ = env.step(int(a))
            if terminated or truncated:
                env.reset()
        return time.process_time() - start
    from stable_baselines3.common.env_util import make_vec_env

    from gym4real.rl.sb3 import _rescale

    venv = make_vec_env(
        env_id,
        n_envs=hp["n_envs"],
        seed=0,
        env_kwargs={"render_mode": None, **hp["env_kwargs"]},
        wrapper_class=_rescale,
    )
    venv.reset()
    venv.action_space.seed(0)
    actions = [
        np.array([venv.action_space.sample() for _ in range(venv.num_envs)]) for _ in range(steps // venv.num_envs)
    ]
    start = time.process_time()
    for a in actions:
        venv.step(a)
    return time.process_time() - start


def _train(env_id: str, hp: dict[str, Any], steps: int, compiled: bool | None) -> tuple[float, int]:
    """CPU seconds and environment steps of a short training run with the preset's settings."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.process_time()
        if hp["algo"] in ("qlearning", "sarsa"):
            from gym4real.rl.tabular import train_tabular

            horizon = gym.make(env_id, **hp["env_kwargs"]).unwrapped.config.duration
            short = {**hp, "episodes": max(1, steps // horizon), "eval_every": 10**9, "eval_episodes": 1}
            _, counts = train_tabular(env_id, short, 0, Path(tmp), compiled=compiled)
        else:
            from gym4real.rl.sb3 import train_sb3

            short = {**hp, "total_timesteps": steps, "eval_freq": 10**9, "eval_episodes": 1}
            _, counts = train_sb3(env_id, short, 0, Path(tmp))
        return time.process_time() - start, counts["train"]


#: The end-to-end presets, with the env arguments the benchmark trains and evaluates on.
END_TO_END = {
    "gym4real/microgrid-v0:ppo:paper": {"preset": "default"},
    "gym4real/dam-v0:ppo:paper": None,
    "gym4real/wds-v0:dqn:paper": None,
    "gym4real/trading-v0:ppo:hourly": None,
}


def _raw_rate(env_id: str, kwargs: dict[str, Any], steps: int) -> float:
    """Steps per CPU second of the single env from ``gymnasium.make`` (random actions drawn beforehand)."""
    env = gym.make(env_id, **kwargs)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    start = time.process_time()
    for a in actions:
        *_, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    cpu = time.process_time() - start
    env.close()
    return steps / cpu


def _episode_length(env_id: str, kwargs: dict[str, Any], seed: int) -> int:
    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    n, done = 0, False
    while not done:
        *_, terminated, truncated, _ = env.step(env.action_space.sample())
        n, done = n + 1, terminated or truncated
    env.close()
    return n


@contextlib.contextmanager
def _before_issue_22() -> Iterator[None]:
    """The training harness as it was: SB3's DummyVecEnv, evaluation episodes one at a time through ``predict``."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from gym4real.bench.benchmark import run_episode
    from gym4real.rl import evaluation, vec_env

    class OneAtATime(evaluation.BatchEvaluation):
        def __init__(self, env_id: str, env_kwargs: dict[str, Any], episodes: int, seed: int) -> None:
            super().__init__(env_id, env_kwargs, 1, seed, native=False)
            self.episodes = episodes

        def run(self, policy: Any) -> list[np.ndarray]:
            env = self.envs[0]
            return [run_episode(env, policy, self.seed + i, None)["rewards"] for i in range(self.episodes)]

    saved = evaluation.BatchEvaluation, vec_env.TrainingVecEnv
    evaluation.BatchEvaluation, vec_env.TrainingVecEnv = OneAtATime, DummyVecEnv  # type: ignore[misc]
    try:
        yield
    finally:
        evaluation.BatchEvaluation, vec_env.TrainingVecEnv = saved  # type: ignore[misc]


def _end_to_end(item: str, env_kwargs: dict[str, Any] | None, steps: int, raw_steps: int) -> dict[str, Any]:
    from gym4real.rl.sb3 import train_sb3

    env_id, algo, preset = item.split(":")
    hp = load_preset(env_id, algo, preset)
    train_kwargs = env_kwargs if env_kwargs is not None else hp["env_kwargs"]
    eval_kwargs = env_kwargs if env_kwargs is not None else (hp.get("eval_env_kwargs") or hp["env_kwargs"])
    episodes, freq = int(hp["eval_episodes"]), int(hp["eval_freq"])
    full = _episode_length(env_id, eval_kwargs, int(hp["eval_seed"]))
    every = steps // math.ceil(steps / freq)  # evaluations spread evenly over the run, as often as the preset's
    length = max(1, min(full, round(full * every / freq)))  # shorter episodes where `every` < `freq`
    hyper = dict(hp["hyperparams"])
    if algo == "ppo":
        per_env = min(hyper["n_steps"], steps // hp["n_envs"])
        hyper["n_steps"] = per_env
        hyper["batch_size"] = math.gcd(hyper["batch_size"], per_env * hp["n_envs"])
    short = {
        **hp,
        "hyperparams": hyper,
        "total_timesteps": steps,
        "eval_freq": every,
        "env_kwargs": train_kwargs,
        "eval_env_kwargs": {**eval_kwargs, "max_episode_steps": length},
    }
    with tempfile.TemporaryDirectory() as tmp:  # warm-up (first torch calls, data caches): not timed
        train_sb3(env_id, {**short, "total_timesteps": 1}, 0, Path(tmp))
    raw = [_raw_rate(env_id, train_kwargs, raw_steps)]
    rates, counts = {}, {}
    for label in ("now", "before"):
        harness = _before_issue_22() if label == "before" else contextlib.nullcontext()
        with tempfile.TemporaryDirectory() as tmp, harness:
            start = time.process_time()
            _, counts = train_sb3(env_id, short, 0, Path(tmp))
            rates[label] = counts["train"] / (time.process_time() - start)
    raw.append(_raw_rate(env_id, train_kwargs, raw_steps))
    raw_rate = float(np.mean(raw))
    return {
        "preset": item,
        "raw steps/CPU s": raw_rate,
        "preset's eval steps per train step": episodes * full / freq,
        "eval steps per train step": counts["eval"] / counts["train"],
        "train steps/CPU s": rates["now"],
        "ratio": rates["now"] / raw_rate,
        "before: train steps/CPU s": rates["before"],
        "before: ratio": rates["before"] / raw_rate,
        "speed-up": rates["now"] / rates["before"],
    }


#: The presets of ``--trainers`` (PPO on the envs with a native vector env), with the env arguments they train on.
TRAINERS = {
    "gym4real/microgrid-v0:ppo:paper": {"preset": "default"},
    "gym4real/dam-v0:ppo:paper": None,
    "gym4real/trading-v0:ppo:hourly": None,  # the paper preset's tick data is not in the offline data folder
}


class _Clock:
    """CPU and wall seconds of the blocks timed with :meth:`time`, summed per name."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = {}
        self.wall: dict[str, float] = {}

    @contextlib.contextmanager
    def time(self, name: str) -> Iterator[None]:
        cpu, wall = time.process_time(), time.perf_counter()
        yield
        self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - cpu
        self.wall[name] = self.wall.get(name, 0.0) + time.perf_counter() - wall


def _sb3_iterations(env_id: str, hp: dict[str, Any], iterations: int) -> _Clock:
    """Rollouts and updates of SB3's PPO as :func:`gym4real.rl.sb3.train_sb3` builds it (the first untimed)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    from gym4real.rl.sb3 import _algorithm, _rescale, _sb3
    from gym4real.rl.vec_env import TrainingVecEnv

    _sb3()  # torch on one thread
    venv = make_vec_env(
        env_id,
        n_envs=hp["n_envs"],
        seed=0,
        env_kwargs={"render_mode": None, **hp["env_kwargs"]},
        vec_env_cls=TrainingVecEnv,
        wrapper_class=_rescale,
    )
    if hp.get("normalize_obs"):
        gamma = hp["hyperparams"].get("gamma", 0.99)
        venv = VecNormalize(venv, norm_obs=True, norm_reward=False, clip_obs=hp["clip_obs"], gamma=gamma)
    model = _algorithm(PPO, hp, venv, 0, None)
    total, callback = model._setup_learn(hp["total_timesteps"], callback=None)
    clock = _Clock()
    for i in range(iterations + 1):
        timed = clock.time if i else lambda name: contextlib.nullcontext()
        with timed("rollout"):
            model.collect_rollouts(model.env, callback, model.rollout_buffer, model.n_steps)
        model._update_current_progress_remaining(model.num_timesteps, total)
        with timed("update"):
            model.train()
    venv.close()
    return clock


def _jax_iterations(env_id: str, hp: dict[str, Any], iterations: int) -> _Clock:
    """Rollouts and updates of the JAX trainer (the first, which compiles, untimed)."""
    from gym4real.rl.jax_ppo import JaxPPO

    trainer = JaxPPO(env_id, hp, 0)
    trainer.start_episodes()
    clock = _Clock()
    for i in range(iterations + 1):
        timed = clock.time if i else lambda name: contextlib.nullcontext()
        with timed("rollout"):
            data = trainer.collect()
        with timed("update"):
            trainer.learn(data)
    trainer.close()
    return clock


def _trainers(item: str, env_kwargs: dict[str, Any] | None, iterations: int, raw_steps: int) -> list[dict[str, Any]]:
    env_id, algo, preset = item.split(":")
    hp = load_preset(env_id, algo, preset)
    if env_kwargs is not None:
        hp = {**hp, "env_kwargs": env_kwargs}
    steps = hp["hyperparams"]["n_steps"] * hp["n_envs"]
    clocks = {"sb3": _sb3_iterations(env_id, hp, iterations), "jax": _jax_iterations(env_id, hp, iterations)}
    raw = _raw_rate(env_id, hp["env_kwargs"], raw_steps)
    rows = []
    for trainer, clock in clocks.items():
        rollout, update = clock.cpu["rollout"] / iterations, clock.cpu["update"] / iterations
        rows.append(
            {
                "preset": item,
                "trainer": trainer,
                "steps/iteration": steps,
                "rollout CPU s": rollout,
                "update CPU s": update,
                "rollout wall s": clock.wall["rollout"] / iterations,
                "update wall s": clock.wall["update"] / iterations,
                "train steps/CPU s": steps / (rollout + update),
                "raw steps/CPU s": raw,
                "ratio": steps / (rollout + update) / raw,
            }
        )
    return rows


def _evaluation_rounds(item: str, env_kwargs: dict[str, Any] | None, rounds: int) -> dict[str, Any]:
    """Wall and CPU seconds of rounds of an evaluation and the iterations between two, in-line and beside."""
    from gym4real.rl.checkpoint_evaluations import CheckpointEvaluations
    from gym4real.rl.jax_ppo import JaxPPO

    env_id, algo, preset = item.split(":")
    hp = load_preset(env_id, algo, preset)
    eval_kwargs = hp.get("eval_env_kwargs") or hp["env_kwargs"]
    if env_kwargs is not None:
        hp = {**hp, "env_kwargs": env_kwargs}
        eval_kwargs = {**eval_kwargs, **env_kwargs}
    steps = hp["hyperparams"]["n_steps"] * hp["n_envs"]
    between = max(1, round(hp["eval_freq"] / steps))
    trainer = JaxPPO(env_id, hp, 0)
    trainer.start_episodes()
    trainer.iteration()  # compiles
    row: dict[str, Any] = {"preset": item, "iterations between evaluations": between}
    for mode in ("in-line", "beside"):
        evaluations = CheckpointEvaluations(
            env_id, eval_kwargs, hp["eval_episodes"], hp["eval_seed"], beside=mode == "beside"
        )
        clock = _Clock()
        for r in range(rounds + 1):
            timed = clock.time if r else lambda name: contextlib.nullcontext()
            with timed("round"):
                evaluations.submit(trainer.timesteps, trainer.model())
                if mode == "in-line":  # in-line, the results are computed when taken: take them first
                    list(evaluations.results())
                for _ in range(between):
                    trainer.iteration()
                list(evaluations.results())
        evaluations.close()
        row[f"{mode} wall s/round"] = clock.wall["round"] / rounds
        row[f"{mode} CPU s/round"] = clock.cpu["round"] / rounds
    trainer.close()
    row["saved wall s/iteration"] = (row["in-line wall s/round"] - row["beside wall s/round"]) / between
    row["saved CPU s/iteration"] = (row["in-line CPU s/round"] - row["beside CPU s/round"]) / between
    return row


def _full_run(item: str, trainer: str, seed: int) -> dict[str, Any]:
    """One whole training run of ``item`` by ``trainer``: its wall and CPU seconds (this process, its children)."""
    import resource

    from gym4real.bench.versions import available_cpus, cpu_model
    from gym4real.rl.train import train

    env_id, algo, preset = item.split(":")
    before = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        run = train(env_id, algo, preset, seed=seed, out=Path(folder) / "run", trainer=trainer)
        wall = time.perf_counter() - start
    after = [resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    cpu = [(a.ru_utime + a.ru_stime) - (b.ru_utime + b.ru_stime) for a, b in zip(after, before, strict=True)]
    return {
        "preset": item,
        "trainer": trainer,
        "seed": seed,
        "train steps": run.env_steps,
        "eval steps": run.eval_steps,
        "wall s": wall,
        "wall min": wall / 60,
        "CPU s (this process)": cpu[0],
        "CPU s (children: evaluations beside)": cpu[1],
        "machine": f"{cpu_model()}, {available_cpus()} cores",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=None, help="comma-separated ENV:ALGO:PRESET")
    parser.add_argument("--steps", type=int, default=None, help="environment steps per measurement")
    parser.add_argument("--end-to-end", action="store_true", help="training throughput with evaluation")
    parser.add_argument("--json", help="(--end-to-end, --trainers) also write the rows to this JSON file")
    parser.add_argument("--trainers", action="store_true", help="PPO's SB3 and JAX trainers side by side")
    parser.add_argument("--evaluations", action="store_true", help="JAX: checkpoint evaluations in-line and beside")
    parser.add_argument(
        "--iterations", type=int, default=2, help="(--trainers) timed iterations per trainer; (--evaluations) rounds"
    )
    parser.add_argument("--full-run", metavar="ENV:ALGO:PRESET", help="one whole training run, timed")
    parser.add_argument("--trainer", default="jax", choices=["sb3", "jax"], help="(--full-run) PPO's trainer")
    parser.add_argument("--seed", type=int, default=42, help="(--full-run) the run's seed")
    args = parser.parse_args()
    gym4real.register_envs()
    if args.full_run:
        row = _full_run(args.full_run, args.trainer, args.seed)
        report([row], list(row), 4, args.json)
        return
    if args.trainers:
        items = args.presets.split(",") if args.presets else list(TRAINERS)
        rows = [r for item in items for r in _trainers(item, TRAINERS.get(item), args.iterations, 20_000)]
        report(rows, list(rows[0]), 3, args.json)
        return
    if args.evaluations:
        items = args.presets.split(",") if args.presets else list(TRAINERS)
        rows = [_evaluation_rounds(item, TRAINERS.get(item), args.iterations) for item in items]
        report(rows, list(rows[0]), 3, args.json)
        return
    if args.end_to_end:
        items = args.presets.split(",") if args.presets else list(END_TO_END)
        steps = args.steps or 16_384
        rows = [_end_to_end(item, END_TO_END.get(item), steps, min(steps, 20_000)) for item in items]
        report(rows, list(rows[0]), 3, args.json)
        return
    args.presets, args.steps = args.presets or DEFAULT, args.steps or 20_000
    print("preset | loop | train steps/CPU s | env-only steps/CPU s | env share of training")
    print("--- | --- | --- | --- | ---")
    for item in args.presets.split(","):
        env_id, algo, preset = item.split(":")
        if preset not in presets(env_id, "paper").values() and preset not in ("paper", "smoke"):
            raise SystemExit(f"unknown preset {item}")
        hp = load_preset(env_id, algo, preset)
        env_cpu = _env_only(env_id, hp, args.steps)
        loops = [True, False] if algo in ("qlearning", "sarsa") else [None]
        if True in loops:
            _train(env_id, hp, 1, True)  # compile the loop first (numba)
        for compiled in loops:
            cpu, n = _train(env_id, hp, args.steps, compiled)
            loop = {True: "compiled", False: "python", None: "sb3"}[compiled]
            share = "- (compiled dynamics)" if compiled else f"{env_cpu / args.steps * n / cpu:.0%}"
            print(f"{item} | {loop} | {n / cpu:.4g} | {args.steps / env_cpu:.4g} | {share}")


if __name__ == "__main__":
    main()
