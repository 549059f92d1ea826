"""``gym4real evaluate --mo``: a multi-objective agent's front on a vector-reward id, against the reference fronts.

An **agent** is a set of policies, or a weight-conditioned factory ``factory(env, weights=w, seed=S)`` (a
function with a ``weights`` parameter), which is run at each weight of the EUM's weight set
(:func:`gym4real.bench.mo_metrics.simplex_weights`; weights over the spec's objectives: map them to the vector
reward with :meth:`~gym4real.core.mo_spec.MultiObjectiveSpec.reward_weights`). A set's member is anything
``gym4real evaluate`` takes as a policy (a baseline, ``sb3:ALGO:PATH``, ``module:attr``...), and a
``module:attr`` naming a list (``gym4real.wds.multi_objective:TANK_LEVEL.policies``) gives its items. With
training seeds, the whole set is built once per seed (``{seed}`` filled in, ``seed=S`` passed).

Each policy runs the id's test protocol; its point is its mean objective vector over the test episodes.
Per training seed, the set's points give a hypervolume and an EUM on the id's normalised scale (reference
point 0, ``random``'s best episode 1; :mod:`gym4real.bench.mo_reference`); the agent's values are their mean
over seeds, with a two-level (seed, episode) percentile-bootstrap interval (:mod:`gym4real.bench.stats`:
the test episodes drawn with replacement, the same for the agent and every reference front, and the seeds
drawn with replacement). The gap to each shipped reference front is the front's value minus the agent's, on
the same bootstrap replicates (positive: the front is ahead).
"""

from __future__ import annotations

import functools
import inspect
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench import mo_metrics, stats
from gym4real.bench.agent_errors import agent_label, check_timeout
from gym4real.bench.mo_reference import Build, MOReference, load, run_objectives, sweep_builder, test_plan
from gym4real.bench.policies import build_policy, is_user_object, make_policy, user_policy
from gym4real.core.errors import ConfigError
from gym4real.core.mo_spec import SweepPolicy, mo_ids, mo_spec
from gym4real.core.registry import MARK, load_object, non_causal, slug

#: What a member of a set of policies may be: a policy string or a factory (or a sweep's policy).
Member = str | Callable[..., Any]
#: An agent: a weight-conditioned factory, a policy, or a sequence of policies (a set).
MOAgent = Member | Sequence[Member]


@dataclass
class AgentRun:
    """An agent's objectives on the test episodes.

    Attributes:
        name: The agent's name.
        labels: One label per policy of its set (its weights for a weight-conditioned factory).
        seeds: Its training seeds (one row, ``[0]``, when not trained).
        trained: Whether rows are training seeds (resampled by the bootstrap).
        values: ``(seeds, policies, episodes, objectives)`` raw objective values.
    """

    name: str
    labels: list[str]
    seeds: list[int]
    trained: bool
    values: np.ndarray

    @property
    def means(self) -> np.ndarray:
        """Each policy's mean vector over seeds and test episodes, ``(policies, objectives)``."""
        return np.asarray(self.values.mean(axis=(0, 2)))


@dataclass
class MOResult:
    """One vector-reward id's multi-objective evaluation."""

    env_id: str
    reference: MOReference
    runs: dict[str, AgentRun]
    _records: dict[str, dict[str, Any]] = field(default_factory=dict, repr=False)

    def record(self, agent: str) -> dict[str, Any]:
        """The agent's entry of ``score.json``'s ``"mo"`` section (computed once: the bootstrap is seeded)."""
        if agent not in self._records:
            self._records[agent] = _agent_record(self.runs[agent], self.reference)
        return self._records[agent]

    def score(self) -> dict[str, Any]:
        """The id's entry of ``score.json``'s ``"mo"`` section."""
        ref = self.reference
        return {
            "objectives": [dict(o) for o in ref.record["objectives"]],
            "reference_point": ref.scale.reference_point.tolist(),
            "top": ref.scale.top.tolist(),
            "scale": "normalised per objective: (value - reference_point) / (top - reference_point)",
            "weights": ref.record["weights"],
            "reference": ref.source,
            "reference_fronts": {
                name: {k: v for k, v in ref.record["fronts"][name].items() if k in ("kind", "hypervolume", "eum")}
                | {"points": front.means[mo_metrics.nondominated(front.means)].tolist()}
                for name, front in ref.fronts.items()
            },
            "agents": {a: self.record(a) for a in self.runs},
        }


