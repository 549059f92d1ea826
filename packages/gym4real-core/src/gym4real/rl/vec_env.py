"""The in-process vector env SB3 trains on: SB3's ``DummyVecEnv`` without the copy of every step's ``info``.

``DummyVecEnv`` deep-copies the ``info`` of every env at every step; an env with a rich ``info``
(microgrid's nested energy and reward terms) then spends a third of the rollout copying dictionaries that
no learner reads. :class:`TrainingVecEnv` steps the same envs in the same order and returns the same
observations, rewards and dones; its ``info`` dicts hold only what SB3 reads: ``TimeLimit.truncated``,
``terminal_observation`` (a copy) and ``Monitor``'s ``episode`` and ``is_success``.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

#: The ``info`` keys of a single env that SB3's learners and loggers read.
KEPT_INFO = ("episode", "is_success")


class TrainingVecEnv(DummyVecEnv):  # type: ignore[misc]
    """``DummyVecEnv`` whose ``info`` dicts carry only the keys SB3 reads (see the module docstring)."""

    def step_wait(self) -> VecEnvStepReturn:
        """Step every env with its action; an env whose episode ended is reset, as ``DummyVecEnv`` does."""
        for i, env in enumerate(self.envs):
            obs, self.buf_rews[i], terminated, truncated, info = env.step(self.actions[i])
            kept: dict[str, Any] = {k: info[k] for k in KEPT_INFO if k in info}
            kept["TimeLimit.truncated"] = truncated and not terminated
            self.buf_dones[i] = terminated or truncated
            if self.buf_dones[i]:
                kept["terminal_observation"] = copy.deepcopy(obs)
                obs, self.reset_infos[i] = env.reset()
            self.buf_infos[i] = kept
            self._save_obs(i, obs)
        return self._obs_from_buf(), np.copy(self.buf_rews), np.copy(self.buf_dones), list(self.buf_infos)
