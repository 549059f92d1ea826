"""The hindsight planner of WDSEnv: a non-causal upper reference that knows the week's demand.

At the first decision of an episode the planner reads the week's demand multipliers, which no agent knows
in advance, and searches the pump schedules through the env's own hydraulics: copies of the env (EPANET
via the same engine, the same network, configuration and demand) run in lockstep, hour by hour. A search
node is the tanks' levels after an hour (the network's only state between hours: the next action sets
the pumps); each hour every node of the beam is expanded with every action, each child simulated for the
hour by one copy restored to its parent's levels, and the ``width`` best children by return so far are
kept, one per cell of ``resolution`` metres of tank levels (children in one cell have the same future up
to the cell's size). Ties, frequent where every hour scores its full DSR, go to the child with the most
water below the overflow threshold (the buffer for the hours to come).

The best schedule found is replayed from the start through a fresh copy, as are the rule-based schedules
(each pump alone, the tank-level rule); the planner keeps whichever scores best and plays it.
``planned_objective`` is the search's return of the kept schedule (restoring a copy re-starts EPANET's
solver from other link flows, so it can differ from the replay in the last digits), ``replayed_objective``
the env's score of it.

Given ``weights`` over the objectives of ``gym4real/wds-mo-v0`` (dsr, overflow:
:mod:`gym4real.wds.multi_objective`), the search, the replays and the choice of schedule score the weighted
objective instead, ``w_dsr * dsr + w_overflow * overflow`` hour by hour (:func:`weighted_hindsight`, the
factory of the multi-objective upper reference front). Without weights (the default) nothing changes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import PolicyError
from gym4real.core.policies import ConstantPolicy
from gym4real.wds import engine as en
from gym4real.wds.baselines import TankLevelRule
from gym4real.wds.env import WDSEnv
from gym4real.wds.multi_objective import SPECS
from gym4real.wrappers.multi_objective import scalar_env

#: Search nodes kept per hour.
WIDTH = 8
#: Tank-level cell (m) within which search nodes are merged.
RESOLUTION = 0.05


class _Node:
    """A search node: the tanks' levels after some hours, the return so far and the actions taken."""

    __slots__ = ("actions", "levels", "value")

    def __init__(self, levels: np.ndarray, value: float, actions: tuple[int, ...]) -> None:
        self.levels = levels
        self.value = value
        self.actions = actions


