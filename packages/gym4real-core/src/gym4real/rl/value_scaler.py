"""skrl's running standardisation of PPO's value targets (the dam preset's ``value_scaler``).

Shared by the SB3 trainer (:mod:`gym4real.rl.skrl_ppo`) and the JAX trainer (:mod:`gym4real.rl.jax_ppo`).
"""

from __future__ import annotations

from typing import Any

import numpy as np


class RunningStandardScaler:
    """skrl's ``RunningStandardScaler`` of one value (its defaults: epsilon 1e-8, clip threshold 5).

    The statistics start at mean 0, variance 1 and count 1, and each batch is merged with the parallel
    variance algorithm, the batch's variance taken with Bessel's correction as ``torch.var`` does.
    """

    def __init__(self, mean: float = 0.0, var: float = 1.0, count: float = 1.0) -> None:
        """Start from saved statistics (a resumed run), else from skrl's initial ones."""
        self.mean, self.var, self.count = float(mean), float(var), float(count)
        self.epsilon, self.clip = 1e-8, 5.0

    def update(self, x: np.ndarray) -> None:
        """Merge a batch of values into the running statistics."""
        n = x.size
        delta = float(np.mean(x)) - self.mean
        total = self.count + n
        m2 = self.var * self.count + float(np.var(x, ddof=1)) * n + delta**2 * self.count * n / total
        self.mean += delta * n / total
        self.var = m2 / total
        self.count = total

    def standardize(self, x: np.ndarray) -> np.ndarray:
        """``clip((x - mean) / (std + epsilon), -5, 5)``."""
        return np.clip((x - self.mean) / (np.sqrt(self.var) + self.epsilon), -self.clip, self.clip).astype(x.dtype)

    def restore(self, x: Any) -> Any:
        """A standardised value (array or torch tensor) back in reward units: ``std * clip(x, -5, 5) + mean``."""
        return self.std * x.clip(-self.clip, self.clip) + self.mean

    @property
    def std(self) -> float:
        """The running standard deviation."""
        return float(np.sqrt(self.var))

    def state(self) -> list[float]:
        """``[mean, var, count]``, as a checkpoint saves them."""
        return [self.mean, self.var, self.count]
