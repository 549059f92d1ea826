"""Plain data records that plugins return from their ``gym4real_register_*`` hooks."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

#: The characteristics and RL paradigms of the paper's Table 1, in the table's order.
FLAGS: tuple[str, ...] = (
    "continuous_states",
    "continuous_actions",
    "partially_observable",
    "partially_controllable",
    "non_stationary",
    "visual_input",
    "frequency_adaptation",
    "hierarchical",
    "risk_averse",
    "imitation_learning",
    "provably_efficient",
    "multi_objective",
)

_ENV_ID = re.compile(r"^gym4real/[a-z0-9]+(-[a-z0-9]+)*-v\d+$")
_SNAKE = re.compile(r"^[a-z][a-z0-9_]*$")
_ENTRY = re.compile(r"^[\w.]+:[\w.]+$")


def _check(ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(what)


@dataclass(frozen=True)
class EnvSpec:
    """An environment that a plugin provides.

    Args:
        id: Gymnasium id, ``gym4real/<domain>[-<variant>]-v<N>``.
        entry_point: ``"module:Class"`` of the env, imported only at ``make()``.
        description: One line for ``gym4real list`` and ``env_info``.
        flags: Table-1 flags of the paper that the environment has (names from ``FLAGS``).
        presets: Names of the packaged configuration presets; the first is the default.
        datasets: Names of the datasets the environment reads.
        kwargs: Default keyword arguments passed to the constructor.
        max_episode_steps: Gymnasium time limit, or None when the env truncates by itself.
        info_provider: ``"module:function"`` returning run-time facts for ``env_info`` (engine, versions).
        vector_entry_point: ``"module:Class"`` of a native batched ``VectorEnv`` (``gym.make_vec(...,
            vectorization_mode="vector_entry_point")``), if the env has one.
    """

    id: str
    entry_point: str
    description: str
    flags: frozenset[str] = frozenset()
    presets: tuple[str, ...] = ("default",)
    datasets: tuple[str, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    max_episode_steps: int | None = None
    info_provider: str | None = None
    vector_entry_point: str | None = None

    def __post_init__(self) -> None:
        _check(bool(_ENV_ID.match(self.id)), f"env id `{self.id}` is not `gym4real/<name>-v<N>`")
        _check(bool(_ENTRY.match(self.entry_point)), f"entry point `{self.entry_point}` is not `module:attr`")
        unknown = sorted(set(self.flags) - set(FLAGS))
        _check(not unknown, f"unknown Table-1 flags {unknown}; expected some of {list(FLAGS)}")
        _check(bool(self.presets), f"env `{self.id}` declares no preset")


@dataclass(frozen=True)
class DatasetSpec:
    """A data file an environment reads, fetched from its upstream address and checked by hash.

    Args:
        name: Logical name, ``<domain>/<what>`` (for example ``dam/level/train``).
        path: Path relative to a data folder (``GYM4REAL_DATA_DIR``, the cache), with ``/``.
        sha256: Hex SHA-256 of the file.
        url: Public upstream address of the file.
        licence: Licence of the data.
        description: One line on what the file holds.
        stand_in_for: What data of the paper this file stands in for, when it is a stand-in (empty when it
            is the paper's own data): the results page and ``gym4real data list`` label it so.
    """

    name: str
    path: str
    sha256: str
    url: str
    licence: str = ""
    description: str = ""
    stand_in_for: str = ""

    def __post_init__(self) -> None:
        _check(bool(re.fullmatch(r"[0-9a-f]{64}", self.sha256)), f"dataset `{self.name}`: sha256 must be 64 hex digits")
        _check(not self.path.startswith("/") and ".." not in self.path, f"dataset `{self.name}`: path must be relative")


#: The kinds of upper reference (:attr:`BaselineSpec.bound`), each in plain words.
BOUNDS: dict[str, str] = {
    "exact": "proven optimal: no controller can score more on an episode (checked against brute force)",
    "heuristic": "a plan, not proven optimal: a further search found at most its stated gap more on the test "
    "episodes, so a controller could score up to about that much more",
    "not a bound": "reads what no agent knows but is not an optimum: a controller can score more (no headroom "
    "is measured to it)",
}


@dataclass(frozen=True)
class BaselineSpec:
    """A named policy for an environment.

    Args:
        env_id: The environment the policy acts in.
        name: Lower-case snake-case name (``longest_first``).
        entry_point: ``"module:factory"``; ``factory(env)`` returns a policy, a callable
            ``obs -> action`` that may also define ``reset(seed)`` (called at each episode start).
        description: One line on what the policy does.
        causal: False for a non-causal upper reference (``hindsight``) that is handed the episode's exogenous data.
        bound: For a non-causal baseline only, what kind of upper reference it is (:data:`BOUNDS`): ``exact``,
            ``heuristic`` or ``not a bound``.
        gap: For a ``heuristic`` bound only: the largest relative gain (a fraction of the objective's magnitude)
            that a further search found over it on one test episode, measured.
        bound_note: One line on why the kind holds: the test that proves it exact, how the gap was measured,
            or what beats it.
    """

    env_id: str
    name: str
    entry_point: str
    description: str = ""
    causal: bool = True
    bound: str = ""
    gap: float | None = None
    bound_note: str = ""

    def __post_init__(self) -> None:
        _check(bool(_SNAKE.match(self.name)), f"baseline name `{self.name}` is not lower-case snake case")
        _check(bool(_ENTRY.match(self.entry_point)), f"entry point `{self.entry_point}` is not `module:attr`")
        where = f"baseline `{self.name}` of `{self.env_id}`"
        if self.causal:
            _check(
                not self.bound and self.gap is None and not self.bound_note,
                f"{where} is causal: `bound`, `gap` and `bound_note` are for non-causal upper references only",
            )
            return
        _check(
            self.bound in BOUNDS,
            f"{where} is non-causal: declare `bound` as one of {list(BOUNDS)} (what kind of upper reference it is), "
            f"not {self.bound!r}",
        )
        _check(bool(self.bound_note), f"{where}: `bound_note` must say why its bound is `{self.bound}`")
        if self.bound == "heuristic":
            _check(
                self.gap is not None and math.isfinite(self.gap) and self.gap >= 0,
                f"{where}: a `heuristic` bound needs `gap`, the measured relative gain of a further search "
                f"(a fraction >= 0), not {self.gap}",
            )
        else:
            _check(self.gap is None, f"{where}: `gap` is for a `heuristic` bound only, not `{self.bound}`")

    def bound_words(self) -> str:
        """The kind of bound in a table cell: ``exact``, ``heuristic (gap <= 0.05 %)`` or ``not a bound``."""
        if self.bound == "heuristic" and self.gap is not None:
            return f"heuristic (a further search gains <= {100 * self.gap:.2g} %)"
        return self.bound

    @property
    def is_bound(self) -> bool:
        """Whether it bounds what a controller can score (``exact`` or ``heuristic``): headroom is measured to it."""
        return self.bound in ("exact", "heuristic")


#: How a claim compares its policy with the others (see :class:`Claim`).
RELATIONS: tuple[str, ...] = ("above", "below", "not_above", "less_variable")

#: The per-episode quantity a claim compares (see :class:`Claim`).
QUANTITIES: tuple[str, ...] = ("objective", "success")


@dataclass(frozen=True)
class Claim:
    """A claim of the paper about an environment's test comparison, checked by ``gym4real reproduce``.

    Each comparison of ``policy`` with one of ``others`` is decided by the two-level (seed, episode)
    percentile-bootstrap interval of the difference of a statistic of the per-episode ``quantity``
    (:mod:`gym4real.bench.stats`): the interquartile mean of the objective, the mean of the success
    indicator (the success rate), or for ``less_variable`` the spread across test episodes (per training
    seed). The comparisons of a claim use Bonferroni-simultaneous intervals, so that its verdict holds at a
    95 % family level. The rules are in :mod:`gym4real.results.claims`.

    Args:
        text: The claim in the paper's words, with where it is made (and the reason of a margin).
        policy: The RL algorithm (``ppo``, ``qlearning``, ...) or baseline the claim is about.
        relation: ``above`` (its statistic is above each of ``others``'), ``below``, ``not_above`` (the
            negation of ``above``: it does not outperform them) or ``less_variable`` (its spread is below
            theirs).
        others: The policies compared with: baselines or RL algorithms.
        margin: For ``not_above`` only: the margin of practical equivalence, in the objective's unit, of the
            claim's second, stricter reading (no gain of ``margin`` or more over any of ``others``); the
            text says why a difference below it is of no practical consequence.
        consistently: For ``above``, ``below`` and ``not_above``: the claim says *consistently*, so every
            training seed's own interval must also be on the claimed side (for ``not_above``: the negation
            of "consistently above").
        quantity: ``objective`` (the per-episode objective, compared by its IQM) or ``success`` (1 for an
            episode whose ``success`` reward component is positive, else 0, compared by its mean: the
            success rate).
        section: Where the paper makes the claim (``"2.1"``); empty for a check of this suite's own.
        paper: False for a check of this suite's own, which the paper does not make (shown apart, outside
            the count of the paper's claims).
    """

    text: str
    policy: str
    relation: str
    others: tuple[str, ...]
    margin: float | None = None
    consistently: bool = False
    quantity: str = "objective"
    section: str = ""
    paper: bool = True

    def __post_init__(self) -> None:
        _check(self.relation in RELATIONS, f"claim relation `{self.relation}` is not one of {list(RELATIONS)}")
        _check(bool(self.others), f"claim `{self.text}` compares `{self.policy}` with no other policy")
        _check(
            self.quantity in QUANTITIES,
            f"claim `{self.text}`: quantity `{self.quantity}` is not one of {list(QUANTITIES)}",
        )
        if self.relation == "not_above":
            _check(
                self.margin is not None and math.isfinite(self.margin) and self.margin > 0,
                f"claim `{self.text}`: a `not_above` claim needs `margin`, a positive margin of practical "
                f"equivalence in the objective's unit (not {self.margin}), with its reason in the text",
            )
        else:
            _check(self.margin is None, f"claim `{self.text}`: `margin` is for `not_above` claims only")
        _check(
            not self.consistently or self.relation in ("above", "below", "not_above"),
            f"claim `{self.text}`: `consistently` is for `above`, `below` and `not_above` claims only",
        )
        _check(
            self.relation != "less_variable" or self.quantity == "objective",
            f"claim `{self.text}`: `less_variable` compares the objective's spread; set quantity `objective`",
        )
        _check(
            not self.paper or not self.section or self.section in self.text,
            f"claim `{self.text}`: its text names no `{self.section}`; cite the paper's section in the text",
        )


@dataclass(frozen=True)
class BenchmarkSpec:
    """The paper's evaluation protocol of an environment.

    Args:
        env_id: The environment.
        protocol: ``"module:function"``; ``function(env_kwargs)`` returns the list of episodes, each a
            dict with ``seed`` and ``options`` for ``reset``.
        env_kwargs: Keyword arguments of ``make()`` for evaluation (for example ``{"preset": "test"}``).
        policies: The baselines the default benchmark compares.
        objective: Reward components whose per-episode sum is the paper's objective: the score (higher is
            better) that ``bench``, ``evaluate``, the suite score and the results page rank by; empty: the return.
        final_info: ``info`` keys whose value at the end of an episode is reported (final SoH, ...).
        figures: ``"module:function"``; ``function(result, out)`` draws the domain's own figures of the
            paper into the folder ``out`` and returns their paths (beside the two common figures).
        description: One line on the protocol.
        step_unit: What one step of the protocol's env is, the x-axis label of per-step figures (``"day"``,
            ``"hour"``, ``"second"``).
        claims: The paper's claims about this comparison, checked by ``gym4real reproduce``.
        rule_based: The rule-based baselines among ``policies`` (hand-written rules: not ``random``, not an
            oracle reading the simulator, not a replay of recorded decisions, not a pretrained agent); the
            best of them is 1 on the suite score's scale, ``random`` 0 (:mod:`gym4real.bench.suite_score`).
        placements: ``"module:function"``; ``function(env_kwargs)`` returns, per test episode of the protocol,
            where its object lies in the camera image (``(u, v)`` pixels, read by resetting the env with the
            episode's seed): the results page draws each success claim's rate over the workspace from them.
        portable_forward: Score model-file policies with :mod:`gym4real.rl.portable_forward` (the same bits
            on every CPU) instead of torch's kernels, which differ in the last bit between CPUs: for envs
            whose dynamics turn an action's last bit into another episode (a robot's contacts).
    """

    env_id: str
    protocol: str
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    policies: tuple[str, ...] = ()
    objective: tuple[str, ...] = ()
    final_info: tuple[str, ...] = ()
    figures: str | None = None
    description: str = ""
    step_unit: str = "step"
    claims: tuple[Claim, ...] = ()
    rule_based: tuple[str, ...] = ()
    placements: str | None = None
    portable_forward: bool = False

    def __post_init__(self) -> None:
        _check(bool(_ENTRY.match(self.protocol)), f"protocol `{self.protocol}` is not `module:function`")
        _check(
            self.placements is None or bool(_ENTRY.match(self.placements)),
            f"placements `{self.placements}` is not `module:function`",
        )
        unlisted = sorted(set(self.rule_based) - set(self.policies))
        _check(not unlisted, f"rule-based baselines {unlisted} of `{self.env_id}` are not among its policies")
        _check(
            self.figures is None or bool(_ENTRY.match(self.figures)),
            f"figures `{self.figures}` is not `module:function`",
        )


@dataclass(frozen=True)
class TrainingSpec:
    """An RL training preset (hyperparameters of the paper's appendix) for an environment.

    Args:
        env_id: The environment.
        algo: ``ppo``, ``dqn``, ``qlearning`` or ``sarsa``.
        preset: Preset name (``paper``, ``smoke``).
        resource: ``"package:relative/path.yaml"`` of the YAML holding the hyperparameters.
        budget: The ``gym4real reproduce`` budget (``paper`` or ``quick``) this preset serves in place of the
            preset named for it (``paper``; ``smoke`` for ``quick``), for a stand-in of the paper's setting.
    """

    env_id: str
    algo: str
    preset: str
    resource: str
    budget: str | None = None

    def __post_init__(self) -> None:
        _check(bool(_SNAKE.match(self.algo)), f"algo `{self.algo}` is not lower-case snake case")
        _check(":" in self.resource, f"resource `{self.resource}` is not `package:path`")
        _check(self.budget in (None, "paper", "quick"), f"budget `{self.budget}` is not `paper`, `quick` or None")
