"""What an agent's own code did wrong, said in one line: the agent, the env, where, what, and the fix.

An agent (``gym4real evaluate NAME=module:attr``, a ``module:attr`` of ``gym4real bench``) is someone else's
code: its factory may raise or return no policy, its policy may raise, act out of the action space (NaN,
another shape, text), or never finish an episode. :func:`blame` turns each of these into one
:class:`AgentError` naming the agent (``name=module:attr``), the env, the training seed, the test episode
and the step, the failure with its type, and the fix. The agent's own exception is the error's
``__cause__`` (its traceback: ``gym4real ... --debug``). Failures of the environment (a missing data file)
are not the agent's, and pass unchanged.

A time limit per episode (:func:`time_limit`, ``--episode-timeout``) interrupts an agent that hangs: with
``SIGALRM``, on the main thread of a POSIX process (elsewhere it is not enforced).
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from gym4real.core.errors import ActionError, ConfigError, PolicyError

#: Where the traceback of the agent's own exception is.
TRACEBACK = "its traceback: rerun with `--debug` (or GYM4REAL_DEBUG=1)"


class AgentError(PolicyError):
    """An agent failed: the message names the agent, the env, where it failed, what, and the fix."""


class PolicyFailure(PolicyError):
    """The policy raised, or acted out of the action space, at a step of an episode (see :func:`run_episode`).

    Args:
        step: The step (0: the first action; ``reset`` when its ``reset(seed)`` failed).
        what: What failed, in words, with the exception's type.
        fix: What to do about it.
    """

    def __init__(self, step: int | str, what: str, fix: str) -> None:
        super().__init__(f"step {step}: {what}; {fix}")
        self.step = step
        self.what = what
        self.fix = fix


class EpisodeTimeout(BaseException):
    """An episode ran past its time limit (raised by the alarm of :func:`time_limit` wherever the run was).

    Attributes:
        seconds: The limit.
        step: The step the episode had reached (set by :func:`~gym4real.bench.benchmark.run_episode`).
    """

    def __init__(self, seconds: float) -> None:
        super().__init__(f"the episode ran past {seconds:g} s")
        self.seconds = seconds
        self.step: int | None = None


def one_line(exc: BaseException) -> str:
    """``RuntimeError: boom``: the exception's type and message on one line."""
    message = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


def action_failure(step: int, exc: ActionError, env: Any) -> PolicyFailure:
    """The policy's action at ``step`` is not in the action space (the env's :class:`ActionError`)."""
    env_id = getattr(getattr(env, "spec", None), "id", None) or "ENV"
    return PolicyFailure(
        step,
        str(exc),
        f"fix: return an action of the action space {env.action_space} (`gym4real info {env_id}` describes it)",
    )


def code_failure(step: int | str, what: str, exc: BaseException) -> PolicyFailure:
    """The policy's own code raised at ``step`` (``what``: ``its policy``, ``its reset(seed)``)."""
    return PolicyFailure(step, f"{what} raised {one_line(exc)}", f"fix the agent ({TRACEBACK})")


def factory_failure(name: str, exc: BaseException, called: str) -> PolicyError:
    """A factory raised when it was called as ``called`` (``factory(env, seed=0)``)."""
    return PolicyError(f"its factory `{name}` raised {one_line(exc)} when called as `{called}`; fix it ({TRACEBACK})")


def agent_label(name: str, ref: object) -> str:
    """How errors name an agent: ``mine=mypkg.agents:make_policy``, a policy string alone, or a callable's name."""
    if isinstance(ref, str):
        return ref if ref == name else f"{name}={ref}"
    if isinstance(ref, (list, tuple)):
        return agent_label(name, ref[0]) if len(ref) == 1 else f"{name} (a set of {len(ref)} policies)"
    qualified = getattr(ref, "__qualname__", None) or type(ref).__name__
    module = getattr(ref, "__module__", None)
    what = f"{module}:{qualified}" if module else qualified
    return what if what == name else f"{name}={what}"


def check_timeout(seconds: float | None) -> None:
    """Refuse a time limit that is not a positive, finite number of seconds (None: no limit).

    Raises:
        ConfigError: Naming the value.
    """
    if seconds is not None and not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds > 0):
        raise ConfigError(f"the episode timeout must be a positive number of seconds, not {seconds!r}")


@contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`EpisodeTimeout` in the block once it has run ``seconds`` (None: no limit).

    The alarm (``SIGALRM``) interrupts the agent even inside one call that never returns; it works on the main
    thread of a POSIX process, and the limit is not enforced elsewhere.
    """
    if seconds is None or not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        yield
        return

    def alarm(signum: int, frame: Any) -> None:
        raise EpisodeTimeout(seconds)

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@contextmanager
def blame(where: str, timeout: float | None = None) -> Iterator[None]:
    """Turn the agent's failures inside the block into one :class:`AgentError` that begins with ``where``.

    Args:
        where: The agent, env and run (``agent `mine=m:f` on `gym4real/dam-v0` (training seed 0), test
            episode 3``).
        timeout: The block's time limit in seconds (:func:`time_limit`), or None.

    Raises:
        AgentError: The policy or factory failed (a :class:`PolicyError` raised inside: a factory's exception,
            a policy that is not callable, an action out of the space, ...), or the block ran past ``timeout``.
    """
    try:
        with time_limit(timeout):
            yield
    except EpisodeTimeout as exc:
        at = f", step {exc.step}" if exc.step is not None else ""
        raise AgentError(
            f"{where}{at}: did not finish within {exc.seconds:g} s (--episode-timeout); fix: make the agent faster, "
            "or give it more time"
        ) from None
    except AgentError:
        raise
    except PolicyError as exc:
        raise AgentError(f"{where}, {exc}" if isinstance(exc, PolicyFailure) else f"{where}: {exc}") from exc
