"""What a vector-reward id's multi-objective evaluation measures: its objectives and its baselines' sweeps.

A domain declares the evaluation of each of its vector-reward ids (``gym4real/dam-mo-v0``, ...) in the
module ``gym4real.<domain>.multi_objective``, as a tuple ``SPECS`` of :class:`MultiObjectiveSpec` records
(the convention of ``gym4real.<domain>.standin``; the module imports nothing heavier than this one). Each
objective is the per-episode sum of some of the env's reward components, maximised; components a
trade-off does not need (shaping terms) are left out and the spec says why. Each :class:`Sweep` is a
rule-based baseline with a parameter, whose policies give a reference front
(:mod:`gym4real.bench.mo_reference`).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gym4real.core.errors import ConfigError
from gym4real.core.registry import base_env, domain_of, env_spec, load_object, registry

#: The module of a domain that declares its multi-objective evaluations (``SPECS``).
MODULE = "multi_objective"


def _require(ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(what)


@dataclass(frozen=True)
class Objective:
    """One objective: the per-episode sum of reward components, maximised.

    Args:
        name: Lower-case name (``shortage``).
        components: The reward components summed (each a reward: higher is better).
        description: What it measures, in the domain's terms, with its unit.
    """

    name: str
    components: tuple[str, ...]
    description: str

    def __post_init__(self) -> None:
        _require(bool(self.components), f"objective `{self.name}` sums no reward component")


class SweepPolicy:
    """One policy of a sweep: ``factory(env, **params)``, imported when built (keeps the spec module light).

    Args:
        entry_point: ``"module:factory"``.
        params: The keyword arguments of this point of the sweep.
    """

    def __init__(self, entry_point: str, params: Mapping[str, float]) -> None:
        self.entry_point = entry_point
        self.params = dict(params)
        self.__name__ = self.label

    @property
    def label(self) -> str:
        """``name=value,...``: the policy's label in tables and files."""
        return ",".join(f"{k}={v:g}" for k, v in self.params.items())

    def __call__(self, env: Any) -> Any:
        """Build the policy for ``env``."""
        return load_object(self.entry_point)(env, **self.params)


@dataclass(frozen=True)
class Sweep:
    """A rule-based baseline with a parameter, run at several values: its non-dominated set is a reference front.

    Args:
        name: Lower-case name of the front (``constant_release``).
        entry_point: ``"module:factory"``; ``factory(env, **params)`` returns a policy.
        points: The parameter values, one mapping of keyword arguments per policy.
        description: What the parameter is, and which registered baselines the sweep contains.
    """

    name: str
    entry_point: str
    points: tuple[Mapping[str, float], ...]
    description: str

    def __post_init__(self) -> None:
        _require(len(self.points) >= 2, f"sweep `{self.name}` has fewer than two points")
        labels = [SweepPolicy(self.entry_point, p).label for p in self.points]
        _require(len(set(labels)) == len(labels), f"sweep `{self.name}` repeats a point: {labels}")

    @property
    def policies(self) -> tuple[SweepPolicy, ...]:
        """One factory per point (``gym4real evaluate --mo rules=gym4real.wds.multi_objective:SWEEP.policies``)."""
        return tuple(SweepPolicy(self.entry_point, p) for p in self.points)


