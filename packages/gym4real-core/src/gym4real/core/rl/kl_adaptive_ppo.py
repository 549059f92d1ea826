"""Stable-Baselines3 PPO with skrl's KL-adaptive learning rate (the ``kl_adaptive`` schedule).

skrl's PPO (``agents/torch/ppo/ppo.py`` in skrl 1.4.3) estimates, for each mini-batch before its gradient
step, the KL divergence ``mean((exp(r) - 1) - r)`` with ``r`` the log-ratio of the new and the rollout's
action probabilities, and after each epoch steps ``KLAdaptiveLR`` with the mean over the epoch's
mini-batches. SB3's PPO computes the same estimator at the same point (its ``approx_kl``) but offers no
per-epoch hook: this subclass sees each epoch through the rollout buffer's mini-batch generator, recomputes
the log-probabilities of each mini-batch with the parameters it is about to be trained with (the same numbers
SB3 computes next), and adapts the optimizer's rate when the generator is exhausted, i.e. at the end of the
epoch. Imported only with the ``rl`` extra.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.utils import update_learning_rate

from gym4real.core.rl.schedules import KLAdaptiveRate


class KLAdaptivePPO(PPO):  # type: ignore[misc]
    """PPO whose learning rate follows a :class:`KLAdaptiveRate`, adapted after each epoch."""

    def __init__(self, policy: Any, env: Any, *, rate: KLAdaptiveRate, **kwargs: Any) -> None:
        """Args as :class:`stable_baselines3.PPO`, with ``rate`` in place of ``learning_rate``."""
        self.rate = rate
        #: The mean KL divergence of each epoch so far (the sequence the rate was adapted to).
        self.epoch_kls: list[float] = []
        super().__init__(policy, env, learning_rate=rate, **kwargs)

    def _excluded_save_params(self) -> list[str]:
        # a model file is data: the running rate is a checkpoint's number (state.json), not a pickled object
        return [*super()._excluded_save_params(), "rate", "epoch_kls"]

    def _epoch(self, batches: Iterator[Any]) -> Iterator[Any]:
        """Yield an epoch's mini-batches, each one's KL estimated first; adapt the rate at the end."""
        kls = []
        for batch in batches:
            actions = batch.actions
            if isinstance(self.action_space, spaces.Discrete):
                actions = actions.long().flatten()
            with th.no_grad():
                _, log_prob, _ = self.policy.evaluate_actions(batch.observations, actions)
                log_ratio = log_prob - batch.old_log_prob
                kls.append(float(th.mean((th.exp(log_ratio) - 1) - log_ratio)))
            yield batch
        self.epoch_kls.append(float(np.mean(kls)))
        update_learning_rate(self.policy.optimizer, self.rate.update(self.epoch_kls[-1]))

    def train(self) -> None:
        """PPO's update, the rate adapted after each epoch (SB3 sets it from ``rate`` at the start)."""
        buffer = self.rollout_buffer
        whole_epoch = buffer.get
        setattr(buffer, "get", lambda batch_size=None: self._epoch(whole_epoch(batch_size)))  # noqa: B010
        try:
            super().train()
        finally:
            del buffer.get
        self.logger.record("train/learning_rate", self.rate.rate)
