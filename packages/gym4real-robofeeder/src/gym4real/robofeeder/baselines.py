"""Baseline policies: the reference's fixed picking action, an oracle reading the simulator, the pretrained agents.

Factories take the environment (``factory(env) -> policy``); a policy maps an observation to an action.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.datasets import resolve
from gym4real.core.policies import ConstantPolicy
from gym4real.robofeeder._plugin import PICKING_AGENT, PLANNING_AGENT


def fixed(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """The reference's picking baseline: the middle of the action box, (0, 0, 0), at every step."""
    return ConstantPolicy(np.zeros(3, dtype=np.float32))


class OraclePolicy:
    """Reads the true object poses from the simulator (an upper bound the paper does not have).

    Picking: grasps the object nearest the crop (or image) centre at its grasp point (wall centre, 3 mm
    to its outer side) with the gripper aligned to its yaw. Planning: chooses a crop holding a graspable
    object, and idles when none is left.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        self.env: Any = env.unwrapped
        if not hasattr(self.env, "oracle_action"):
            raise TypeError(f"the oracle needs a RoboFeeder environment, not {type(self.env).__name__}")

    def __call__(self, obs: Any) -> Any:
        """The oracle action for the environment's current state (``obs`` is not needed)."""
        return self.env.oracle_action()


def oracle(env: gym.Env[Any, Any]) -> OraclePolicy:
    """Baseline factory: :class:`OraclePolicy`."""
    return OraclePolicy(env)


class PretrainedPolicy:
    """A reference ONNX agent acting on the observation (deterministic: the mean, or the argmax)."""

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        from gym4real.robofeeder.agents import OnnxPickingAgent, OnnxPlanningAgent

        data_dir = env.unwrapped.config.data_dir  # type: ignore[attr-defined]
        if isinstance(env.action_space, gym.spaces.Discrete):
            self.agent: Any = OnnxPlanningAgent(resolve(PLANNING_AGENT, data_dir))
        else:
            self.agent = OnnxPickingAgent(resolve(PICKING_AGENT, data_dir), clip=True)

    def __call__(self, obs: Any) -> Any:
        """The agent's action."""
        return self.agent(obs)


def pretrained(env: gym.Env[Any, Any]) -> PretrainedPolicy:
    """Baseline factory: the reference's pretrained PPO agent for the environment (picking-v0 or planning)."""
    return PretrainedPolicy(env)
