"""The ``gym4real`` command: list, info, bench, record, data, train, reproduce, evaluate, dataset.

One module per command, each with ``add(sub)`` (its arguments) and the function it runs. A command that needs an
extra of gym4real-core (``bench``: measurement, training, publishing) names it before it runs. Errors are printed
as one line (``gym4real: error: ...``) with exit status 2, never a traceback (``--debug`` or
``GYM4REAL_DEBUG=1`` for one, with the traceback of your agent's own exception); an error that documents its own
``exit_status`` (``reproduce --check``: stale, not checkable here, damaged files) exits with that.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

from gym4real.cli import bench, data, dataset, envs, evaluate, record, reproduce, train
from gym4real.core.errors import Gym4RealError
from gym4real.core.install_hint import extra_error, extra_providing, require_extra


class _Versions(argparse.Action):
    """``--version``: every installed gym4real distribution and its version, then exit."""

    def __init__(self, option_strings: Sequence[str], dest: str, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> None:
        from gym4real.core.hookspecs import PLUGIN_API_VERSION
        from gym4real.core.registry import installed_distributions

        for name, version in installed_distributions():
            print(f"{name} {version}" + (f" (plugin API {PLUGIN_API_VERSION})" if name == "gym4real-core" else ""))
        parser.exit()


#: What the command trusts, printed under ``--help``.
TRUST = (
    "Trusted: the installed gym4real plugins (Python packages you installed), and your own code that you name as a "
    "policy `module:attr` (it is imported and run, like a plugin). Data, never run as code: configs, presets, data "
    "files, reference runs, and model files given as ppo:PATH, dqn:PATH, sb3:ALGO:PATH, qlearning:PATH or "
    "sarsa:PATH (an SB3 zip is read without unpickling anything; a pickled entry SB3 does not write for its "
    "algorithm is refused)."
)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="gym4real", description="Realistic RL environments with the Gymnasium API.", epilog=TRUST
    )
    p.add_argument("--version", action=_Versions, help="list the installed gym4real distributions and exit")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in (envs, bench, record, data, train, reproduce, evaluate, dataset):
        command.add(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    args = _parser().parse_args(argv)
    run: Callable[[argparse.Namespace], None] = args.run
    try:
        if args.extra is not None:
            require_extra(args.extra, f"`gym4real {args.command}`")
        run(args)
    except BrokenPipeError:  # the reader went away (`gym4real list | head`): nothing left to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so that the exit flush is quiet
        return 0
    except (Gym4RealError, OSError, ValueError, KeyError, ModuleNotFoundError) as exc:
        if args.debug or os.environ.get("GYM4REAL_DEBUG"):
            raise
        if isinstance(exc, ModuleNotFoundError):  # a library of an extra of core: name the extra; else a bug
            extra = extra_providing(exc.name or "")
            if extra is None:
                raise
            exc = extra_error(extra, f"`gym4real {args.command}`", [str(exc.name)])
        msg = " ".join(str(exc).split())
        print(f"gym4real: error: {msg}", file=sys.stderr)
        return exc.exit_status if isinstance(exc, Gym4RealError) else 2
    return 0
