"""``gym4real train``: one RL agent with a registered preset or a YAML preset file."""

from __future__ import annotations

import argparse
from typing import Any

from gym4real.cli.common import ENV_ID_HELP, command


def _train(args: argparse.Namespace) -> None:
    from gym4real.rl.train import train

    run = train(
        args.env_id,
        algo=args.algo,
        preset=args.preset,
        seed=args.seed,
        out=args.out,
        progress=not args.quiet,
        trainer=args.trainer,
        eval_beside=args.eval_beside,
    )
    print(f"model written to {run.model_path}; learning curve in {run.curve_csv}")


def add(sub: Any) -> None:
    """``train``."""
    from gym4real.rl.presets import ALGOS
    from gym4real.rl.train import TRAINERS

    train = command(
        sub, "train", "train an RL agent with a registered preset or a YAML preset file", _train, extra="bench"
    )
    train.add_argument("env_id", help=ENV_ID_HELP)
    train.add_argument("--algo", required=True, choices=ALGOS, help=f"algorithm: {', '.join(ALGOS)}")
    train.add_argument(
        "--trainer",
        default="sb3",
        choices=TRAINERS,
        help="PPO's trainer: sb3 (Stable-Baselines3, the reference) or jax (the `jax` extra; envs with a native "
        "vector env: dam, microgrid, trading)",
    )
    train.add_argument(
        "--eval-beside",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="--trainer jax: run the checkpoint evaluations in a second process beside training, from a snapshot "
        "of the policy (default: when this process may use two cores or more); the curve and the selected model "
        "are the same either way",
    )
    train.add_argument("--preset", default="paper", help="registered preset (paper, smoke) or a YAML file")
    train.add_argument("--seed", type=int, default=0, help="seed of the run (default 0)")
    train.add_argument(
        "--out",
        default=None,
        help="output folder (default runs/<env>/<agent>-<preset>-seed<S>: runs/dam-v0/ppo-paper-seed0, "
        "runs/dam-v0/ppo-jax-paper-seed0 for --trainer jax)",
    )
    train.add_argument("--quiet", action="store_true", help="no progress bar")
