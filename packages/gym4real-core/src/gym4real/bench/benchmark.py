"""The benchmark harness: run named policies on an environment's evaluation protocol.

``benchmark()`` returns a :class:`BenchmarkResult` whose ``returns`` maps each policy to its episode
returns and ``components`` maps policy -> reward component -> per-episode sums. A policy is keyed as it
was given (a model file as ``kind:path``); tables and figures show its short label (``labels``).

**One score.** The score of a policy is the protocol's objective (the sum of its reward components per
episode; the return where the protocol names none), higher is better, summarised by its interquartile mean
(IQM) with a 95 % bootstrap interval: what ``gym4real evaluate``, the suite score and the results page
rank by. The table and the figures rank and plot the objective; the return (the training reward) is a
column of its own, labelled so, and only where it differs from the objective.

``save()`` writes the per-episode CSV, a JSON record, a summary table and the paper's two figures (mean
cumulative objective with a 95 % band, boxplot of the episode objective).
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

from gym4real.bench import stats
from gym4real.bench.agent_errors import EpisodeTimeout, action_failure, agent_label, blame, code_failure
from gym4real.bench.policies import check_policy, make_policy
from gym4real.bench.progress import ProgressDisplay
from gym4real.core.errors import ActionError, ConfigError
from gym4real.core.registry import (
    MARK,
    base_env,
    baseline_names,
    env_spec,
    load_object,
    non_causal,
    registry,
    upper_reference,
)
from gym4real.core.specs import BenchmarkSpec
from gym4real.wrappers.multi_objective import MultiObjective

PolicyRef = str | Callable[[Any], Any]

#: Below this many episodes per policy the table warns that its bootstrap CI and IQM mean little: the
#: percentile bootstrap covers the mean far less often than 95 % on small samples, and the IQM of fewer
#: than 4 values is a plain mean.
FEW_EPISODES = 10


def policy_name(ref: PolicyRef) -> str:
    """The key of a policy in a result: the string as given, or a callable's name."""
    return ref if isinstance(ref, str) else getattr(ref, "__name__", type(ref).__name__)


def short_label(name: str) -> str:
    """The label of a policy in tables and figures: a model file ``kind:path`` by its run folder or file name.

    ``qlearning:runs/elevator-v0/qlearning-paper-seed0/qtable.npz`` -> ``qlearning-paper-seed0``
    (a run folder of ``gym4real train`` names the algorithm, preset and seed); ``ppo:models/best.zip`` ->
    ``ppo:best``; a baseline name is its own label.
    """
    kind, sep, path = name.partition(":")
    if not sep:
        return name
    file = Path(path)
    return file.parent.name if file.parent.name.startswith(kind) else f"{kind}:{file.stem}"


def labels_of(names: Sequence[str]) -> dict[str, str]:
    """Short labels of policy keys; keys whose labels would collide keep their full name."""
    short = {n: short_label(n) for n in names}
    return {n: label if list(short.values()).count(label) == 1 else n for n, label in short.items()}


def number_format(values: Sequence[float]) -> Callable[[float], str]:
    """One fixed-point format for a table's numbers, with decimals for about four significant digits of the largest."""
    finite = [abs(v) for v in values if np.isfinite(v)]
    largest = max(finite, default=0.0)
    decimals = int(np.clip(3 - np.floor(np.log10(largest)), 0, 6)) if largest > 0 else 0
    return lambda v: f"{v:,.{decimals}f}"


