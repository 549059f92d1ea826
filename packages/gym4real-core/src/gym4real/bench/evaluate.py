"""``gym4real evaluate``: score your own agent on the suite's test protocols, beside the reference runs.

Each agent runs the test protocol of each environment (the one ``gym4real.benchmark(env, episodes="test")``
runs), once per training seed, and is compared, without retraining anything, with the reference runs the
environment's domain ships (:mod:`gym4real.bench.reference`: the paper agents' and baselines' per-episode
scores, refused when measured on another protocol than the installed one). Baselines the reference runs
lack, or all of them when the domain ships none, are run here.

Per environment: the IQM of the per-episode objective with its seed-level interval, the same on the
suite's normalised scale, the probability of improvement over each reference agent and over the best
rule-based baseline, where the agent's IQM sits in each reference policy's scores, and for each upper
reference its kind (exact, heuristic with its measured gap, or not a bound) and, for a bound, the agent's
shortfall from it and the share of the headroom it closed (:mod:`gym4real.bench.upper_reference`). Over the
suite: the IQM of the normalised runs with a stratified bootstrap, the shortfall below the best rule, each
env's normalised score and the performance profile (:mod:`gym4real.bench.suite_score`), for the agent and
for each reference agent.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd

from gym4real.bench import stats, suite_score, upper_reference
from gym4real.bench.agent_errors import AgentError, agent_label, blame, check_timeout
from gym4real.bench.benchmark import benchmark, protocol, run_episode
from gym4real.bench.policies import build_policy, check_policy, is_user_object, make_policy, user_policy
from gym4real.bench.reference import check_fingerprint, fingerprint, load_reference
from gym4real.bench.seeds import SeedRequest, check_seed_count
from gym4real.bench.seeds import seeds as plan_seeds
from gym4real.core.errors import ConfigError
from gym4real.core.registry import MARK, baseline_names, list_envs, load_object, non_causal, registry, slug

PolicyRef = str | Callable[..., Any]
#: What ``evaluate`` takes per agent: a policy string or factory for every env (``{env}``/``{seed}`` filled in a
#: string), a sequence of them (one per seed), or a mapping env id -> policy (or a sequence, one per seed).
Agent = PolicyRef | Sequence[PolicyRef] | Mapping[str, PolicyRef | Sequence[PolicyRef]]
Builder = Callable[[gym.Env[Any, Any]], Callable[[Any], Any]]


@dataclass
class EnvResult:
    """One environment's scores: the agents', the reference agents' and the baselines'.

    Attributes:
        env_id: The environment.
        scale: Its normalisation (:class:`~gym4real.bench.suite_score.Scale`).
        scores: Policy -> per-episode objective ``(seeds, episodes)``.
        kinds: Policy -> ``agent`` (evaluated here), ``reference`` (a paper agent), ``baseline``, or ``upper``
            (a non-causal upper reference, ``hindsight``: never an anchor, the agent's headroom is measured to it).
        seeds: Policy -> its training seeds (empty for a baseline).
        episodes: Every episode of the agents: seed, episode, objective, return, reward components.
        reference: Where the reference runs came from, or why there are none.
    """

    env_id: str
    scale: suite_score.Scale
    scores: dict[str, np.ndarray]
    kinds: dict[str, str]
    seeds: dict[str, list[int]]
    episodes: pd.DataFrame
    reference: str
    _records: dict[str, dict[str, Any]] = field(default_factory=dict, repr=False)

    def record(self, agent: str) -> dict[str, Any]:
        """The agent's entry of ``score.json`` for this environment (computed once: the bootstrap is seeded)."""
        if agent not in self._records:
            self._records[agent] = self._record(agent)
        return self._records[agent]

    def _record(self, agent: str) -> dict[str, Any]:
        matrix = self.scores[agent]
        iqm, low, high = stats.iqm_ci(matrix, trained=True)
        entry: dict[str, Any] = {"seeds": matrix.shape[0], "episodes": matrix.shape[1], "iqm": iqm}
        entry.update(iqm_low=low, iqm_high=high, normalized_iqm=None, low=None, high=None, scale=self.scale.record())
        if self.scale.usable:
            value, n_low, n_high = (float(v) for v in self.scale.normalise([iqm, low, high]))
            entry.update(normalized_iqm=value, low=n_low, high=n_high)
        else:
            entry["note"] = f"not normalised: {self.scale.note}"
        others = [p for p, kind in self.kinds.items() if kind == "reference"]
        if self.scale.best is not None:
            others.append(self.scale.best)
        improvement, intervals = {}, {}
        for other in others:
            p, p_low, p_high = stats.probability_of_improvement(
                matrix, self.scores[other], True, self.kinds[other] != "baseline"
            )
            improvement[other], intervals[other] = p, [p_low, p_high]
        entry["probability_of_improvement"] = improvement
        entry["probability_of_improvement_ci"] = intervals
        entry["profile_position"] = {
            p: float(np.mean(self.scores[p] > iqm)) for p, kind in self.kinds.items() if kind != "agent"
        }
        uppers = [p for p, kind in self.kinds.items() if kind == "upper"]
        entry["upper_references"] = {p: _kind(self.env_id, p) for p in uppers}
        bounds = [p for p in uppers if p in upper_reference.bound_references(self.env_id)]
        entry["headroom"] = {p: upper_reference.headroom(self.scores[p], matrix) for p in bounds}
        entry["headroom_closed"] = {
            p: upper_reference.headroom_closed(self.scores[p], self.scores[suite_score.ZERO], matrix)
            for p in bounds
            if suite_score.ZERO in self.scores and stats.iqm(self.scores[p]) > stats.iqm(self.scores[suite_score.ZERO])
        }
        return entry


@dataclass
class Evaluation:
    """What :func:`evaluate` found: per environment, and over the suite."""

    agents: list[str]
    envs: dict[str, EnvResult] = field(default_factory=dict)
    _aggregates: dict[str, dict[str, Any]] = field(default_factory=dict, repr=False)

    def references(self) -> list[str]:
        """The reference agents (paper agents) found on any environment."""
        return list(dict.fromkeys(p for r in self.envs.values() for p, k in r.kinds.items() if k == "reference"))

    def runs(self, policy: str) -> dict[str, tuple[np.ndarray, suite_score.Scale]]:
        """Env id -> the policy's scores and the env's scale, on the environments that have a scale."""
        return {e: (r.scores[policy], r.scale) for e, r in self.envs.items() if r.scale.usable and policy in r.scores}

    def aggregate(self, policy: str) -> dict[str, Any]:
        """The policy's suite score: IQM, shortfall below the best rule, their intervals, per env (computed once)."""
        if policy not in self._aggregates:
            self._aggregates[policy] = suite_score.summary(self.runs(policy))
        return self._aggregates[policy]

    def record(self, agent: str) -> dict[str, Any]:
        """The agent's score record: ``{"envs": {...}, "aggregate": {...}}``."""
        envs = {e: r.record(agent) for e, r in self.envs.items() if agent in r.scores}
        return {"envs": envs, "aggregate": self.aggregate(agent)}

    def score(self) -> dict[str, Any]:
        """The content of ``score.json``: each agent's record (the only agent's also at the top level)."""
        agents = {a: self.record(a) for a in self.agents}
        scales = {
            e: {
                "random": _finite(r.scale.random),
                "best_rule_based": r.scale.best,
                "best": _finite(r.scale.top),
                "note": r.scale.note,
                **r.scale.record(),
            }
            for e, r in self.envs.items()
        }
        out: dict[str, Any] = dict(agents[self.agents[0]]) if len(self.agents) == 1 else {}  # the shape
        out.update(
            agents=agents,
            references={p: self.aggregate(p) for p in self.references()},
            scales=scales,
            reference_runs={e: r.reference for e, r in self.envs.items()},
        )
        return out

    def table(self) -> str:
        """The comparison as text: one block per environment, then the suite scores."""
        lines = []
        for env_id, result in self.envs.items():
            lines.append(f"== {env_id}  (reference runs: {result.reference})")
            scale = result.scale
            objective = " + ".join(protocol(env_id).objective) or "the episode return"
            lines.append(f"   objective (the score, higher is better): {objective}, per test episode")
            lines.append(f"   {scale.words()}")
            records = {a: result.record(a) for a in self.agents if a in result.scores}
            heads = f"{'objective IQM [95% CI]':>36s} {'normalised IQM [95% CI]':>32s}"
            lines.append(f"   {'policy':24s} {'kind':9s} {'seeds':>5s} {heads}")
            for policy, matrix in result.scores.items():
                trained = result.kinds[policy] in ("agent", "reference")
                iqm, low, high = stats.iqm_ci(matrix, trained)
                norm = ""
                if scale.usable:
                    n, n_low, n_high = scale.normalise([iqm, low, high])
                    norm = f"{n:.3f} [{n_low:.3f}, {n_high:.3f}]"
                seeds = str(matrix.shape[0]) if trained else "-"
                lines.append(
                    f"   {policy:24s} {result.kinds[policy]:9s} {seeds:>5s} "
                    f"{f'{iqm:.5g} [{low:.5g}, {high:.5g}]':>36s} {norm:>32s}"
                )
            for agent, rec in records.items():
                for other, p in rec["probability_of_improvement"].items():
                    p_low, p_high = rec["probability_of_improvement_ci"][other]
                    lines.append(f"   P({agent} > {other}) = {p:.3f} [{p_low:.3f}, {p_high:.3f}]")
                for upper, kind in rec["upper_references"].items():
                    if upper not in rec["headroom"]:
                        lines.append(f"   {upper} ({MARK}): {kind['words']}: no headroom is measured to it")
                        continue
                    room = rec["headroom"][upper]
                    line = (
                        f"   shortfall of {agent} from {upper} ({MARK}, {kind['words']}): IQM {room['shortfall']:.5g} "
                        f"[{room['low']:.5g}, {room['high']:.5g}]"
                    )
                    closed = rec["headroom_closed"].get(upper)
                    if closed is not None:
                        line += (
                            f"; share of the headroom closed {closed['share']:.3f} "
                            f"[{closed['low']:.3f}, {closed['high']:.3f}] (0 = random, 1 = {upper})"
                        )
                    lines.append(line)
            lines.append("")
        lines.append("== suite score (normalised: 0 = random, 1 = best rule-based baseline; IQM over envs x seeds)")
        lines.append(
            f"   {'policy':24s} {'kind':9s} {'envs':>4s} {'runs':>4s} {'IQM [95% CI]':>26s} "
            f"{'shortfall below best rule':>26s}  per env"
        )
        for policy in [*self.agents, *self.references()]:
            agg = self.aggregate(policy)
            kind = "agent" if policy in self.agents else "reference"
            if agg["iqm"] is None:
                lines.append(f"   {policy:24s} {kind:9s} no environment with a normalised scale")
                continue
            value = f"{agg['iqm']:.3f} [{agg['low']:.3f}, {agg['high']:.3f}]"
            gap = f"{agg['shortfall']:.3f} [{agg['shortfall_low']:.3f}, {agg['shortfall_high']:.3f}]"
            per_env = ", ".join(f"{slug(e)} {v:.3f}" for e, v in agg["per_env"].items())
            lines.append(
                f"   {policy:24s} {kind:9s} {len(agg['envs']):>4d} {agg['runs']:>4d} {value:>26s} {gap:>26s}  {per_env}"
            )
        lines.append(
            "   intervals: 95 % stratified bootstrap, seeds and test episodes resampled within each env; an env whose "
            "anchors are not separated is left out; policies on different envs average different envs: compare "
            "them per env"
        )
        return "\n".join(lines)

    def episodes(self) -> pd.DataFrame:
        """Every policy's every test episode: env, policy, kind, seed, episode, objective, normalised score."""
        rows = []
        for env_id, result in self.envs.items():
            for policy, matrix in result.scores.items():
                normalised = result.scale.normalise(matrix) if result.scale.usable else np.full(matrix.shape, np.nan)
                seeds: list[int | None] = [*result.seeds[policy]] or [None] * matrix.shape[0]
                for row, seed in enumerate(seeds):
                    for episode in range(matrix.shape[1]):
                        rows.append(
                            {
                                "env_id": env_id,
                                "policy": policy,
                                "kind": result.kinds[policy],
                                "seed": seed,
                                "episode": episode,
                                "objective": matrix[row, episode],
                                "normalized": normalised[row, episode],
                            }
                        )
        return pd.DataFrame(rows)

    def save(self, out: str | Path) -> list[Path]:
        """Write ``score.json``, ``episodes.csv``, ``agent_episodes.csv``, the figures and ``report.md``."""
        from gym4real.bench import evaluate_report

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = [out / "score.json", out / "episodes.csv", out / "agent_episodes.csv"]
        written[0].write_text(json.dumps(self.score(), indent=1, default=float) + "\n")
        self.episodes().to_csv(written[1], index=False)
        pd.concat([r.episodes.assign(env_id=e) for e, r in self.envs.items()]).to_csv(written[2], index=False)
        written += evaluate_report.figures(self, out)
        written.append(evaluate_report.write_report(self, out, [p.name for p in written[3:]]))
        return written


def _kind(env_id: str, name: str) -> dict[str, Any]:
    """An upper reference's kind for ``score.json``: ``bound`` (exact, heuristic, not a bound), ``gap``, words, note."""
    from gym4real.core.registry import upper_reference as spec_of

    spec = spec_of(env_id, name)
    return {"bound": spec.bound, "gap": spec.gap, "words": spec.bound_words(), "note": spec.bound_note}


def _finite(value: float) -> float | None:
    """A number for JSON: None for NaN (an anchor the environment lacks)."""
    return float(value) if np.isfinite(value) else None


def _env_ids(envs: str | Sequence[str]) -> list[str]:
    if envs == "all":
        return [e for e in list_envs(multi_objective=False) if e in registry().benchmarks]
    if isinstance(envs, str):
        return [envs]
    return list(envs)


def _filled(ref: str, env_id: str, seed: int) -> str:
    return ref.replace("{env}", slug(env_id)).replace("{seed}", str(seed))


def _of_policy(env_id: str, ref: PolicyRef) -> Builder:
    return lambda env: make_policy(env_id, ref, env)


def _of_factory(factory: Callable[..., Any], name: str, seed: int | None) -> Builder:
    return lambda env: build_policy(factory, env, name, seed)


def _of_string(ref: str, env_id: str, seed: int | None) -> Builder:
    """A policy string with ``{env}`` and ``{seed}`` filled in, checked now (:func:`check_policy`).

    A ``module:attr`` factory gets the seed.
    """
    filled = _filled(ref, env_id, seed or 0)
    check_policy(env_id, filled)
    if is_user_object(filled):
        return lambda env: user_policy(filled, env, seed)
    return _of_policy(env_id, filled)


def _labels(name: str, count: int, seeds: Sequence[int] | None) -> list[int]:
    if seeds is not None and len(seeds) != count:
        raise ConfigError(f"agent `{name}` has {count} policies (one per seed) but {len(seeds)} seeds")
    return list(seeds) if seeds is not None else list(range(count))


def _builders(name: str, agent: Agent, env_id: str, seeds: Sequence[int] | None) -> list[tuple[int, Builder]]:
    """``(seed, build)`` per training seed of an agent on ``env_id``; ``build(env)`` returns the policy."""
    if isinstance(agent, Mapping):  # policies, given per env (a sequence: one per seed)
        if env_id not in agent:
            return []
        per_env = agent[env_id]
        refs = list(per_env) if isinstance(per_env, Sequence) and not isinstance(per_env, str) else [per_env]
        return [
            (s, _of_policy(env_id, r) if callable(r) else _of_string(r, env_id, None))
            for s, r in zip(_labels(name, len(refs), seeds), refs, strict=True)
        ]
    if isinstance(agent, Sequence) and not isinstance(agent, str):  # factories, one per seed
        return [
            (s, _of_factory(f, name, None) if callable(f) else _of_string(f, env_id, None))
            for s, f in zip(_labels(name, len(agent), seeds), agent, strict=True)
        ]
    if isinstance(agent, str):
        if seeds is not None and len(seeds) > 1 and not is_user_object(agent) and "{seed}" not in agent:
            raise ConfigError(
                f"agent `{name}` (`{agent}`) names no `{{seed}}`, so every seed would be the same policy: "
                "write the seed into the path (`sb3:a2c:runs/{env}/seed{seed}/model.zip`), or evaluate one seed"
            )
        return [(s, _of_string(agent, env_id, s if seeds is not None else None)) for s in (seeds or [0])]
    if callable(agent):
        return [(s, _of_factory(agent, name, s if seeds is not None else None)) for s in (seeds or [0])]
    raise ConfigError(f"agent `{name}` is a {type(agent).__name__}; expected a policy string, a factory or a mapping")


def _run_agent(
    name: str,
    label: str,
    env_id: str,
    builders: list[tuple[int, Builder]],
    kwargs: dict[str, Any],
    plan: list[dict[str, Any]],
    timeout: float | None = None,
) -> tuple[np.ndarray, pd.DataFrame]:
    """Run each seed's policy on the test episodes; return the objective matrix and every episode's row.

    Raises:
        AgentError: The agent (``label``) failed, naming the env, seed, test episode and step
            (:func:`~gym4real.bench.agent_errors.blame`), or scored a non-finite objective.
    """
    objective = protocol(env_id).objective
    rows = []
    for seed, build in builders:
        where = f"agent `{label}` on `{env_id}` (seed {seed})"
        env = gym.make(env_id, **kwargs)
        try:
            with blame(where):
                policy = build(env)
            for i, episode in enumerate(plan):
                at = f"{where}, test episode {i} (reset seed {episode.get('seed')})"
                with blame(at, timeout):
                    run = run_episode(env, policy, episode.get("seed"), episode.get("options"))
                ret = float(run["rewards"].sum())
                value = float(sum(run["components"].get(c, 0.0) for c in objective)) if objective else ret
                if not np.isfinite(value):
                    raise AgentError(
                        f"{at}: its objective is {value} (the env's reward components: {run['components']}); fix "
                        "the actions that drive the env there"
                    )
                rows.append(
                    {"policy": name, "seed": seed, "episode": i, "objective": value, "return": ret, **run["components"]}
                )
        finally:
            env.close()
    frame = pd.DataFrame(rows)
    matrix = frame.pivot(index="seed", columns="episode", values="objective").loc[[s for s, _ in builders]]
    return matrix.to_numpy(dtype=float), frame


def _reference_note(env_id: str, references: str | Path | None) -> str:
    if references is not None:
        return f"none in `{references}`: compared with the baselines run now"
    plugin = registry().owners.get(env_id, "")
    dist, version = registry().distributions.get(plugin, ("its domain", "?"))
    return f"none shipped with {dist} {version}: compared with the baselines run now"


def _prepare(
    policies: Mapping[str, Agent],
    env_id: str,
    seeds: SeedRequest,
    references: str | Path | None,
    allow_non_causal: bool,
) -> dict[str, list[tuple[int, Builder]]]:
    """Each agent's ``(seed, build)`` on ``env_id``, every policy string checked: what can be refused before a run.

    Raises:
        ConfigError: An agent named like a baseline or reference policy of the env, a non-causal baseline given
            as an agent, or policies and seeds that do not match.
        PolicyError: A policy string that names no policy (:func:`~gym4real.bench.policies.check_policy`).
    """
    seed_list = None if seeds is None else plan_seeds(env_id, "paper", seeds)
    reference = load_reference(env_id, references)
    taken = {*baseline_names(env_id), *(reference.scores if reference is not None else ())}
    prepared = {}
    for name, agent in policies.items():
        upper_reference.check_agent(
            env_id, name, agent.get(env_id) if isinstance(agent, Mapping) else agent, allow_non_causal
        )
        if name in taken:
            raise ConfigError(
                f"agent name `{name}` is taken by a baseline or reference agent of `{env_id}`; name your agent "
                f"otherwise (`NAME={name}` on the command line)"
            )
        prepared[name] = _builders(name, agent, env_id, seed_list)
    return prepared


def evaluate(
    policies: Mapping[str, Agent],
    envs: str | Sequence[str] = "all",
    seeds: SeedRequest = None,
    references: str | Path | None = None,
    out: str | Path | None = None,
    allow_non_causal: bool = False,
    headroom: bool = True,
    episode_timeout: float | None = None,
) -> Evaluation:
    """Evaluate agents on the suite's test protocols and compare them with the reference runs.

    Args:
        policies: Agent name -> the agent: a policy string (a baseline, ``sb3:ALGO:PATH``, ``ppo:PATH``, ...,
            or your ``module:attr``, imported; ``{env}`` and ``{seed}`` in it are replaced by the env's name,
            ``dam-v0``, and the seed), or a factory ``factory(env) -> policy`` (``factory(env, seed=S)`` when
            ``seeds`` is given), for every environment; a sequence of those, one per training seed; or a
            mapping env id -> policy (or a sequence, one per seed). The training seed is the unit of
            replication, as in the reference runs. Empty: only the reference agents are scored (their suite
            scores, for a results page).
        envs: ``"all"`` (every installed environment with a test protocol) or env ids.
        seeds: The training seeds (labels of the runs; a single string or factory is built once per seed): a
            number N, the first N seeds of each environment's plan, as ``gym4real reproduce --seeds N`` trains
            them (the paper's, then 0, 1, ...), or the seeds themselves.
        references: A folder of reference files to use instead of those the domains ship.
        out: If given, write ``score.json``, the CSVs, figures and ``report.md`` there (only once every run
            has succeeded: a failed agent leaves no file).
        allow_non_causal: Accept a non-causal upper reference (``hindsight``) as an agent; it is refused
            otherwise, as it knows the episode's exogenous data. The environments' upper references are
            run beside the agents in any case (kind ``upper``), and each agent's shortfall from them is its
            ``headroom``.
        headroom: Run the upper references the reference runs lack (their plans are cached; the first run of
            a planner can take minutes: elevator's about 6 CPU minutes); False: only those the reference runs
            hold are reported.
        episode_timeout: Seconds an agent may take for one test episode (None: no limit); see
            :func:`~gym4real.bench.agent_errors.time_limit`.

    Raises:
        ReferenceMismatchError: A domain's reference runs were measured on another protocol.
        PolicyError: A policy string that names no policy (refused before anything runs).
        AgentError: An agent failed (its factory or policy raised, it acted out of the action space, ran past
            ``episode_timeout``...): the agent, the env, the seed, test episode and step, and the fix.
        ConfigError: An agent named like a reference policy, or policies and seeds that do not match.
    """
    check_seed_count(seeds)
    check_timeout(episode_timeout)
    ids = _env_ids(envs)
    for env_id in ids:
        protocol(env_id)  # an unknown id, or one without a test protocol, before anything runs
    prepared = {env_id: _prepare(policies, env_id, seeds, references, allow_non_causal) for env_id in ids}
    evaluation = Evaluation(list(policies))
    for env_id in ids:
        spec = protocol(env_id)
        kwargs = dict(spec.env_kwargs)
        plan = load_object(spec.protocol)(dict(kwargs))
        env = gym.make(env_id, **kwargs)
        try:
            installed = fingerprint(env_id, env)
        finally:
            env.close()
        reference = load_reference(env_id, references)
        scores: dict[str, np.ndarray] = {}
        kinds: dict[str, str] = {}
        run_seeds: dict[str, list[int]] = {}
        if reference is not None:
            check_fingerprint(reference, installed)
            for policy, matrix in reference.scores.items():
                scores[policy] = matrix
                run_seeds[policy] = reference.seeds[policy]
                kinds[policy] = "reference" if reference.seeds[policy] else "baseline"
                if policy in non_causal(env_id):
                    kinds[policy] = "upper"
        agents: dict[str, tuple[list[int], np.ndarray, pd.DataFrame]] = {}  # run first: a failing agent fails early
        for name, agent in policies.items():
            if builders := prepared[env_id][name]:
                label = agent_label(name, agent.get(env_id) if isinstance(agent, Mapping) else agent)
                matrix, frame = _run_agent(name, label, env_id, builders, kwargs, plan, episode_timeout)
                agents[name] = ([s for s, _ in builders], matrix, frame)
        registered = baseline_names(env_id)
        upper = [b for b in non_causal(env_id) if b not in scores]
        missing_upper = upper if headroom else []
        missing = [
            b
            for b in dict.fromkeys(("random", *spec.policies))
            if b in registered and b not in scores and b not in upper
        ]
        if missing:
            result = benchmark(env_id, missing, episodes="test")
            for b in missing:
                scores[b], kinds[b], run_seeds[b] = (
                    np.asarray(result.objective_values(b), dtype=float)[None],
                    "baseline",
                    [],
                )
        if missing_upper:
            result = benchmark(env_id, missing_upper, episodes="test")
            for b in missing_upper:
                scores[b], kinds[b], run_seeds[b] = np.asarray(result.objective_values(b), float)[None], "upper", []
        frames = []
        for name, (agent_seeds, matrix, frame) in agents.items():
            scores[name], kinds[name], run_seeds[name] = matrix, "agent", agent_seeds
            frames.append(frame)
        anchors = {p: m for p, m in scores.items() if kinds[p] == "baseline"}
        evaluation.envs[env_id] = EnvResult(
            env_id,
            suite_score.scale(env_id, anchors, spec.rule_based),
            scores,
            kinds,
            run_seeds,
            pd.concat(frames) if frames else pd.DataFrame(),
            f"{reference.budget} budget, {reference.source}"
            if reference is not None
            else _reference_note(env_id, references),
        )
    if out is not None:
        evaluation.save(out)
    return evaluation
