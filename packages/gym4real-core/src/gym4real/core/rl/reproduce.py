"""``gym4real reproduce``: train the paper's agents over several seeds, test them, check the paper's claims.

For each environment, every algorithm with a training preset of the budget (``paper``: the paper's
settings; ``quick``: the ``smoke`` presets, minutes) is trained once per seed, unless a finished run of
the same settings is already in the output folder (an unfinished one resumes from its last checkpoint).
Every model and every baseline of the protocol then runs the test protocol; the per-episode objective
gives, per policy, a ``(seeds, episodes)`` score matrix, summarised by its IQM with a 95 % bootstrap
interval over the test episodes (:mod:`gym4real.core.stats`). Each claim that the domain declares
(:class:`~gym4real.core.specs.Claim`) is checked with the interval of the difference.

Layout of the output folder ``OUT``::

    OUT/results.md                        the results page (every environment and budget found in OUT)
    OUT/claims.json, OUT/summary.csv      every claim's verdict; every policy's row
    OUT/<env>/<budget>/runs/<algo>/seed<S>/   one training run (model, curve.csv, settings.json, run.json)
    OUT/<env>/<budget>/summary.csv, claims.json, report.json
    OUT/<env>/<budget>/cumulative_reward.png, returns_boxplot.png, learning_curves.png, learning_curves.csv
    OUT/<env>/<budget>/error.txt          why the environment could not be run (missing data, ...)
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.core import stats
from gym4real.core.benchmark import BenchmarkResult, benchmark, protocol
from gym4real.core.errors import Gym4RealError
from gym4real.core.rl.plan import Item, plan, slug
from gym4real.core.rl.progress import PlanProgress
from gym4real.core.rl.runner import describe_error, train_plan
from gym4real.core.rl.train import TrainingRun, versions
from gym4real.core.specs import Claim


def _scores(result: Any, name: str) -> np.ndarray:
    return np.asarray(result.objective_values(name), dtype=float)


@dataclass
class EnvReport:
    """What :func:`reproduce_env` found for one environment and budget."""

    table: pd.DataFrame
    claims: list[dict[str, Any]]


def pooled(result: BenchmarkResult, groups: dict[str, list[str]]) -> BenchmarkResult:
    """``result`` with each group of policies (an algorithm's runs, one per seed) as one policy.

    The group's policy holds all their test episodes in turn; everything else (objective, step unit, ...) is
    ``result``'s.
    """

    def joined(table: dict[str, Any]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for group, names in groups.items():
            first = table[names[0]]
            if isinstance(first, dict):  # components, final_info: one list per key
                out[group] = {key: [x for n in names for x in table[n][key]] for key in first}
            else:
                out[group] = [x for n in names for x in table[n]]
        return out

    return dataclasses.replace(
        result,
        episodes=list(result.episodes) * max(len(names) for names in groups.values()),
        returns=joined(result.returns),
        rewards=joined(result.rewards),
        components=joined(result.components),
        final_info=joined(result.final_info),
    )


def check_claim(claim: Claim, scores: dict[str, np.ndarray]) -> dict[str, Any]:
    """The verdict of one claim, with every comparison's difference and 95 % interval."""
    statistic = "std" if claim.relation == "less_variable" else "iqm"
    record: dict[str, Any] = {
        "text": claim.text,
        "policy": claim.policy,
        "relation": claim.relation,
        "statistic": statistic,
        "comparisons": [],
    }
    missing = [p for p in (claim.policy, *claim.others) if p not in scores]
    if missing:
        record["verdict"] = "not checked"
        record["reason"] = f"no test scores of {missing}"
        return record
    verdicts = []
    for other in claim.others:
        diff, low, high = stats.difference_ci(scores[claim.policy], scores[other], statistic)
        verdicts.append(stats.verdict(claim.relation, low, high))
        record["comparisons"].append({"other": other, "difference": diff, "ci95": [low, high], "verdict": verdicts[-1]})
    if "does not hold" in verdicts:
        record["verdict"] = "does not hold"
    elif all(v == "holds" for v in verdicts):
        record["verdict"] = "holds"
    else:
        record["verdict"] = "inconclusive"
    return record


def _table(scores: dict[str, np.ndarray], returns: dict[str, list[float]], runs: list[TrainingRun]) -> pd.DataFrame:
    rows = []
    for name, matrix in scores.items():
        mine = [r for r in runs if r.algo == name]
        value, low, high = stats.iqm_ci(matrix)
        row: dict[str, Any] = {
            "policy": name,
            "kind": "agent" if mine else "baseline",
            "seeds": matrix.shape[0] if mine else 0,
            "episodes": matrix.shape[1],
            "iqm": value,
            "ci95_low": low,
            "ci95_high": high,
            "mean": float(matrix.mean()),
            "std": float(matrix.std()),
            "mean_return": float(np.mean(returns[name])),
            "seed_iqm_min": float(min(stats.iqm(m) for m in matrix)),
            "seed_iqm_max": float(max(stats.iqm(m) for m in matrix)),
        }
        if mine:
            row["train_wall_time_s"] = float(sum(r.wall_time_s for r in mine))
            row["env_steps"] = int(sum(r.env_steps + r.eval_steps for r in mine))
            row["env_steps_per_s"] = row["env_steps"] / row["train_wall_time_s"]
        rows.append(row)
    return pd.DataFrame(rows).set_index("policy")


def _curves(runs: list[TrainingRun], folder: Path) -> None:
    """``learning_curves.csv`` and ``.png``: per algorithm, the mean over seeds and its 95 % band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = []
    fig, ax = plt.subplots(figsize=(7, 4))
    unit = "timesteps"
    for algo in sorted({r.algo for r in runs}):
        curves = [pd.read_csv(r.curve_csv) for r in runs if r.algo == algo and r.curve_csv.exists()]
        if not curves:
            continue
        unit = "episodes" if "episodes" in curves[0].columns else "timesteps"
        x = np.array(sorted({v for c in curves for v in c[unit]}))
        rows = np.full((len(curves), len(x)), np.nan)
        for i, c in enumerate(curves):
            rows[i, np.searchsorted(x, c[unit])] = c["mean_return"]
        if len(curves) > 1:
            mean, low, high = stats.t_band(rows)
            band = "95 % t-interval over seeds"
        else:
            mean, low, high = rows[0], curves[0]["ci95_low"].to_numpy(), curves[0]["ci95_high"].to_numpy()
            band = "95 % interval over evaluation episodes (one seed)"
        frames.append(
            pd.DataFrame(
                {"algo": algo, unit: x, "seeds": np.sum(~np.isnan(rows), 0), "mean": mean, "low": low, "high": high}
            )
        )
        ax.plot(x, mean, label=f"{algo} ({len(curves)} seed{'s' if len(curves) > 1 else ''}; {band})")
        ax.fill_between(x, low, high, alpha=0.25)
    if not frames:
        plt.close(fig)
        return
    ax.set(xlabel=unit, ylabel="validation return", title=f"{runs[0].env_id}: learning curves (mean, 95 % band)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(folder / "learning_curves.png", dpi=100)
    plt.close(fig)
    pd.concat(frames).to_csv(folder / "learning_curves.csv", index=False)


def reproduce_env(
    env_id: str,
    budget: str,
    runs: list[TrainingRun],
    out: Path,
    command: str,
) -> EnvReport:
    """Test the trained ``runs`` of ``env_id`` (one per algorithm and seed), check the claims, write."""
    from gym4real.core import plots

    folder = out / slug(env_id) / budget
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "error.txt").unlink(missing_ok=True)
    spec = protocol(env_id)
    baselines = list(spec.policies)
    test_start = time.perf_counter()
    result = benchmark(env_id, [*baselines, *(run.policy for run in runs)], episodes="test")
    groups = {name: [name] for name in baselines}
    for run in runs:
        groups.setdefault(run.algo, []).append(run.policy)
    scores = {group: np.stack([_scores(result, name) for name in names]) for group, names in groups.items()}
    test_wall = time.perf_counter() - test_start
    tested = pooled(result, groups)
    table = _table(scores, tested.returns, runs)
    claims = [{"env_id": env_id, **check_claim(c, scores)} for c in spec.claims]
    plots.save_figures(tested, folder)
    _curves(runs, folder)
    table.to_csv(folder / "summary.csv")
    (folder / "claims.json").write_text(json.dumps(claims, indent=1))
    report = {
        "env_id": env_id,
        "budget": budget,
        "command": command,
        "objective": list(spec.objective) or ["return"],
        "protocol": spec.description,
        "seeds": sorted({r.seed for r in runs}),
        "presets": {r.algo: r.preset for r in runs},
        "runs": [
            {
                "algo": r.algo,
                "seed": r.seed,
                "wall_time_s": r.wall_time_s,
                "env_steps": r.env_steps,
                "eval_steps": r.eval_steps,
                "env_steps_per_s": r.steps_per_s,
            }
            for r in runs
        ],
        "training_wall_time_s": sum(r.wall_time_s for r in runs),
        "test_wall_time_s": test_wall,
        "versions": versions(),
    }
    (folder / "report.json").write_text(json.dumps(report, indent=1))
    return EnvReport(table, claims)


def reproduce(
    env_ids: Sequence[str],
    budget: str = "paper",
    n_seeds: int | None = None,
    out: str | Path = "results/reproduce",
    progress: bool = False,
    page: str | Path | None = None,
    jobs: int = 1,
    ray: bool = False,
    storage: str | None = None,
) -> str:
    """Reproduce the paper's results of ``env_ids``; return a text report (tables and claim verdicts).

    An environment that cannot run (missing data, a missing extra) is reported with its error, in the
    output and in ``<env>/<budget>/error.txt``, and the others go on.

    Args:
        env_ids: Registered ids.
        budget: ``paper`` or ``quick``.
        n_seeds: Training seeds per algorithm (default: the paper's; see :func:`seeds`).
        out: Output folder (see the module's docstring for its layout).
        progress: One progress bar over the whole plan (training runs, then the tests of each env).
        page: Also write the results page and its figures into this folder (a docs folder).
        jobs: Training runs at a time on this machine (:func:`~gym4real.core.rl.runner.train_plan`).
        ray: Run the training runs on Ray instead (:func:`~gym4real.core.rl.cluster.train_on_ray`).
        storage: With ``ray``: where the workers keep the run folders (default ``out``).
    """
    out = Path(out)
    plans: dict[str, list[Item]] = {}
    errors: dict[str, str] = {}
    for env_id in env_ids:
        try:
            plans[env_id] = plan(env_id, budget, n_seeds, out)
        except Gym4RealError as exc:
            errors[env_id] = " ".join(str(exc).split())
    bar = PlanProgress(sum(len(items) for items in plans.values()) + len(plans), progress)
    everything = [item for items in plans.values() for item in items]
    if ray:
        from gym4real.core.rl.cluster import train_on_ray

        outcomes = train_on_ray(everything, out, storage, bar)
    else:
        outcomes = train_plan(everything, bar, jobs)
    lines = []
    for env_id, items in plans.items():
        mine = [o for o in outcomes if o.item.env_id == env_id]
        failed = [o for o in mine if o.run is None]
        try:
            if failed:
                raise Gym4RealError(f"{len(failed)} training run(s) failed; first: {failed[0].error}")
            n_seeds = len({i.seed for i in items})
            command = f"gym4real reproduce {env_id} --budget {budget} --seeds {n_seeds} --out {out}"
            report = reproduce_env(env_id, budget, [o.run for o in mine if o.run is not None], out, command)
        except Exception as exc:  # one env's failure (missing data, a bug) must not stop the others
            errors[env_id] = describe_error(exc)
        else:
            lines += [f"== {env_id} ({budget})", report.table.to_string(float_format=lambda v: f"{v:.4g}"), ""]
            for c in report.claims:
                lines.append(f"claim: {c['text']} -> {c['verdict']}")
            lines.append("")
        bar.close_item()
    for env_id, error in errors.items():
        folder = out / slug(env_id) / budget
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "error.txt").write_text(error + "\n")
        lines.append(f"== {env_id} ({budget}): not run: {error}")
    bar.close()
    from gym4real.core.rl.results_page import write_page

    written = write_page(out, page)
    lines.append(f"results in {out}/ (page {written})")
    return "\n".join(lines)