def _interval(point: float, low: float, high: float) -> dict[str, float]:
    return {"value": float(point), "low": float(low), "high": float(high)}


def _agent_record(run: AgentRun, ref: MOReference, seed: int = 0) -> dict[str, Any]:
    """Front, hypervolume, EUM and the gaps to the reference fronts, with their bootstrap intervals."""
    weights = ref.weights
    fronts = list(ref.fronts.values())
    episodes = run.values.shape[2]
    index = np.arange(run.values.shape[0] * episodes, dtype=float).reshape(run.values.shape[0], episodes)

    def statistics(batch: np.ndarray) -> np.ndarray:
        out = np.empty((len(batch), 2 + 2 * len(fronts)))
        for b, cells in enumerate(batch.astype(np.int64)):
            rows, cols = cells[:, 0] // episodes, cells[0] % episodes
            hv, eum = [], []
            for row in rows:
                points = ref.scale.normalise(run.values[row][:, cols].mean(axis=1))
                hv.append(mo_metrics.hypervolume(points))
                eum.append(mo_metrics.expected_utility(points, weights))
            out[b, :2] = np.mean(hv), np.mean(eum)
            for k, front in enumerate(fronts):
                points = ref.scale.normalise(front.episodes[:, cols].mean(axis=1))
                out[b, 2 + 2 * k] = mo_metrics.hypervolume(points) - out[b, 0]
                out[b, 3 + 2 * k] = mo_metrics.expected_utility(points, weights) - out[b, 1]
        return out

    point, low, high = stats.bounds([index], [run.trained], statistics, seed)
    means = run.means
    mask = mo_metrics.nondominated(means)
    return {
        "seeds": len(run.seeds),
        "episodes": episodes,
        "policies": len(run.labels),
        "front": [
            {"label": label, "mean": m.tolist(), "normalised": ref.scale.normalise(m).tolist(), "nondominated": bool(k)}
            for label, m, k in zip(run.labels, means, mask, strict=True)
        ],
        "hypervolume": _interval(point[0], low[0], high[0]),
        "eum": _interval(point[1], low[1], high[1]),
        "gap": {
            front.name: {
                "hypervolume": _interval(point[2 + 2 * k], low[2 + 2 * k], high[2 + 2 * k]),
                "eum": _interval(point[3 + 2 * k], low[3 + 2 * k], high[3 + 2 * k]),
            }
            for k, front in enumerate(fronts)
        },
        "interval": "95 % two-level (seed, episode) percentile bootstrap"
        if run.trained
        else "95 % percentile bootstrap over test episodes (one run)",
    }


def _takes_weights(obj: Any) -> bool:
    if not (inspect.isfunction(obj) or inspect.ismethod(obj) or isinstance(obj, type)):
        return False
    try:
        return "weights" in inspect.signature(obj).parameters
    except (TypeError, ValueError):
        return False


def _resolved(member: Member) -> Any:
    """A ``module:attr`` string's object when it names a weight-conditioned factory or a list; else ``member``."""
    if isinstance(member, str) and is_user_object(member):
        obj = load_object(member)
        if _takes_weights(obj) or (isinstance(obj, Sequence) and not isinstance(obj, str)):
            return obj
    return member


def _member(env_id: str, member: Member, name: str, seed: int | None) -> tuple[str, Build]:
    """A set's member as ``(label, build)``."""
    if isinstance(member, SweepPolicy):
        return member.label, sweep_builder(member)
    if isinstance(member, str):
        filled = member.replace("{env}", slug(env_id)).replace("{seed}", str(seed if seed is not None else 0))
        if is_user_object(filled):
            return filled, lambda env: user_policy(filled, env, seed)
        return filled, lambda env: make_policy(env_id, filled, env)
    if callable(member):
        label = getattr(member, "__name__", type(member).__name__)
        return label, lambda env: build_policy(member, env, name, seed)
    raise ConfigError(f"agent `{name}`: {member!r} is not a policy string, a factory or a policy")