@dataclass
class BenchmarkResult:
    """Outcome of :func:`benchmark`; every mapping is keyed by policy name."""

    env_id: str
    episodes: list[dict[str, Any]]
    returns: dict[str, list[float]] = field(default_factory=dict)
    components: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    rewards: dict[str, list[np.ndarray]] = field(default_factory=dict)
    objective_rewards: dict[str, list[np.ndarray]] = field(default_factory=dict)  # per step, when objective set
    final_info: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    objective: tuple[str, ...] = ()
    step_unit: str = "step"
    objectives: tuple[str, ...] = ()  # a vector-reward id's reward entries, in order: one table column each
    description: str = ""  # the episodes run: the test protocol's description, or "N seeded episodes"
    test_protocol: bool = False  # whether the episodes are the env's test protocol
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # the make() arguments of the episodes
    planned: dict[str, list[float]] = field(default_factory=dict)  # a planner's own objective of each episode

    @property
    def labels(self) -> dict[str, str]:
        """Policy key -> the short label tables and figures show (see :func:`short_label`)."""
        return labels_of(list(self.returns))

    def objective_values(self, policy: str) -> list[float]:
        """Per-episode sum of the objective's components (the return when no objective is set)."""
        if not self.objective:
            return self.returns[policy]
        comps = self.components[policy]
        return [float(sum(comps[c][i] for c in self.objective)) for i in range(len(self.returns[policy]))]

    def objective_steps(self, policy: str) -> list[np.ndarray]:
        """Per episode, the objective of each step (the reward when no objective is set)."""
        return self.objective_rewards[policy] if self.objective else self.rewards[policy]

    @property
    def objective_name(self) -> str:
        """What the objective sums, for labels: ``deficit + overflow + starving``, or ``return``."""
        return " + ".join(self.objective) if self.objective else "return"

    @property
    def objective_is_return(self) -> bool:
        """Whether the objective and the return (training reward) are the same quantity in every episode."""
        return all(
            np.allclose(self.objective_values(name), rets, rtol=stats.RTOL, atol=0.0)
            for name, rets in self.returns.items()
        )

    def score(self, policy: str) -> tuple[float, float, float]:
        """The policy's score: IQM of its per-episode objective and its 95 % bootstrap interval (episodes resampled).

        The statistic and interval of ``gym4real evaluate`` and the results page for a policy with one run.
        """
        return stats.iqm_ci(np.asarray(self.objective_values(policy), dtype=float)[None], trained=False)

    def ranking(self) -> list[str]:
        """The policies, best first by the IQM of their objective, as :meth:`score` (ties in the order given)."""
        scores = {name: stats.iqm(self.objective_values(name)) for name in self.returns}
        return sorted(scores, key=lambda name: -scores[name])

    def protocol_lines(self) -> list[str]:
        """What was run, for the head of the table: the episodes, their seeds, ``make()`` arguments, objective."""
        seeds = [e.get("seed") for e in self.episodes]
        kwargs = ", ".join(f"{k}={v}" for k, v in self.env_kwargs.items()) or "none"
        where = "test protocol" if self.test_protocol else "not the test protocol"
        objective = (
            f"objective (the score): {self.objective_name} per episode, higher is better"
            if not self.objective_is_return
            else "objective (the score): the episode return (training reward) itself, higher is better"
        )
        return [
            f"{self.env_id}, {where}: {self.description}",
            f"  {len(self.episodes)} episode(s) per policy, reset seeds {_seeds_text(seeds)}; "
            f"make() arguments: {kwargs}",
            f"  {objective}; policies ranked by its IQM (as `gym4real evaluate` and the results page rank)",
        ]

    def summary(self) -> pd.DataFrame:
        """One row per policy (by label), best first: the objective's IQM with its 95 % interval, mean and std.

        The return (training reward) has its own columns (``return_mean``, ``return_std``) where it differs
        from the objective; then each reward component's and final ``info`` value's mean.
        """
        rows = []
        labels = self.labels
        separate_return = not self.objective_is_return
        for rank, name in enumerate(self.ranking(), start=1):
            values = self.objective_values(name)
            iqm, low, high = self.score(name)
            row: dict[str, Any] = {
                "policy": labels[name],
                "rank": rank,
                "episodes": len(values),
                "objective_iqm": iqm,
                "objective_low": low,
                "objective_high": high,
                "objective_mean": float(np.mean(values)),
                "objective_std": float(np.std(values)),
            }
            if separate_return:
                row["return_mean"] = float(np.mean(self.returns[name]))
                row["return_std"] = float(np.std(self.returns[name]))
            for comp, vals in self.components[name].items():
                row[f"{comp}_mean"] = float(np.mean(vals))
            for key, vals in self.final_info.get(name, {}).items():
                row[f"final_{key}_mean"] = float(np.nanmean(vals)) if np.isfinite(vals).any() else np.nan
            rows.append(row)
        return pd.DataFrame(rows).set_index("policy")

    def table(self) -> str:
        """The protocol run, then the summary as a fixed-width text table (best first), with notes on its columns."""
        cols = ["episodes", "objective_iqm", "objective_low", "objective_high", "objective_mean", "objective_std"]
        separate_return = not self.objective_is_return
        if separate_return:
            cols.append("return_mean")
        cols += [f"{o}_mean" for o in self.objectives]
        frame = self.summary()[cols]
        numbers = frame.drop(columns="episodes").to_numpy(dtype=float).ravel().tolist()
        notes = [
            f"objective_iqm: interquartile mean of the per-episode objective ({self.objective_name}), the score; "
            "objective_low/high: its 95 % bootstrap interval (episodes resampled); objective_mean/std: mean and "
            "standard deviation over the episodes"
        ]
        if separate_return:
            notes.append("return_mean: mean episode return (training reward), not the score")
        if self.objectives:
            names = ", ".join(f"{o}_mean" for o in self.objectives)
            notes.append(f"{names}: mean per-episode sum of each entry of the vector reward")
        notes += _planned_notes(self)
        fewest = int(frame["episodes"].min()) if len(frame) else 0
        if fewest < FEW_EPISODES:
            notes.append(
                f"warning: {fewest} episode(s) per policy: bootstrap CIs and the IQM mean little below {FEW_EPISODES}"
            )
        body = frame.to_string(float_format=number_format(numbers))
        return "\n".join([*self.protocol_lines(), "", body, *(f"  {n}" for n in notes)])

    def per_episode(self) -> pd.DataFrame:
        """One row per (policy, episode) with return, objective, components and final info."""
        rows = []
        labels = self.labels
        for name, rets in self.returns.items():
            objective = self.objective_values(name)
            for i, ret in enumerate(rets):
                row: dict[str, Any] = {
                    "policy": labels[name],
                    "episode": i,
                    **_jsonable(self.episodes[i]),
                    "return": ret,
                    "objective": objective[i],
                }
                row.update({c: v[i] for c, v in self.components[name].items()})
                row.update({f"final_{k}": v[i] for k, v in self.final_info.get(name, {}).items()})
                if name in self.planned:
                    row["planned_objective"] = self.planned[name][i]
                rows.append(row)
        return pd.DataFrame(rows)

    def save(self, out: str | Path) -> list[Path]:
        """Write ``episodes.csv``, ``summary.csv``, ``results.json`` and the two figures into ``out``."""
        from gym4real.bench import plots

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = [out / "episodes.csv", out / "summary.csv", out / "results.json"]
        self.per_episode().to_csv(written[0], index=False)
        self.summary().to_csv(written[1])
        record = {
            "env_id": self.env_id,
            "labels": self.labels,  # policy as given (a model file's path) -> label in the tables and figures
            "step_unit": self.step_unit,
            "objective": list(self.objective),
            "objective_is_return": self.objective_is_return,
            "protocol": {"test": self.test_protocol, "description": self.description, "env_kwargs": self.env_kwargs},
            "ranking": [self.labels[name] for name in self.ranking()],  # best first by the objective's IQM
            "episodes": [_jsonable(e) for e in self.episodes],
            "returns": self.returns,
            "components": self.components,
            "final_info": {  # null where an episode ended without the value
                name: {k: [v if np.isfinite(v) else None for v in vals] for k, vals in finals.items()}
                for name, finals in self.final_info.items()
            },
            "planned": self.planned,
        }
        written[2].write_text(json.dumps(record, indent=1, default=str))
        written += plots.save_figures(self, out)
        spec = registry().benchmarks.get(base_env(self.env_id))
        if spec is not None and spec.figures:
            written += list(load_object(spec.figures)(self, out))
        return written


