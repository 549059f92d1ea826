"""``gym4real record``: videos (MP4 and GIF) of a policy's episodes."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from gym4real.cli.common import ENV_ID_HELP, command, env_kwargs, user_code_importable


def _record(args: argparse.Namespace) -> None:
    import warnings

    from gym4real.bench.record import NoMp4Warning, record

    user_code_importable()
    with warnings.catch_warnings(record=True) as caught:  # each warning of the recording said in one line
        warnings.simplefilter("always", NoMp4Warning)
        paths = record(
            args.env_id,
            args.policy,
            episodes=args.episodes,
            seed=args.seed,
            out=args.out,
            fps=args.fps,
            env_kwargs=env_kwargs(args.env),
            max_steps=args.max_steps,
            mp4=not args.no_mp4,
            gif_frames=args.gif_frames,
            progress=not args.quiet,
        )
    for warning in caught:
        print(f"gym4real: warning: {warning.message}", file=sys.stderr)
    for path in paths:
        print(f"wrote {path}")


def add(sub: Any) -> None:
    """``record``."""
    rec = command(sub, "record", "write videos (MP4 and animated GIF) of a policy's episodes", _record)
    rec.add_argument("env_id", help=ENV_ID_HELP)
    rec.add_argument("--policy", required=True, help="a baseline name or kind:path model (ppo:runs/x/model.zip)")
    rec.add_argument("--episodes", type=int, default=1, help="episodes, seeded seed, seed + 1, ...")
    rec.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    rec.add_argument("--out", default=str(Path("results") / "videos"), help="output folder (default results/videos)")
    rec.add_argument("--fps", type=float, default=None, help="frames per second (default the env's render_fps)")
    rec.add_argument("--env", action="append", default=[], metavar="KEY=VALUE", help="make() keyword argument")
    rec.add_argument("--max-steps", type=int, default=None, help="cut each episode after this many steps")
    rec.add_argument("--gif-frames", type=int, default=100, help="most frames in the GIF (evenly spaced steps)")
    rec.add_argument("--no-mp4", action="store_true", help="write the GIF only (no MoviePy needed)")
    rec.add_argument("--quiet", action="store_true", help="no progress bar")