def _weighted(
    factory: Callable[..., Any], env: Any, name: str, seed: int | None, weights: list[float]
) -> Callable[[Any], Any]:
    """The policy of a weight-conditioned factory at ``weights`` (its failures named, as any factory's)."""
    return build_policy(factory, env, name, seed, weights)


def policies_of(env_id: str, name: str, agent: MOAgent, seed: int | None) -> list[tuple[str, Build]]:
    """The agent's set of policies on ``env_id`` for one training seed, as ``(label, build)``.

    Raises:
        ConfigError: An empty set, or a weight-conditioned factory inside a set.
    """
    agent = _resolved(agent) if isinstance(agent, str) else agent
    if _takes_weights(agent):
        factory: Callable[..., Any] = agent  # type: ignore[assignment]
        return [
            (
                "w=" + ",".join(f"{x:.4g}" for x in w),
                functools.partial(_weighted, factory, name=name, seed=seed, weights=[float(x) for x in w]),
            )
            for w in mo_metrics.simplex_weights(len(mo_spec(env_id).objectives))
        ]
    members: list[Member] = []
    for item in [agent] if isinstance(agent, str) or callable(agent) else list(agent):  # type: ignore[arg-type]
        found = _resolved(item)
        if _takes_weights(found):
            raise ConfigError(
                f"agent `{name}`: a weight-conditioned factory is an agent of its own, not a set's member"
            )
        members += list(found) if isinstance(found, Sequence) and not isinstance(found, str) else [found]
    if not members:
        raise ConfigError(f"agent `{name}` is an empty set of policies")
    return [_member(env_id, m, name, seed) for m in members]


def run_agent(
    env_id: str, name: str, agent: MOAgent, seeds: Sequence[int] | None = None, timeout: float | None = None
) -> AgentRun:
    """Run an agent's policies (per training seed) on a vector-reward id's test protocol.

    Args:
        env_id: The vector-reward id.
        name: The agent's name.
        agent: Its set of policies, or its weight-conditioned factory.
        seeds: Its training seeds (none: one run).
        timeout: Seconds a test episode may take, or None.

    Raises:
        ConfigError: Seeds that repeat, or sets of different sizes across seeds.
        AgentError: A policy that cannot be built, fails, runs past ``timeout`` or scores a non-finite
            objective (naming the agent, the id, the seed and policy, the test episode and step).
    """
    plan, kwargs = test_plan(env_id)
    seed_list: list[int | None] = list(seeds) if seeds is not None else [None]
    if seeds is not None and len(set(seed_list)) != len(seed_list):
        raise ConfigError(f"seeds {seed_list} repeat a seed; each training seed is one run")
    labels: list[str] = []
    values = []
    for seed in seed_list:
        built = policies_of(env_id, name, agent, seed)
        if labels and len(built) != len(labels):
            raise ConfigError(f"agent `{name}` has {len(built)} policies at seed {seed} but {len(labels)} at the first")
        labels = labels or [label for label, _ in built]
        who = f"agent `{agent_label(name, agent)}`"
        values.append(
            [
                run_objectives(env_id, build, plan, kwargs, f"{who} (seed {seed or 0}, policy {label})", timeout)
                for label, build in built
            ]
        )
    return AgentRun(
        name, labels, [s if s is not None else 0 for s in seed_list], seeds is not None, np.array(values, dtype=float)
    )


