"""Upper references: the non-causal baselines (``hindsight``) that are handed an episode's exogenous data.

A domain registers its hindsight planner as a baseline with ``causal=False``
(:class:`~gym4real.core.specs.BaselineSpec`). It plans the whole episode knowing what no agent can know
in advance (the year's inflows, the day's prices), against the environment's own objective, and its plan
is replayed through the environment and scored by the protocol like any policy.

**Kinds.** Where it is declared, each upper reference says what kind it is (``BaselineSpec.bound``,
:data:`gym4real.core.specs.BOUNDS`): ``exact`` (proven optimal: no controller scores more on an episode),
``heuristic`` (a plan with a measured ``gap``: the most a further search found beyond it on a test episode)
or ``not a bound`` (it reads privileged information but a controller can score more). Only a bound has a
**headroom** (:func:`headroom`: how far an agent is from it) and a **share of the headroom closed**
(:func:`headroom_closed`: ``(agent - random) / (upper - random)``); tables and figures name the kind
(:func:`label`).

Because it reads the future, an upper reference is never a baseline an agent is compared with on equal
terms: it is never the 1-anchor of the suite scale (:func:`gym4real.bench.suite_score.scale` leaves it
out), never in a claim's family (a protocol naming one is refused), and ``gym4real evaluate`` refuses it
as "your agent" unless asked explicitly (``allow_non_causal``).

Planning can take minutes per protocol, so each planner caches its plans in the user cache
(:func:`plan_cache`), one file per protocol fingerprint (:func:`gym4real.bench.reference.fingerprint`,
the key of the reference runs), with one entry per episode keyed by a hash of everything the plan depends
on: a plan is recomputed when the environment, its data or the planner change.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.bench.progress import NOTICES
from gym4real.core.errors import ConfigError
from gym4real.core.registry import base_env, non_causal, registry, upper_reference

#: The name a domain gives its hindsight planner.
HINDSIGHT = "hindsight"
#: The name a domain gives its causal model-predictive controller: the hindsight planner on forecasts.
MPC = "mpc"


def check_protocol(env_id: str) -> None:
    """Refuse a protocol whose rule-based baselines or claims name a non-causal baseline.

    Raises:
        ConfigError: Naming the non-causal baselines and where the protocol names them.
    """
    spec = registry().benchmarks.get(base_env(env_id))
    if spec is None:
        return
    upper = set(non_causal(env_id))
    named = {"rule_based": set(spec.rule_based) & upper}
    for claim in spec.claims:
        named.setdefault("claims", set()).update({claim.policy, *claim.others} & upper)
    bad = {where: sorted(names) for where, names in named.items() if names}
    if bad:
        raise ConfigError(
            f"the protocol of `{env_id}` names the non-causal upper references {bad}: an upper reference knows the "
            "episode's future, so it can be neither the suite scale's 1 nor in a claim's family; remove it there"
        )


def check_agent(env_id: str, name: str, ref: Any, allow: bool) -> None:
    """Refuse a non-causal baseline given as the agent to evaluate, unless ``allow``.

    Raises:
        ConfigError: The agent is a non-causal baseline and ``allow`` is False (the fix: the explicit flag).
    """
    if allow or not isinstance(ref, str) or ref not in non_causal(env_id):
        return
    raise ConfigError(
        f"agent `{name}` is `{ref}`, the non-causal upper reference of `{env_id}` (it is handed the episode's "
        "exogenous data, which no agent knows in advance); it is already reported as the headroom. To score it as "
        "an agent anyway pass `allow_non_causal=True` (`--allow-non-causal`)"
    )


def headroom(upper: np.ndarray, agent: np.ndarray, agent_trained: bool = True) -> dict[str, float]:
    """An agent's shortfall from an upper reference on the same test episodes.

    Args:
        upper: The upper reference's per-episode objective, ``(episodes,)`` or ``(1, episodes)``.
        agent: The agent's per-episode objective, ``(seeds, episodes)``.
        agent_trained: Whether the agent's rows are training seeds (resampled), not a baseline's one row.

    Returns:
        ``upper_iqm``, ``agent_iqm`` and ``shortfall`` (their difference, >= 0 when the upper reference is
        ahead), with the 95 % interval of the shortfall (``low``, ``high``) from the two-level (seed,
        episode) bootstrap of :func:`gym4real.bench.stats.difference_ci` (the episodes paired).
    """
    from gym4real.bench import stats

    upper_row = np.asarray(upper, dtype=float).reshape(1, -1)
    matrix = np.atleast_2d(np.asarray(agent, dtype=float))
    if upper_row.shape[1] != matrix.shape[1]:
        raise ConfigError(
            f"the upper reference has {upper_row.shape[1]} episodes and the agent {matrix.shape[1]}: headroom needs "
            "the same test episodes"
        )
    difference, low, high = stats.difference_ci(upper_row, matrix, False, agent_trained)
    return {
        "upper_iqm": stats.iqm(upper_row),
        "agent_iqm": stats.iqm(matrix),
        "shortfall": difference,
        "low": low,
        "high": high,
    }


def headroom_split(
    upper: np.ndarray, mpc: np.ndarray, agent: np.ndarray, agent_trained: bool = True
) -> dict[str, dict[str, float]]:
    """An agent's headroom split at a causal model-predictive controller that forecasts what the upper reference knows.

    ``forecast``: upper reference minus ``mpc``, what better forecasts could give (:func:`headroom` of ``mpc``; both
    are baselines, so only the test episodes are resampled, paired). ``learning``: ``mpc`` minus the agent, what a
    better learner could give where it is positive (:func:`headroom` of the agent from ``mpc``: the agent's training
    seeds and the test episodes resampled, paired). Their estimates add up to the agent's headroom (IQM differences).

    Args:
        upper: The upper reference's per-episode objective, ``(episodes,)`` or ``(1, episodes)``.
        mpc: The model-predictive controller's, the same shape.
        agent: The agent's ``(seeds, episodes)``.
        agent_trained: Whether the agent's rows are training seeds (resampled), not a baseline's one row.

    Returns:
        ``forecast`` and ``learning``, each as :func:`headroom` returns it (``shortfall`` with ``low``, ``high``).
    """
    return {"forecast": headroom(upper, mpc, agent_trained=False), "learning": headroom(mpc, agent, agent_trained)}


def bound_references(env_id: str) -> list[str]:
    """The upper references of an environment that bound what a controller can score (``exact``, ``heuristic``)."""
    return [name for name in non_causal(env_id) if upper_reference(env_id, name).is_bound]


def headroom_closed(
    upper: np.ndarray, random: np.ndarray, agent: np.ndarray, agent_trained: bool = True
) -> dict[str, float]:
    """The share of the headroom an agent closed: ``(IQM agent - IQM random) / (IQM upper - IQM random)``.

    0 is the ``random`` baseline, 1 the upper reference (a bound): the scale of the suite score
    (:mod:`gym4real.bench.suite_score`), with the optimum in place of the best rule.

    Args:
        upper: The upper reference's per-episode objective, ``(episodes,)`` or ``(1, episodes)``.
        random: The ``random`` baseline's, the same shape.
        agent: The agent's ``(seeds, episodes)``.
        agent_trained: Whether the agent's rows are training seeds (resampled), not a baseline's one row.

    Returns:
        ``share`` with its 95 % two-level bootstrap interval (``low``, ``high``; the episodes paired across the
        three, replicates where the upper reference does not beat ``random`` left out).

    Raises:
        ConfigError: The three do not hold the same test episodes, or the upper reference's IQM does not beat
            ``random``'s (no headroom to close).
    """
    from gym4real.bench import stats

    rows = [np.atleast_2d(np.asarray(m, dtype=float)) for m in (upper, random, agent)]
    if len({m.shape[1] for m in rows}) > 1:
        raise ConfigError(
            f"the upper reference, random and the agent have {[m.shape[1] for m in rows]} episodes: the share of "
            "the headroom closed needs the same test episodes"
        )
    top, bottom = stats.iqm(rows[0]), stats.iqm(rows[1])
    if not top > bottom:
        raise ConfigError(f"the upper reference's IQM {top:.6g} does not beat random's {bottom:.6g}: no headroom")

    def share(u: np.ndarray, r: np.ndarray, a: np.ndarray) -> np.ndarray:
        iqm = stats.batched("iqm")
        room = iqm(u) - iqm(r)
        return np.where(room > 0, (iqm(a) - iqm(r)) / np.where(room > 0, room, 1.0), np.nan)

    point = float(share(*(m[None] for m in rows))[0])
    values = stats.replicates(rows, [False, False, agent_trained], share, 0, stats.replicates_at(0.95))
    low, high = np.nanpercentile(values, [2.5, 97.5])
    return {"share": point, "low": float(low), "high": float(high)}


class PlanCache:
    """A planner's plans of one protocol, in one JSON file of the user cache.

    Args:
        path: The cache file (created on the first :meth:`put`); None: nothing is cached.
        label: The planner and environment, for the notice of a cold cache (``dam-dp-1 on gym4real/dam-v0``).
    """

    def __init__(self, path: Path | None, label: str = "a planner") -> None:
        self.path = path
        self.label = label
        self._entries: dict[str, Any] | None = None
        self._announced = False

    def _load(self) -> dict[str, Any]:
        if self._entries is None:
            self._entries = {}
            if self.path is not None and self.path.is_file():
                try:
                    self._entries = dict(json.loads(self.path.read_text()).get("plans", {}))
                except (OSError, ValueError):  # a damaged cache file is recomputed, never trusted
                    self._entries = {}
        return self._entries

    def get(self, key: str) -> Any:
        """The cached plan of ``key``, or None (the first miss announces the planning on :data:`NOTICES`)."""
        found = self._load().get(key)
        if found is None and not self._announced:
            self._announced = True
            where = f"cached afterwards in {self.path}" if self.path is not None else "not cached"
            NOTICES.info(
                "planning (%s): each episode not in the plan cache is planned before it is replayed, minutes per "
                "protocol on a cold cache (%s)",
                self.label,
                where,
            )
        return found

    def put(self, key: str, plan: Any) -> None:
        """Store a plan (JSON-ready) under ``key``; the file is replaced atomically."""
        entries = self._load()
        entries[key] = plan
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(dir=self.path.parent, suffix=".tmp")
        with os.fdopen(handle, "w") as out:
            json.dump({"plans": entries}, out)
        os.replace(name, self.path)


def plan_key(**inputs: Any) -> str:
    """A hash of everything a plan depends on (numbers as their ``repr``, so every bit counts)."""
    text = json.dumps(inputs, sort_keys=True, default=lambda v: np.asarray(v).tolist())
    return hashlib.sha256(text.encode()).hexdigest()


def plan_cache(env: gym.Env[Any, Any], planner: str) -> PlanCache:
    """The cache of a planner's plans on an environment's protocol (``GYM4REAL_HINDSIGHT_CACHE=0``: none).

    The file is named for the environment and a hash of its protocol fingerprint; an env made outside
    ``gymnasium.make`` or without a protocol shares one file per planner (the entries' keys still hold
    every input of a plan).

    Args:
        env: The environment the planner acts in.
        planner: The planner's name and version (``dam-dp-1``): a new version starts a new file.
    """
    env_id = getattr(env.unwrapped.spec, "id", None) or getattr(env.spec, "id", None)
    label = f"{planner} on {env_id or 'an unregistered env'}"
    if os.environ.get("GYM4REAL_HINDSIGHT_CACHE", "1") == "0":
        return PlanCache(None, label)
    from gym4real.core.datasets import cache_dir

    protocol_key: Mapping[str, Any] = {"env": "unregistered"}
    if env_id is not None and base_env(env_id) in registry().benchmarks:
        from gym4real.bench.reference import fingerprint

        protocol_key = fingerprint(base_env(env_id), env)
    digest = plan_key(planner=planner, fingerprint=protocol_key)[:16]
    slug = (env_id or "unregistered").replace("/", "_")
    return PlanCache(cache_dir() / "hindsight" / f"{slug}-{planner}-{digest}.json", label)
