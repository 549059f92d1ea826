"""Rule-based pump policies of the paper: single pumps and the network's tank-level rule (the expert)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import PolicyError
from gym4real.core.policies import ConstantPolicy


class TankLevelRule:
    """Hysteresis on tank levels, as the ``[CONTROLS]`` of the network file (the paper's *Default* policy).

    For each rule (pump, tank, low, high): the pump opens when the tank's level is below ``low``, closes
    above ``high``, and otherwise keeps its previous status. Levels are read from the observation (tanks
    come first); pumps start at their initial status in the network file; pumps without a rule keep it.

    The rule acts at the env's decisions (hourly), so it approximates the controls: EPANET executing them
    switches a pump the moment its tank crosses a level, the rule at the next decision, and the tanks
    overshoot. Over a week of Anytown test profiles 0-19 the tank levels drift 4.6-7.8 m from EPANET's,
    the DSR up to 0.9 %. The exact expert is the env with ``pump_control="controls"``.

    Args:
        env: The WDS environment; its ``pump_rules`` come from the network file, else from the config.
        levels: ``(low, high)`` in m for every rule instead of its own levels (the multi-objective sweep's
            parameter, :func:`tank_level_rule`); None keeps each rule's.
    """

    def __init__(self, env: gym.Env[Any, Any], levels: tuple[float, float] | None = None) -> None:
        base = env.unwrapped
        net = base.network  # type: ignore[attr-defined]
        self.rules = base.pump_rules  # type: ignore[attr-defined]
        self.initial = list(net.pump_initial_status)
        self.n_pumps = len(net.pump_ids)
        self._pairs = []
        for r in self.rules:
            if r.pump not in net.pump_ids or r.tank not in net.tank_ids:
                msg = (
                    f"tank-level rule ({r.pump}, {r.tank}) does not match the network's pumps {net.pump_ids} and "
                    f"tanks {net.tank_ids}; set `default_rule` in the config"
                )
                raise PolicyError(msg)
            low, high = (r.low, r.high) if levels is None else levels
            self._pairs.append((net.pump_ids.index(r.pump), net.tank_ids.index(r.tank), low, high))
        if levels is not None and not levels[0] < levels[1]:
            raise PolicyError(f"tank-level rule levels {levels}: low must be below high (m)")
        self.status = list(self.initial)

    def reset(self, seed: int | None = None) -> None:
        """Pumps back to their initial status."""
        self.status = list(self.initial)

    def __call__(self, obs: np.ndarray) -> int:
        """Return the action for an observation."""
        for pump, tank, low, high in self._pairs:
            level = obs[tank]
            if level < low:
                self.status[pump] = 1
            elif level > high:
                self.status[pump] = 0
        action = 0
        for s in self.status:
            action = (action << 1) | s
        return action


def _fixed(env: gym.Env[Any, Any], pump: str) -> ConstantPolicy:
    ids = env.unwrapped.network.pump_ids  # type: ignore[attr-defined]
    if pump not in ids:
        raise PolicyError(f"pump `{pump}` is not in this network (pumps: {ids})")
    return ConstantPolicy(1 << (len(ids) - 1 - ids.index(pump)))


def p78(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: only P78 on (action 2 on Anytown)."""
    return _fixed(env, "P78")


def p79(env: gym.Env[Any, Any]) -> ConstantPolicy:
    """Baseline factory: only P79 on (action 1 on Anytown)."""
    return _fixed(env, "P79")


def default(env: gym.Env[Any, Any]) -> TankLevelRule:
    """Baseline factory: the network's tank-level rule (also the expert for imitation learning)."""
    return TankLevelRule(env)


def tank_level_rule(env: gym.Env[Any, Any], low: float, high: float) -> TankLevelRule:
    """Policy factory: the tank-level rule with every pump opening below ``low`` and closing above ``high`` (m).

    ``default`` is ``low=5, high=8``; the multi-objective sweep (:mod:`gym4real.wds.multi_objective`) moves the
    band to trade demand satisfaction against overflow risk.
    """
    return TankLevelRule(env, (float(low), float(high)))


def constant_pumps(env: gym.Env[Any, Any], action: int) -> ConstantPolicy:
    """Policy factory: the same pump combination every hour (``p78`` and ``p79`` are two of the four)."""
    space = env.action_space
    if not space.contains(int(action)):  # type: ignore[arg-type]
        raise PolicyError(f"pump combination {action} is not an action of {space}")
    return ConstantPolicy(int(action))