@dataclass
class MOEvaluation:
    """What :func:`evaluate_mo` found, per vector-reward id."""

    results: dict[str, MOResult]

    def score(self) -> dict[str, Any]:
        """``score.json``'s ``"mo"`` section: per id, the objectives, reference point, fronts and agents."""
        return {env_id: result.score() for env_id, result in self.results.items()}

    def table(self) -> str:
        """The evaluation as text: per id, each agent's and reference front's hypervolume and EUM.

        Every line but an id's heading fits in :data:`TABLE_WIDTH` columns (a page's code block shows it
        without cutting it).
        """
        lines = []
        for env_id, result in self.results.items():
            ref = result.reference
            names = ", ".join(f"{o['name']} ({' + '.join(o['components'])})" for o in ref.record["objectives"])
            lines.append(f"== {env_id}  objectives: {names}")
            point = ", ".join(f"{v:.6g}" for v in ref.scale.reference_point)
            lines.append(f"   reference point ({point}); {ref.record['weights']['count']} EUM weights; {ref.source}")
            lines.append(f"   {'front':20s} {'kind':10s} {'hypervolume [95% CI]':>28s} {'EUM [95% CI]':>28s}")
            for agent in result.runs:
                rec = result.record(agent)
                lines.append(f"   {agent:20s} {'agent':10s} {_text(rec['hypervolume']):>28s} {_text(rec['eum']):>28s}")
            for name, front in ref.record["fronts"].items():
                lines.append(f"   {name:20s} {front['kind']:10s} {front['hypervolume']:>28.4f} {front['eum']:>28.4f}")
            for agent in result.runs:
                rec = result.record(agent)
                lines.append(f"   {agent}: {rec['policies']} policies, {rec['seeds']} seed(s)")
            for agent in result.runs:
                lines.append(f"   {'gap: front - agent':31s} {'hypervolume [95% CI]':>28s} {'EUM [95% CI]':>28s}")
                for name, gap in result.record(agent)["gap"].items():
                    pair = f"{name} - {agent}"
                    lines.append(f"   {pair:31s} {_text(gap['hypervolume']):>28s} {_text(gap['eum']):>28s}")
            lines.append("")
        lines += [
            "   normalised scale: reference point 0, random's best test episode 1 per objective;",
            "   gap > 0: the reference front is ahead",
        ]
        return "\n".join(lines)

    def episodes(self) -> pd.DataFrame:
        """Every agent's every test episode: env, agent, seed, policy, episode and each objective."""
        rows = []
        for env_id, result in self.results.items():
            names = [o["name"] for o in result.reference.record["objectives"]]
            for run in result.runs.values():
                for s, seed in enumerate(run.seeds):
                    for p, label in enumerate(run.labels):
                        for e, values in enumerate(run.values[s, p]):
                            row = {"env_id": env_id, "agent": run.name, "seed": seed, "policy": label, "episode": e}
                            rows.append(row | dict(zip(names, values.tolist(), strict=True)))
        return pd.DataFrame(rows)

    def save(self, out: str | Path) -> list[Path]:
        """Write ``score.json`` (its ``"mo"`` section), ``mo_episodes.csv`` and a Pareto plot per id."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        score = out / "score.json"
        existing = json.loads(score.read_text()) if score.is_file() else {}
        score.write_text(json.dumps(existing | {"mo": self.score()}, indent=1, default=float) + "\n")
        written = [score, out / "mo_episodes.csv"]
        self.episodes().to_csv(written[1], index=False)
        written += [pareto_plot(result, out / f"pareto-{slug(e)}.png") for e, result in self.results.items()]
        return written


#: The width every line of :meth:`MOEvaluation.table` but an id's heading keeps within.
TABLE_WIDTH = 100


def _text(interval: Mapping[str, float]) -> str:
    return f"{interval['value']:.4f} [{interval['low']:.4f}, {interval['high']:.4f}]"


def pareto_plot(result: MOResult, path: Path) -> Path:
    """The agents' points and fronts with the reference fronts and the reference point (first two objectives)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ref = result.reference
    names = [o["name"] for o in ref.record["objectives"]]
    fig, ax = plt.subplots(figsize=(6.4, 4.8))

    def staircase(points: np.ndarray, **style: Any) -> None:
        front = points[mo_metrics.nondominated(points)][:, :2]
        front = front[np.argsort(-front[:, 0])]
        ax.step(front[:, 0], front[:, 1], where="post", **style)

    upper = set(non_causal(result.env_id))
    for name, front in ref.fronts.items():
        means = front.means
        if name in upper or front.kind in upper:  # a non-causal upper reference: its own marker and label
            ax.plot(means[:, 0], means[:, 1], "*", color="black", ms=8, alpha=0.6)
            staircase(means, color="black", linestyle=":", label=f"{name} ({MARK})")
            continue
        line = ax.plot(means[:, 0], means[:, 1], "o", alpha=0.35, ms=4)[0]
        staircase(means, color=line.get_color(), label=name if name == front.kind else f"{name} ({front.kind})")
    for agent, run in result.runs.items():
        means = run.means
        line = ax.plot(means[:, 0], means[:, 1], "s", ms=6)[0]
        staircase(means, color=line.get_color(), lw=2, label=f"{agent} (agent)")
    point = ref.scale.reference_point
    ax.plot([point[0]], [point[1]], "kx", ms=9, label="reference point")
    ax.set_xlabel(f"{names[0]} (higher is better)")
    ax.set_ylabel(f"{names[1]} (higher is better)")
    title = f"{result.env_id}: mean per test episode"
    ax.set_title(title if len(names) == 2 else f"{title} (first two of {len(names)} objectives)", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _env_ids(envs: str | Sequence[str]) -> list[str]:
    if envs == "all":
        return mo_ids()
    return [envs] if isinstance(envs, str) else list(envs)


def evaluate_mo(
    agents: Mapping[str, MOAgent],
    envs: str | Sequence[str] = "all",
    seeds: Sequence[int] | None = None,
    references: str | Path | None = None,
    out: str | Path | None = None,
    episode_timeout: float | None = None,
) -> MOEvaluation:
    """Evaluate multi-objective agents on vector-reward ids against the shipped reference point and fronts.

    Args:
        agents: Agent name -> a set of policies (a sequence, or one ``module:attr`` naming a list) or a
            weight-conditioned factory ``factory(env, weights=w, seed=S)``.
        envs: ``"all"`` (every vector-reward id with a declared evaluation) or ids.
        seeds: The training seeds (each builds the whole set; none: one run).
        references: A folder holding ``<name>.mo.json`` instead of the domains' shipped files.
        out: If given, write ``score.json`` (its ``"mo"`` section), ``mo_episodes.csv`` and the Pareto plots
            (once every run has succeeded: a failed agent leaves no file).
        episode_timeout: Seconds an agent may take for one test episode (None: no limit).

    Raises:
        ConfigError: An id with no vector reward or no shipped reference.
        ReferenceMismatchError: A reference measured on another protocol.
        AgentError: An agent failed (its factory or a policy raised, acted out of the action space, ran past
            ``episode_timeout``, scored non-finite objectives): the agent, the id, the seed, episode and step.
    """
    if not agents:
        raise ConfigError("no agent to evaluate: give at least one `NAME=POLICY`")
    check_timeout(episode_timeout)
    results = {}
    for env_id in _env_ids(envs):
        reference = load(env_id, references)
        if reference is None:
            raise ConfigError(
                f"`{env_id}` ships no multi-objective reference (`{slug(env_id)}.mo.json`): regenerate it with "
                "`python scripts/export_mo_references.py`, or pass `--references DIR`"
            )
        runs = {name: run_agent(env_id, name, agent, seeds, episode_timeout) for name, agent in agents.items()}
        results[env_id] = MOResult(env_id, reference, runs)
    evaluation = MOEvaluation(results)
    if out is not None:
        evaluation.save(out)
    return evaluation


def agents_of(policies: Sequence[str]) -> dict[str, MOAgent]:
    """``[NAME=]POLICY`` arguments grouped into sets by name (an unnamed policy joins the set ``agent``).

    A name given once is that one policy string (a ``module:attr`` weight-conditioned factory, or a list).
    """
    agents: dict[str, list[str]] = {}
    for policy in policies:
        name, sep, ref = policy.partition("=")
        name, ref = (name, ref) if sep and ":" not in name else ("agent", policy)
        agents.setdefault(name, []).append(ref)
    return {name: refs[0] if len(refs) == 1 else refs for name, refs in agents.items()}