class WDSHindsight:
    """Baseline ``hindsight``: beam search over pump schedules knowing the week's demand, then play the schedule.

    Args:
        env: The WDS env (wrapped or not), fixed decision intervals, pumps switched by the agent.
        width: Search nodes kept per hour.
        resolution: Tank-level cell (m) within which nodes are merged.
        weights: Plan the weighted objective of ``gym4real/wds-mo-v0`` (one non-negative weight per
            objective: dsr, overflow) instead of the protocol's; None: the protocol's.

    Raises:
        PolicyError: The env is not a WDSEnv with fixed intervals and agent-switched pumps, or a bad argument.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        width: int = WIDTH,
        resolution: float = RESOLUTION,
        weights: Sequence[float] | None = None,
    ) -> None:
        base = scalar_env(env)  # wds-mo-v0 included
        if not isinstance(base, WDSEnv):
            raise PolicyError(f"the WDS hindsight planner needs a WDSEnv, not {type(base).__name__}")
        if not base._fixed or base.config.pump_control != "agent":
            msg = (
                "the WDS hindsight planner plans fixed decision intervals with pumps switched by the agent; make "
                "the env with fixes={'fixed_interval': True} and pump_control='agent'"
            )
            raise PolicyError(msg)
        if width < 1 or not resolution > 0:
            raise PolicyError(f"`width` must be >= 1 and `resolution` > 0, not {width} and {resolution}")
        self.env = base
        self.width = width
        self.resolution = resolution
        self.weights = None if weights is None else tuple(float(w) for w in weights)
        self._component_weights = None if weights is None else SPECS[0].component_weights(weights)
        self.schedule: tuple[int, ...] | None = None
        self.source = ""
        self.planned_objective = math.nan
        self.replayed_objective = math.nan
        self.candidates: dict[str, float] = {}
        self._copies: list[WDSEnv] = []

    @property
    def gap(self) -> float:
        """Planned minus replayed objective of the kept schedule."""
        return self.planned_objective - self.replayed_objective

    def reset(self, seed: int | None = None) -> None:
        """Forget the schedule: the next call plans the new episode."""
        self.schedule = None

    def __call__(self, obs: np.ndarray) -> int:
        """The schedule's action for the coming interval."""
        env = self.env
        if self.schedule is None or env._t == 0:
            self._plan()
        assert self.schedule is not None
        return self.schedule[env._t // env.config.decision_interval]

    def close(self) -> None:
        """Release the copies' EPANET projects."""
        for sim in self._copies:
            sim.close()
        self._copies = []

    # -- planning ------------------------------------------------------------------------------------

    def _plan(self) -> None:
        env = self.env
        if env._t != 0:
            raise PolicyError("the WDS hindsight planner plans from the start of an episode; call it from the reset on")
        searched, planned = self._search()
        candidates: dict[str, tuple[tuple[int, ...], float]] = {"search": (searched, planned)}
        for name, rule in self._rules().items():
            schedule = self._rollout(rule)
            candidates[name] = (schedule, math.nan)
        scores = {name: self._replay(schedule) for name, (schedule, _) in candidates.items()}
        self.candidates = scores
        self.source = max(scores, key=lambda k: scores[k])
        self.schedule, planned_value = candidates[self.source]
        self.replayed_objective = scores[self.source]
        self.planned_objective = planned_value if self.source == "search" else scores[self.source]

    def _pool(self, n: int) -> list[WDSEnv]:
        """``n`` copies of the env reset to the episode's demand, at t = 0."""
        env = self.env
        while len(self._copies) < n:
            sim = WDSEnv(env.config)
            self._copies.append(sim)
        pattern = env._pattern / env._scales["demand"]
        for sim in self._copies[:n]:
            sim.perturb(env._scales)
            sim.reset(options={"pattern": pattern})
        return self._copies[:n]

    def _objective(self, info: dict[str, Any]) -> float:
        if self._component_weights is None:
            return step_return(info)
        of = self._component_weights
        return float(sum(of.get(c, 0.0) * v for c, v in info["reward_components"].items()))

    def _search(self) -> tuple[tuple[int, ...], float]:
        """The beam search over the week: the best schedule and its return in the search."""
        env = self.env
        sims = self._pool(self.width * 2 ** len(env.network.pump_ids))
        return beam_search(sims, sims[0]._levels, env._decisions, self._objective, self.width, self.resolution)

    def _rules(self) -> dict[str, Callable[[np.ndarray], int]]:
        """The rule-based schedules replayed as candidates: each pump alone and the tank-level rule."""
        env = self.env
        n_pumps = len(env.network.pump_ids)
        rules: dict[str, Callable[[np.ndarray], int]] = {}
        for k, pump in enumerate(env.network.pump_ids):
            action = 1 << (n_pumps - 1 - k)
            rules[pump] = ConstantPolicy(action)
        if env.pump_rules:
            rule = TankLevelRule(env)
            rules["tank-level rule"] = rule
        return rules

    def _rollout(self, policy: Callable[[np.ndarray], int]) -> tuple[int, ...]:
        """The schedule a (causal) rule plays on the episode."""
        sim = self._pool(1)[0]
        reset = getattr(policy, "reset", None)
        if reset is not None:
            reset(None)
        obs = sim._obs
        actions = []
        for _ in range(self.env._decisions):
            a = int(policy(obs))
            actions.append(a)
            obs, _, _, truncated, _ = sim.step(a)
            if truncated:
                break
        return tuple(actions)

    def _replay(self, schedule: Sequence[int]) -> float:
        """The objective of a schedule played from the start through a fresh copy."""
        sim = self._pool(1)[0]
        total = 0.0
        for a in schedule:
            _, _, _, truncated, info = sim.step(a)
            total += self._objective(info)
            if truncated:
                break
        return total


def step_return(info: dict[str, Any]) -> float:
    """A step's reward from its ``info``: the sum of its reward components (the protocol's objective)."""
    return float(sum(info["reward_components"].values()))


def beam_search(
    sims: Sequence[WDSEnv],
    levels: np.ndarray,
    hours: int,
    objective: Callable[[dict[str, Any]], float],
    width: int = WIDTH,
    resolution: float = RESOLUTION,
) -> tuple[tuple[int, ...], float]:
    """The beam search of the module docstring: the best schedule of ``hours`` decisions and its return.

    Args:
        sims: ``width * 2**P`` copies of the env (P pumps) at one time with one demand; all of them step every
            decision, so that they keep one clock.
        levels: The tanks' levels (m) the search starts from.
        hours: Decisions to plan.
        objective: A step's score from its ``info``.
        width: Search nodes kept per decision.
        resolution: Tank-level cell (m) within which nodes are merged.

    Returns:
        The actions of the best node after ``hours`` decisions and its return in the search.
    """
    first = sims[0]
    n_actions = 2 ** len(first.network.pump_ids)
    if len(sims) != width * n_actions:
        raise PolicyError(f"the beam search of width {width} steps {width * n_actions} copies, not {len(sims)}")
    threshold = first._ovf_start
    low = first.network.tank_min_level
    beam = [_Node(np.array(levels, dtype=np.float64), 0.0, ())]
    for _ in range(hours):
        children: list[_Node] = []
        for index, sim in enumerate(sims):  # every copy steps every hour, so that all keep one clock
            k, a = divmod(index, n_actions)
            node = beam[k] if k < len(beam) else beam[0]
            _restore(sim, node.levels)
            _, _, _, _, info = sim.step(a)
            if k < len(beam):
                children.append(_Node(sim._levels.copy(), node.value + objective(info), (*node.actions, a)))
        buffer = [float(np.minimum(c.levels, threshold).sum() - low.sum()) for c in children]
        order = sorted(range(len(children)), key=lambda i: (-children[i].value, -buffer[i]))
        beam, cells = [], set()
        for i in order:
            cell = tuple(np.floor(children[i].levels / resolution).astype(int))
            if cell in cells:
                continue
            cells.add(cell)
            beam.append(children[i])
            if len(beam) == width:
                break
    return beam[0].actions, beam[0].value


def _restore(sim: WDSEnv, levels: np.ndarray) -> None:
    """Put a copy's tanks at ``levels`` (m) at its present time (the hydraulic state between two hours)."""
    tk, ph, net = sim._engine.tk, sim._engine.ph, sim.network
    levels = np.clip(levels, net.tank_min_level, net.tank_max_level)
    for node, level in zip(sim._tank_nodes, levels, strict=True):
        tk.setnodevalue(ph, node, en.TANKLEVEL, float(level))
    sim._tanks_moved = True
    sim._levels = levels.copy()
    sim._solved_at = None


def hindsight(env: gym.Env[Any, Any]) -> WDSHindsight:
    """Baseline factory: the non-causal hindsight planner (knows the week's demand)."""
    return WDSHindsight(env)


def weighted_hindsight(env: gym.Env[Any, Any], weights: Sequence[float], seed: int | None = None) -> WDSHindsight:
    """Weight-conditioned factory: the hindsight planner of the weighted objective of ``gym4real/wds-mo-v0``.

    ``weights`` (dsr, overflow) weigh the raw objectives; ``seed`` is accepted for the
    ``factory(env, weights=w, seed=S)`` convention and unused (the planner is deterministic).
    """
    return WDSHindsight(env, weights=weights)