def _seeds_text(seeds: Sequence[Any]) -> str:
    """Reset seeds for people: ``0..12`` for a run of consecutive ones, else the first few."""
    if not seeds or all(s is None for s in seeds):
        return "none"
    if all(isinstance(s, int) for s in seeds) and list(seeds) == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}..{seeds[-1]}" if len(seeds) > 1 else str(seeds[0])
    shown = ", ".join(str(s) for s in seeds[:5])
    return shown + (", ..." if len(seeds) > 5 else "")


def _planned_notes(result: BenchmarkResult) -> list[str]:
    """Per planner (an upper reference): its planned objective beside the replayed one, and what it is."""
    notes = [
        f"{result.labels[name]}: {MARK} ({upper_reference(result.env_id, name).bound_words()}), knows what no agent "
        "can know in advance (not a baseline to beat)"
        for name in result.returns
        if name in non_causal(result.env_id)
    ]
    for name, planned in result.planned.items():
        replayed = result.objective_values(name)
        gap = float(np.mean(np.asarray(replayed) - np.asarray(planned)))
        notes.append(
            f"{result.labels[name]}: planned objective mean {np.mean(planned):,.6g} (the planner's own estimate), "
            f"replayed {np.mean(replayed):,.6g} (replayed - planned: {gap:+.4g} per episode)"
        )
    return notes


