"""The JAX trainer's checkpoint evaluations, in-line or beside training in a second process.

At each evaluation point the trainer hands a snapshot of its policy to :class:`CheckpointEvaluations` (a
:class:`~gym4real.rl.actor_critic.Model`: a copy of the parameters and of the observation statistics) and
trains on; it takes the results, in the order the snapshots went, at the next evaluation point and at the
end. Beside training, a worker process (started with ``spawn``) runs the validation episodes in its own
:class:`~gym4real.rl.evaluation.BatchEvaluation`; in-line, this process runs them when the results are
taken. Either way each snapshot runs the same seeded episodes with the same numpy forward pass of the same
arrays: the rewards are the same bit for bit, and so are the learning curve and the selected model.

Evaluations run beside training by default where they can help: when this process may use two cores or
more and is not itself a daemonic worker (those of ``gym4real reproduce --jobs N``, which book the cores
and may not start processes). A worker that dies (killed, out of memory, an error in the episodes) costs
no result: the snapshots it had not answered are evaluated in-line, and so are the next ones (an error of
the episodes themselves is then raised here).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import warnings
from collections import deque
from collections.abc import Iterator
from typing import Any

import numpy as np

from gym4real.bench.versions import available_cpus
from gym4real.rl.actor_critic import Model
from gym4real.rl.evaluation import BatchEvaluation


def beside_by_default() -> bool:
    """Whether evaluations run beside training when not told: two cores or more, and not a daemonic worker."""
    return available_cpus() >= 2 and not multiprocessing.current_process().daemon


def _serve(connection: Any, env_id: str, env_kwargs: dict[str, Any], episodes: int, seed: int) -> None:
    """The worker process: evaluate each snapshot it receives and send back its rewards, until ``None``."""
    evaluation = BatchEvaluation(env_id, env_kwargs, episodes, seed)
    try:
        while (model := connection.recv()) is not None:
            connection.send(evaluation.run(model))
    finally:
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
        self._worker: Any = None
        if beside:
            context = multiprocessing.get_context("spawn")
            self._connection, child = context.Pipe()
            self._worker = context.Process(target=_serve, args=(child, *self._episodes), daemon=True)
            self._worker.start()
            child.close()

    @property
    def beside(self) -> bool:
        """Whether they run in a worker process (False once it died: the next ones run in-line)."""
        return self._worker is not None

    def submit(self, timesteps: int, model: Model) -> None:
        """Evaluate ``model`` (a snapshot: it must not change), the policy after ``timesteps`` training steps."""
        if self._worker is not None:
            try:
                self._connection.send(model)
            except OSError:  # the worker died (BrokenPipeError)
                self._lost()
        self._pending.append((timesteps, model))

    def results(self) -> Iterator[tuple[int, Model, list[np.ndarray]]]:
        """Each submitted evaluation's ``(timesteps, model, rewards of each episode)``, in order, waiting for them."""
        while self._pending:
            timesteps, model = self._pending.popleft()
            yield timesteps, model, self._rewards(model)

    def _rewards(self, model: Model) -> list[np.ndarray]:
        if self._worker is not None:
            try:
                rewards: list[np.ndarray] = self._connection.recv()
                return rewards
            except (EOFError, OSError):
                self._lost()
        if self._here is None:
            self._here = BatchEvaluation(*self._episodes)
        return self._here.run(model)

    def _lost(self) -> None:
        """The worker died: say so, and evaluate in-line from now on."""
        self._worker.join()
        warnings.warn(
            f"the evaluation worker died (exit code {self._worker.exitcode}); evaluating in-line",
            RuntimeWarning,
            stacklevel=3,
        )
        self._connection.close()
        self._worker = None

    def close(self) -> None:
        """Stop the worker (unanswered snapshots are dropped) and close the environments."""
        if self._worker is not None:
            if not self._pending:  # else it may be evaluating, or waiting to send results no one will read
                with contextlib.suppress(OSError):
                    self._connection.send(None)
                self._worker.join(timeout=10)
            if self._worker.is_alive():
                self._worker.kill()
                self._worker.join()
            self._connection.close()
            self._worker = None
        if self._here is not None:
            self._here.close()
