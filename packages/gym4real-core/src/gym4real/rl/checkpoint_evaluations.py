"""The JAX trainer's checkpoint evaluations, in-line or beside training in a second process.

At each evaluation point the trainer hands a snapshot of its policy to :class:`CheckpointEvaluations` (a
:class:`~gym4real.rl.actor_critic.Model`: a copy of the parameters and of the observation statistics) and
trains on; it takes the results, in the order the snapshots went, at the next evaluation point and at the
end. Beside training, a worker process (``python -m gym4real.rl.checkpoint_evaluations``, fed through two
pipes: it imports nothing of the caller's, so a script that trains needs no ``if __name__ == "__main__"``
guard) runs the validation episodes in its own :class:`~gym4real.rl.evaluation.BatchEvaluation`; in-line,
this process runs them when the results are taken. Either way each snapshot runs the same seeded episodes
with the same numpy forward pass of the same arrays: the rewards are the same bit for bit, and so are the
learning curve and the selected model.

Evaluations run beside training by default where they can help: when this process may use two cores or
more (on POSIX systems). ``gym4real reproduce --jobs N`` (N > 1) and its Ray runs evaluate in-line: their
runs book every core. The worker stops when told, or when the training process is gone. A worker that dies
(killed, out of memory, an error in the episodes) costs no result: the snapshots it had not answered are
evaluated in-line, and so are the next ones (an error of the episodes themselves is then raised here).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import warnings
from collections import deque
from collections.abc import Iterator
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from gym4real.bench.versions import available_cpus
from gym4real.rl.actor_critic import Model
from gym4real.rl.evaluation import BatchEvaluation


def beside_by_default() -> bool:
    """Whether evaluations run beside training when not told: on POSIX, where this process may use two cores."""
    return os.name == "posix" and available_cpus() >= 2


def serve(requests: Connection, replies: Connection) -> None:
    """The worker: the episodes' arguments, then each snapshot's rewards sent back, until ``None`` or the end."""
    evaluation = None
    try:
        evaluation = BatchEvaluation(*requests.recv())
        while (model := requests.recv()) is not None:
            replies.send(evaluation.run(model))
    except EOFError:  # the training process is gone
        pass
    finally:
        if evaluation is not None:
            evaluation.close()


class CheckpointEvaluations:
    """Evaluations of policy snapshots on the validation episodes, their results taken in order.

    Args:
        env_id: A registered id.
        env_kwargs: Keyword arguments of the validation env.
        episodes: Episodes of one evaluation (episode ``i`` seeded ``seed + i``).
        seed: Seed of episode 0.
        beside: Run them in a worker process beside training (True) or in this process (False).
    """

    def __init__(self, env_id: str, env_kwargs: dict[str, Any], episodes: int, seed: int, beside: bool) -> None:
        self._episodes = (env_id, dict(env_kwargs), episodes, seed)
        self._here: BatchEvaluation | None = None
        self._pending: deque[tuple[int, Model]] = deque()
        self._worker: subprocess.Popen[bytes] | None = None
        if beside:
            request_read, request_write = os.pipe()
            reply_read, reply_write = os.pipe()
            fds = (request_read, reply_write)
            self._worker = subprocess.Popen([sys.executable, "-m", __name__, *map(str, fds)], pass_fds=fds)
            os.close(request_read)
            os.close(reply_write)
            self._requests = Connection(request_write, readable=False)
            self._replies = Connection(reply_read, writable=False)
            self._send(self._episodes)

    @property
    def beside(self) -> bool:
        """Whether they run in a worker process (False once it died: the next ones run in-line)."""
        return self._worker is not None

    def submit(self, timesteps: int, model: Model) -> None:
        """Evaluate ``model`` (a snapshot: it must not change), the policy after ``timesteps`` training steps."""
        self._send(model)
        self._pending.append((timesteps, model))

    def results(self) -> Iterator[tuple[int, Model, list[np.ndarray]]]:
        """Each submitted evaluation's ``(timesteps, model, rewards of each episode)``, in order, waiting for them."""
        while self._pending:
            timesteps, model = self._pending.popleft()
            yield timesteps, model, self._rewards(model)

    def _send(self, message: Any) -> None:
        if self._worker is not None:
            try:
                self._requests.send(message)
            except OSError:  # the worker died (BrokenPipeError)
                self._lost()

    def _rewards(self, model: Model) -> list[np.ndarray]:
        if self._worker is not None:
            try:
                rewards: list[np.ndarray] = self._replies.recv()
                return rewards
            except (EOFError, OSError):
                self._lost()
        if self._here is None:
            self._here = BatchEvaluation(*self._episodes)
        return self._here.run(model)

    def _lost(self) -> None:
        """The worker died: say so, and evaluate in-line from now on."""
        assert self._worker is not None
        code = self._worker.wait()
        warnings.warn(
            f"the evaluation worker died (exit status {code}); evaluating in-line", RuntimeWarning, stacklevel=4
        )
        self._stop()

    def _stop(self) -> None:
        self._requests.close()
        self._replies.close()
        self._worker = None

    def close(self) -> None:
        """Stop the worker (unanswered snapshots are dropped) and close the environments."""
        if self._worker is not None:
            worker = self._worker
            if not self._pending:  # else it may be evaluating, or waiting to send results no one will read
                self._send(None)
            if self._worker is not None:
                try:
                    worker.wait(timeout=0 if self._pending else 10)
                except subprocess.TimeoutExpired:
                    worker.kill()
                    worker.wait()
                self._stop()
        if self._here is not None:
            self._here.close()


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the training process, which closes the pipes
    serve(Connection(int(sys.argv[1]), writable=False), Connection(int(sys.argv[2]), readable=False))