def _jsonable(episode: Mapping[str, Any]) -> dict[str, Any]:
    return {"seed": episode.get("seed"), "options": json.dumps(episode.get("options") or {}, default=str)}


def seeded_episodes(n: int, seed: int = 0) -> list[dict[str, Any]]:
    """``n`` episodes with seeds ``seed, seed + 1, ...`` and no options."""
    return [{"seed": seed + i, "options": None} for i in range(n)]


def protocol(env_id: str) -> BenchmarkSpec:
    """Return the registered evaluation protocol of an environment (a vector-reward variant: its env's).

    Raises:
        EnvUnavailableError: The id is not registered (:func:`~gym4real.core.registry.env_spec`'s error).
        ConfigError: The env registers no protocol.
    """
    env_spec(env_id)
    spec = registry().benchmarks.get(base_env(env_id))
    if spec is None:
        raise ConfigError(f'`{env_id}` registers no evaluation protocol; pass `episodes=N` instead of "test"')
    return spec


def run_episode(
    env: gym.Env[Any, Any],
    policy: Callable[[Any], Any],
    seed: int | None,
    options: dict[str, Any] | None,
    final_keys: Sequence[str] = (),
    observer: Callable[[int, float], None] | None = None,
    objective: Sequence[str] = (),
) -> dict[str, Any]:
    """Run one episode; return its per-step rewards, component sums and final ``info`` values.

    With ``objective`` (reward components), ``objective_rewards`` holds their sum at each step.

    ``observer(step, score_so_far)``, if given, is called after the reset (step 0) and after each step, with
    the objective so far (the return so far without ``objective``).
    The reward of a vector-reward env is its ``info["scalar_reward"]``; its entries are the components.

    Raises:
        PolicyFailure: The policy raised (or its ``reset``), or its action is not in the action space, naming
            the step and the fix (:mod:`gym4real.bench.agent_errors`); the environment's own errors pass unchanged.
        EpisodeTimeout: From an enclosing :func:`~gym4real.bench.agent_errors.time_limit`, with the step reached.
    """
    reset = getattr(policy, "reset", None)
    if reset is not None:
        try:
            reset(seed)
        except (Exception, SystemExit) as exc:
            raise code_failure("reset", "its reset(seed)", exc) from exc
    obs, info = env.reset(seed=seed, options=options)
    rewards: list[float] = []
    steps_objective: list[float] = []
    comps: dict[str, float] = {}
    done = False
    total = 0.0
    if observer is not None:
        observer(0, total)
    while not done:
        try:
            action = policy(obs)
        except (Exception, SystemExit) as exc:
            raise code_failure(len(rewards), "its policy", exc) from exc
        except EpisodeTimeout as exc:
            exc.step = len(rewards)
            raise
        try:
            obs, reward, terminated, truncated, info = env.step(action)
        except ActionError as exc:
            raise action_failure(len(rewards), exc, env) from exc
        except EpisodeTimeout as exc:
            exc.step = len(rewards)
            raise
        rewards.append(float(info.get("scalar_reward", reward)))
        step_comps = info.get("reward_components", {})
        for key, value in step_comps.items():
            comps[key] = comps.get(key, 0.0) + float(value)
        if objective:
            steps_objective.append(sum(float(step_comps.get(key, 0.0)) for key in objective))
        if observer is not None:
            total += steps_objective[-1] if objective else rewards[-1]
            observer(len(rewards), total)
        done = terminated or truncated
    final = {k: float(info[k]) for k in final_keys if k in info}
    return {
        "rewards": np.asarray(rewards),
        "objective_rewards": np.asarray(steps_objective),
        "components": comps,
        "final": final,
    }


