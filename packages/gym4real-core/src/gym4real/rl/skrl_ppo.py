"""Stable-Baselines3 PPO with the two skrl features of the paper's dam PPO (skrl 1.4.3, ``agents/torch/ppo``).

**KL-adaptive learning rate** (the ``kl_adaptive`` schedule). skrl's PPO estimates, for each mini-batch
before its gradient step, the KL divergence ``mean((exp(r) - 1) - r)`` with ``r`` the log-ratio of the new
and the rollout's action probabilities, and after each epoch steps ``KLAdaptiveLR`` with the mean over the
epoch's mini-batches. SB3's PPO computes the same estimator at the same point (its ``approx_kl``) but offers
no per-epoch hook: :class:`SkrlPPO` sees each epoch through the rollout buffer's mini-batch generator,
recomputes the log-probabilities of each mini-batch with the parameters it is about to be trained with (the
numbers SB3 computes next), and adapts the optimizer's rate when the generator is exhausted: at the end of
the epoch.

**Standardised value targets** (skrl's ``value_preprocessor: RunningStandardScaler``). The value network
predicts standardised values: while collecting a rollout its outputs are mapped back to reward units
(``sqrt(var) * clip(v, -5, 5) + mean``) for the advantages and returns; after the rollout the running
statistics are updated with the rollout's values, then with its returns, and the value loss compares the
network with the standardised returns, as skrl does. Imported only with the ``rl`` extra.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.utils import update_learning_rate

from gym4real.rl.schedules import KLAdaptiveRate
from gym4real.rl.value_scaler import RunningStandardScaler

__all__ = ["RunningStandardScaler", "SkrlPPO"]


class SkrlPPO(PPO):  # type: ignore[misc]
    """PPO with skrl's KL-adaptive rate (``rate``) and/or its standardised value targets (``value_scaler``)."""

    def __init__(
        self,
        policy: Any,
        env: Any,
        *,
        rate: KLAdaptiveRate | None = None,
        value_scaler: RunningStandardScaler | None = None,
        **kwargs: Any,
    ) -> None:
        """Args as :class:`stable_baselines3.PPO`; a ``rate`` takes the place of ``learning_rate``."""
        self.rate = rate
        self.value_scaler = value_scaler
        #: The mean KL divergence of each epoch so far (the sequence the rate was adapted to).
        self.epoch_kls: list[float] = []
        if rate is not None:
            kwargs["learning_rate"] = rate
        super().__init__(policy, env, **kwargs)

    def _excluded_save_params(self) -> list[str]:
        # a model file is data: the running rate and statistics are a checkpoint's numbers (state.json)
        return [*super()._excluded_save_params(), "rate", "value_scaler", "epoch_kls"]

    @contextmanager
    def _values_in_reward_units(self) -> Iterator[None]:
        scaler, policy = self.value_scaler, self.policy
        assert scaler is not None
        forward, predict_values = policy.forward, policy.predict_values

        def restored_forward(obs: Any, deterministic: bool = False) -> Any:
            actions, values, log_prob = forward(obs, deterministic)
            return actions, scaler.restore(values), log_prob

        setattr(policy, "forward", restored_forward)  # noqa: B010
        setattr(policy, "predict_values", lambda obs: scaler.restore(predict_values(obs)))  # noqa: B010
        try:
            yield
        finally:
            del policy.forward, policy.predict_values

    def collect_rollouts(self, env: Any, callback: Any, rollout_buffer: Any, n_rollout_steps: int) -> bool:
        """SB3's rollout; with a value scaler, values in reward units, then the targets standardised."""
        if self.value_scaler is None:
            return bool(super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps))
        with self._values_in_reward_units():
            complete = bool(super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps))
        if complete:  # skrl updates the statistics with the values, then with the returns
            self.value_scaler.update(rollout_buffer.values)
            rollout_buffer.values = self.value_scaler.standardize(rollout_buffer.values)
            self.value_scaler.update(rollout_buffer.returns)
            rollout_buffer.returns = self.value_scaler.standardize(rollout_buffer.returns)
        return complete

    def _epoch(self, batches: Iterator[Any]) -> Iterator[Any]:
        """Yield an epoch's mini-batches, each one's KL estimated first; adapt the rate at the end."""
        assert self.rate is not None
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
        """PPO's update; with a ``rate``, adapted after each epoch (SB3 sets it from ``rate`` at the start)."""
        if self.rate is None:
            super().train()
            return
        buffer = self.rollout_buffer
        whole_epoch = buffer.get
        setattr(buffer, "get", lambda batch_size=None: self._epoch(whole_epoch(batch_size)))  # noqa: B010
        try:
            super().train()
        finally:
            del buffer.get
        self.logger.record("train/learning_rate", self.rate.rate)
