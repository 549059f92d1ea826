"""What every command of ``gym4real`` shares: its sub-command maker, argument types and help texts."""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

from gym4real.core.errors import Gym4RealError

ENV_ID_HELP = "an installed environment id, e.g. gym4real/elevator-v0 (`gym4real list` shows them)"


def command(
    sub: Any, name: str, text: str, run: Callable[[argparse.Namespace], None], extra: str | None = None
) -> argparse.ArgumentParser:
    """A sub-command ``name`` of ``sub`` that runs ``run(args)``; its help is ``text``.

    ``extra``: the extra of gym4real-core it needs (``bench``), checked before it runs (the error names it).
    """
    parser: argparse.ArgumentParser = sub.add_parser(name, help=text, description=text[0].upper() + text[1:] + ".")
    parser.set_defaults(run=run, extra=extra)
    parser.add_argument(
        "--debug", action="store_true", help="on an error, its traceback (and your code's) instead of one line"
    )
    return parser


def env_kwargs(pairs: Sequence[str]) -> dict[str, Any]:
    """``--env KEY=VALUE`` pairs as keyword arguments of ``make()`` (each value read as JSON, else as text)."""
    out: dict[str, Any] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep:
            raise Gym4RealError(f"`--env {pair}` must be KEY=VALUE (the value is read as JSON, else as text)")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def user_code_importable() -> None:
    """Let ``module:attr`` policies name modules of the working folder, as ``python -m`` would."""
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())


def jobs(text: str) -> int:
    """``--jobs``: a positive number, or ``auto`` (the cores available to this process)."""
    from gym4real.bench.versions import available_cpus

    if text == "auto":
        return available_cpus()
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a positive number of jobs or `auto`, not `{text}`")
    return int(text)


def seeds_of(text: str | None) -> int | list[int] | None:
    """``--seeds`` of ``reproduce`` and ``evaluate``: one meaning (:data:`~gym4real.bench.seeds.SeedRequest`)."""
    from gym4real.bench.seeds import parse_seeds

    return None if text is None else parse_seeds(text)