def benchmark(
    env_id: str,
    policies: Sequence[PolicyRef] | None = None,
    episodes: int | str = "test",
    seed: int = 0,
    env_kwargs: Mapping[str, Any] | None = None,
    progress: bool = False,
    out: str | Path | None = None,
) -> BenchmarkResult:
    """Run policies on an environment and collect their returns and reward components.

    Args:
        env_id: A registered id.
        policies: Baseline names, ``kind:path`` model files or callables ``obs -> action``; defaults to the
            baselines of the environment's protocol (or every registered baseline).
        episodes: ``"test"`` for the paper's evaluation protocol, or a number of seeded episodes.
        seed: First seed of numbered episodes.
        env_kwargs: Keyword arguments of ``gymnasium.make`` (added to the protocol's).
        progress: Show a progress bar.
        out: If given, write the results and figures there.
    """
    env_spec(env_id)  # a clear error for an unknown or unavailable id
    # a vector-reward variant is benchmarked on its env's protocol and baselines
    spec = registry().benchmarks.get(base_env(env_id))
    kwargs: dict[str, Any] = dict(env_kwargs or {})
    if episodes == "test":
        test = protocol(env_id)
        kwargs = {**test.env_kwargs, **kwargs}
        plan: list[dict[str, Any]] = load_object(test.protocol)(kwargs)
        description = test.description or f"{len(plan)} episodes"
    elif isinstance(episodes, int) and episodes > 0:
        plan = seeded_episodes(episodes, seed)
        description = f"{episodes} seeded episode(s)"
    else:
        raise ConfigError(f'`episodes` must be "test" or a positive int, not {episodes!r}')
    if not policies:
        policies = list(spec.policies) if spec and spec.policies else baseline_names(env_id)
    for ref in policies:  # every policy named right before the first episode runs
        check_policy(env_id, ref)
    result = BenchmarkResult(
        env_id,
        plan,
        objective=spec.objective if spec else (),
        step_unit=spec.step_unit if spec else "step",
        description=description,
        test_protocol=episodes == "test",
        env_kwargs=dict(kwargs),
    )
    final_keys = spec.final_info if spec else ()
    bar: ProgressDisplay | None = None
    # a planner's episodes cost minutes where the others cost seconds: an estimate of the time left would mislead
    planners = [ref for ref in policies if isinstance(ref, str) and ref in non_causal(env_id)]
    try:
        for ref in policies:
            name = policy_name(ref)
            env = gym.make(env_id, **kwargs)
            try:
                if isinstance(env.unwrapped, MultiObjective):  # a vector reward: its entries are reported
                    result.objectives = env.unwrapped.components
                where = f"policy `{agent_label(name, ref)}` on `{env_id}`"
                with blame(where):
                    policy = make_policy(env_id, ref, env)
                if progress and bar is None:  # drawn once an env is made: a missing data file is said alone
                    bar = ProgressDisplay(env_id, len(policies) * len(plan), "episodes", eta=not planners)
                runs = []
                for i, ep in enumerate(plan):
                    with blame(f"{where}, episode {i} (reset seed {ep.get('seed')})"):
                        runs.append(
                            run_episode(
                                env, policy, ep.get("seed"), ep.get("options"), final_keys, None, result.objective
                            )
                        )
                    if bar is not None:
                        bar.advance()
            finally:
                env.close()
            result.rewards[name] = [r["rewards"] for r in runs]
            if result.objective:
                result.objective_rewards[name] = [r["objective_rewards"] for r in runs]
            result.returns[name] = [float(r["rewards"].sum()) for r in runs]
            keys = sorted({k for r in runs for k in r["components"]})
            result.components[name] = {k: [r["components"].get(k, 0.0) for r in runs] for k in keys}
            # NaN where an episode ended without the value (cut short by a time limit)
            result.final_info[name] = {k: [r["final"].get(k, np.nan) for r in runs] for k in final_keys}
            planned = getattr(policy, "planned_objectives", None)  # a planner's own estimate of each episode
            if planned is not None and len(planned) >= len(plan):
                result.planned[name] = [float(v) for v in planned[-len(plan) :]]
    finally:  # a later error (a policy's model file) is printed below the bar, not inside it
        if bar is not None:
            bar.close()
    if out is not None:
        result.save(out)
    return result