@dataclass(frozen=True)
class MultiObjectiveSpec:
    """The multi-objective evaluation of a vector-reward id.

    Args:
        env_id: The vector-reward id (``gym4real/wds-mo-v0``).
        objectives: The objectives, in order (two or more); their components are disjoint.
        left_out: Why the reward components in no objective are left out (empty when none is).
        sweeps: The rule-based baselines' sweeps (reference fronts).
        margin: The reference point's margin: each objective's worst per-episode value of ``random`` on the
            test protocol, pushed out by this fraction of the range of ``random``'s per-episode values.
    """

    env_id: str
    objectives: tuple[Objective, ...]
    left_out: str = ""
    sweeps: tuple[Sweep, ...] = ()
    margin: float = 0.1

    def __post_init__(self) -> None:
        _require(len(self.objectives) >= 2, f"`{self.env_id}` declares fewer than two objectives")
        used = [c for o in self.objectives for c in o.components]
        _require(len(set(used)) == len(used), f"`{self.env_id}`: a reward component is in two objectives: {used}")
        _require(math.isfinite(self.margin) and self.margin >= 0, f"`{self.env_id}`: margin must be >= 0")

    @property
    def names(self) -> tuple[str, ...]:
        """The objectives' names, in order."""
        return tuple(o.name for o in self.objectives)

    def values(self, components: Mapping[str, float]) -> np.ndarray:
        """The objective vector of an episode from its reward-component sums.

        Raises:
            ConfigError: A component of an objective is missing from ``components``.
        """
        missing = sorted({c for o in self.objectives for c in o.components} - set(components))
        if missing:
            raise ConfigError(
                f"`{self.env_id}`: the episode's reward components {sorted(components)} lack {missing}, which its "
                "objectives sum; is the environment the one this spec was written for?"
            )
        return np.array([sum(float(components[c]) for c in o.components) for o in self.objectives])

    def reward_weights(self, weights: Sequence[float], components: Sequence[str]) -> np.ndarray:
        """Weights over the vector reward's entries that scalarise it as ``weights`` over the objectives.

        Each entry of an objective gets that objective's weight; an entry in no objective gets 0. For
        MO-Gymnasium's ``LinearReward(env, weights=...)``.

        Args:
            weights: One weight per objective (finite, non-negative, not all 0).
            components: The vector reward's entries, in order (the env's ``components``).

        Raises:
            ConfigError: Weights that are not one finite non-negative number per objective, or all 0
                (:meth:`checked_weights`).
        """
        w = self.checked_weights(weights)
        of = {c: float(x) for o, x in zip(self.objectives, w, strict=True) for c in o.components}
        return np.array([of.get(c, 0.0) for c in components])

    def checked_weights(self, weights: Sequence[float]) -> np.ndarray:
        """``weights`` as a float array, once checked: one finite, non-negative weight per objective, not all 0.

        Raises:
            ConfigError: Naming each weight that is wrong (its objective and value), or that they are all 0,
                with what is expected.
        """
        expected = (
            f"`{self.env_id}` has {len(self.objectives)} objectives {list(self.names)}: it takes one finite, "
            "non-negative weight each, not all 0"
        )
        try:
            w = np.asarray(weights, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"{expected}; got {weights!r}, which are not numbers") from None
        if w.shape != (len(self.objectives),):
            raise ConfigError(f"{expected}; got {np.asarray(weights).tolist()!r} (shape {w.shape})")
        wrong = [
            f"{name} = {x}" for name, x in zip(self.names, w.tolist(), strict=True) if not (math.isfinite(x) and x >= 0)
        ]
        if wrong:
            raise ConfigError(f"{expected}; got {w.tolist()}: {', '.join(wrong)}")
        if not w.sum() > 0:
            raise ConfigError(f"{expected}; got {w.tolist()}, all 0: no objective would count")
        return w

    def component_weights(self, weights: Sequence[float]) -> dict[str, float]:
        """Each component of an objective with its objective's weight: the weighted scalarisation per step.

        ``sum_c weight_c x_c`` over a step's reward components ``x`` sums, over an episode, to ``weights``
        times the objective vector (:meth:`values`); for a planner that optimises the weighted objective.

        Raises:
            ConfigError: Not one finite, non-negative weight per objective, or all of them 0 (:meth:`checked_weights`).
        """
        w = self.checked_weights(weights)
        return {c: float(x) for o, x in zip(self.objectives, w, strict=True) for c in o.components}

    def record(self) -> dict[str, Any]:
        """JSON-ready: the objectives, what is left out, the margin and the sweeps."""
        return {
            "objectives": [
                {"name": o.name, "components": list(o.components), "description": o.description}
                for o in self.objectives
            ],
            "left_out": self.left_out,
            "margin": self.margin,
            "sweeps": {
                s.name: {"parameters": [dict(p) for p in s.points], "description": s.description} for s in self.sweeps
            },
        }


def spec_module(domain: str) -> Any:
    """``gym4real.<domain>.multi_objective``, or None when the domain declares no multi-objective evaluation."""
    name = f"gym4real.{domain}.{MODULE}"
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name == name:
            return None
        raise


def mo_spec(env_id: str) -> MultiObjectiveSpec:
    """The multi-objective evaluation of a vector-reward id.

    Raises:
        EnvUnavailableError: The id is not registered.
        ConfigError: The id has no vector reward, or its domain declares no evaluation of it.
    """
    env_spec(env_id)
    if env_id not in registry().multi_objective:
        ids = ", ".join(sorted(registry().multi_objective)) or "none installed"
        raise ConfigError(f"`{env_id}` has no vector reward; multi-objective evaluation takes one of: {ids}")
    module = spec_module(domain_of(base_env(env_id)))
    specs = {s.env_id: s for s in getattr(module, "SPECS", ())}
    if env_id not in specs:
        raise ConfigError(
            f"`{env_id}` declares no multi-objective evaluation (no `SPECS` entry in gym4real.{domain_of(env_id)}."
            f"{MODULE}); add one to evaluate it"
        )
    return specs[env_id]


def mo_ids() -> list[str]:
    """The installed vector-reward ids whose domain declares their evaluation."""
    found = []
    for env_id in sorted(registry().multi_objective):
        module = spec_module(domain_of(env_id))
        if any(s.env_id == env_id for s in getattr(module, "SPECS", ())):
            found.append(env_id)
    return found
