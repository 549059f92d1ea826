"""``gym4real reproduce``: train the paper's agents over several seeds, test them, check the paper's claims.

For each environment, every algorithm with a training preset of the budget (``paper``: the paper's
settings; ``quick``: the ``smoke`` presets, minutes) is trained once per seed, unless a finished run of
the same settings is already in the output folder (an unfinished one resumes from its last checkpoint).
Every model and every baseline of the protocol then runs the test protocol; the per-episode objective
gives, per policy, a ``(seeds, episodes)`` score matrix, summarised by its IQM with a 95 % two-level
(seed, episode) bootstrap interval (:mod:`gym4real.bench.stats`). Each claim that the domain declares
(:class:`~gym4real.core.specs.Claim`) is checked by the rules of :mod:`gym4real.results.claims`. Every
statistic is computed from ``episodes.csv`` alone (:mod:`gym4real.results.analysis`).

Layout of the output folder ``OUT``::

    OUT/results.md, claims.md             the results page (every environment and budget found in OUT)
    OUT/claims.json, OUT/manifest.json    every claim's verdict; code version, versions and data files
    OUT/<env>/<budget>/runs/<algo>/seed<S>/   one training run (model, curve.csv, settings.json, run.json)
    OUT/<env>-<budget>/episodes.csv, runs.csv, report.json            the raw data and its provenance
    OUT/<env>-<budget>/summary.csv, improvement.csv, claims.json      computed from episodes.csv
    OUT/<env>-<budget>/*.png, learning_curves.csv                     the figures
    OUT/<env>-<budget>/error.txt          why the environment could not be run (missing data, ...)
"""

from __future__ import annotations

import dataclasses
import json
import multiprocessing
import platform
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench import stats, versions
from gym4real.bench.benchmark import BenchmarkResult, benchmark, protocol
from gym4real.bench.seeds import SeedRequest, check_request, seeds_flag
from gym4real.core.errors import Gym4RealError
from gym4real.results import analysis, fingerprints, provenance, workspace
from gym4real.results.artefacts import section_name
from gym4real.results.plan import Item, plan
from gym4real.results.published_models import publish_models
from gym4real.results.run_files import DamagedRunError, damaged_file
from gym4real.results.runner import describe_error, thread_limits, train_plan
from gym4real.rl.progress import PlanProgress
from gym4real.rl.train import TrainingRun


@dataclass
class EnvReport:
    """What :func:`reproduce_env` found for one environment and budget."""

    table: pd.DataFrame
    claims: list[dict[str, Any]]


def text_report(env_id: str, budget: str, report: EnvReport) -> list[str]:
    """One env's lines of :func:`reproduce`'s text report: its summary, then each claim's verdict with its mark.

    Numbers are written as people write them (:func:`~gym4real.bench.numbers.human`); the kind column names a
    paper agent, a baseline, or a non-causal upper reference with its kind (``non-causal upper reference,
    exact``), as the figures label it.
    """
    from gym4real.bench.numbers import human
    from gym4real.bench.upper_label import label
    from gym4real.core.registry import non_causal
    from gym4real.results.results_page import SYMBOLS

    table = report.table.copy()
    table["kind"] = [
        label(env_id, p).removeprefix(f"{p} (").removesuffix(")")
        if p in non_causal(env_id)
        else {"agent": "paper agent"}.get(kind, kind)
        for p, kind in zip(table["policy"], table["kind"], strict=True)
    ]
    return [
        f"== {env_id} ({budget})",
        table.to_string(index=False, float_format=human, na_rep=""),
        "",
        *(f"claim: {c['text']} -> {SYMBOLS[c['verdict']]} {c['verdict']}" for c in report.claims),
        "",
    ]


def results_folder(out: Path, env_id: str, budget: str, trainer: str = "sb3") -> Path:
    """``OUT/<env>-<budget>``: the tested results of one env and budget (its runs are in ``OUT/<env>/<budget>``).

    A section of the JAX trainer's runs is ``OUT/<env>-<budget>-jax``.
    """
    return out / section_name(env_id, budget, trainer)


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
        objective_rewards=joined(result.objective_rewards) if result.objective_rewards else {},
        components=joined(result.components),
        final_info=joined(result.final_info),
    )


def episodes_table(result: BenchmarkResult, baselines: list[str], runs: list[TrainingRun]) -> pd.DataFrame:
    """``episodes.csv``: one row per policy, seed (empty for a baseline) and test episode.

    Columns ``policy, seed, episode, objective, return``, then one per reward component (per-episode sums).
    """
    named = [(name, name, None) for name in baselines] + [(r.agent, r.policy, r.seed) for r in runs]
    components = sorted({c for name in result.components.values() for c in name})
    rows = []
    for policy, key, seed in named:
        objective = result.objective_values(key)
        for i, ret in enumerate(result.returns[key]):
            row: dict[str, Any] = {"policy": policy, "seed": seed, "episode": i, "objective": objective[i]}
            row["return"] = ret
            comps = result.components[key]
            row.update({c: comps[c][i] if c in comps else np.nan for c in components})
            rows.append(row)
    frame = pd.DataFrame(rows)
    frame["seed"] = frame["seed"].astype("Int64")
    return frame


def _curves(runs: list[TrainingRun], folder: Path) -> None:
    """``learning_curves.csv`` and ``.png``: per algorithm, each seed's curve, their mean and its 95 % band.

    The mean and its t-band are drawn where at least two seeds have a validation point (seeds that stopped
    early end their curve sooner); an algorithm of one seed shows that seed's curve and its band over the
    validation episodes.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gym4real.bench.plots import LINESTYLES, MARKERS

    frames = []
    fig, ax = plt.subplots(figsize=(9.5, 4.2))
    unit = "timesteps"
    for i, algo in enumerate(sorted({r.agent for r in runs})):
        mine = [r for r in runs if r.agent == algo and r.curve_csv.exists()]
        curves = [pd.read_csv(r.curve_csv) for r in mine]
        if not curves:
            continue
        unit = "episodes" if "episodes" in curves[0].columns else "timesteps"
        x = np.array(sorted({v for c in curves for v in c[unit]}))
        rows = np.full((len(curves), len(x)), np.nan)
        for k, c in enumerate(curves):
            rows[k, np.searchsorted(x, c[unit])] = c["mean_return"]
        style: dict[str, Any] = {
            "linestyle": LINESTYLES[i % len(LINESTYLES)],
            "marker": MARKERS[i % len(MARKERS)],
            "markersize": 4,
        }
        if len(curves) > 1:
            mean, low, high = stats.t_band(rows)
            count = np.sum(~np.isnan(rows), axis=0)
            mean = np.where(count > 1, mean, np.nan)
            label = f"{algo}: mean of {len(curves)} seeds (95 % t-band)"
            (line,) = ax.plot(x, mean, label=label, **style)
            for k, c in enumerate(curves):
                ax.plot(
                    c[unit],
                    c["mean_return"],
                    color=line.get_color(),
                    linewidth=0.7,
                    alpha=0.45,
                    label=f"{algo}: each seed" if k == 0 else None,
                )
        else:
            mean, low, high = rows[0], curves[0]["ci95_low"].to_numpy(), curves[0]["ci95_high"].to_numpy()
            (line,) = ax.plot(x, mean, label=f"{algo}: seed {mine[0].seed} (95 % band over episodes)", **style)
            count = np.ones(len(x), dtype=int)
        ax.fill_between(x, low, high, color=line.get_color(), alpha=0.2, linewidth=0)
        frames.append(pd.DataFrame({"algo": algo, unit: x, "seeds": count, "mean": mean, "low": low, "high": high}))
    if not frames:
        plt.close(fig)
        return
    ax.set(xlabel=f"training {unit}", ylabel="mean validation return", title=f"{runs[0].env_id}: learning curves")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False, fontsize=8)
    fig.tight_layout()
    fig.savefig(folder / "learning_curves.png", dpi=120)
    plt.close(fig)
    pd.concat(frames).to_csv(folder / "learning_curves.csv", index=False)


def tested_baselines(env_id: str) -> list[str]:
    """The baselines the test phase of ``env_id`` runs: the protocol's, those its claims name, the upper references.

    A check of this suite's own may compare with a registered baseline outside the protocol's (``mpc``); the upper
    references give the headroom.
    """
    from gym4real.core.registry import baseline_names, non_causal

    spec = protocol(env_id)
    claimed = [p for c in spec.claims for p in (c.policy, *c.others) if p in baseline_names(env_id)]
    return list(dict.fromkeys([*spec.policies, *claimed, *non_causal(env_id)]))


def reproduce_env(
    env_id: str,
    budget: str,
    runs: list[TrainingRun],
    out: Path,
    command: str,
) -> EnvReport:
    """Test the trained ``runs`` of ``env_id`` (one per algorithm and seed), check the claims, write.

    Writes into ``OUT/<env>-<budget>/``: ``episodes.csv`` and ``runs.csv`` (the raw data), ``report.json``
    (command, protocol, code version, versions, the CPU model of the machine that tests, data files, the fingerprints of
    :mod:`~gym4real.results.fingerprints` and the distributions the runs imported), the models
    (:mod:`~gym4real.results.published_models`), then the statistics computed from ``episodes.csv`` alone
    (:func:`gym4real.results.analysis.analyse`) and the figures.
    """
    from gym4real.bench import plots

    trainer = runs[0].trainer if runs else "sb3"
    folder = results_folder(out, env_id, budget, trainer)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "error.txt").unlink(missing_ok=True)
    spec = protocol(env_id)
    baselines = tested_baselines(env_id)
    test_start = time.perf_counter()
    result = benchmark(env_id, [*baselines, *(run.policy for run in runs)], episodes="test")
    test_wall = time.perf_counter() - test_start
    episodes_table(result, baselines, runs).to_csv(folder / "episodes.csv", index=False)
    provenance.runs_table(runs).to_csv(folder / "runs.csv", index=False)
    report = {
        "env_id": env_id,
        "budget": budget,
        "command": command,
        "objective": list(spec.objective) or ["return"],
        "protocol": spec.description,
        "step_unit": spec.step_unit,
        "seeds": sorted({r.seed for r in runs}),
        "presets": {r.agent: r.preset for r in runs},
        "test_wall_time_s": test_wall,
        "code_version": versions.code_version(),
        "versions": versions.versions(),
        "platform": platform.platform(),
        "cpu": versions.cpu_model(),
        "data_files": provenance.data_files(env_id),
        fingerprints.KEY: fingerprints.fingerprints(env_id, budget, trainer),
    }
    (folder / "report.json").write_text(json.dumps(report, indent=1))
    publish_models(runs, folder, budget)
    claims = analysis.analyse(folder, env_id, budget)
    if workspace.write_placements(folder, env_id):
        workspace.heatmap_figure(folder, env_id)
    groups = {name: [name] for name in baselines}
    for run in runs:
        groups.setdefault(run.agent, []).append(run.policy)
    plots.save_figures(pooled(result, groups), folder)
    _curves(runs, folder)
    report["imported"] = provenance.imported(runs)
    (folder / "report.json").write_text(json.dumps(report, indent=1))
    return EnvReport(pd.read_csv(folder / "summary.csv"), claims)


def _tested(env_id: str, budget: str, runs: list[TrainingRun], out: Path, command: str) -> EnvReport | str:
    """:func:`reproduce_env`, or its error described (one env's failure must not stop the others)."""
    try:
        return reproduce_env(env_id, budget, runs, out, command)
    except Exception as exc:
        return describe_error(exc)


def tested_envs(
    tests: dict[str, tuple[list[TrainingRun], str]], budget: str, out: Path, jobs: int, bar: PlanProgress
) -> dict[str, EnvReport | str]:
    """The test phase of each env (its trained runs and the command that made them): a report or an error.

    With ``jobs`` > 1 and several envs, up to ``jobs`` envs are tested at a time, each in a worker process
    (``spawn``, one thread each, as the training workers); every test episode is seeded, so the results are
    those of one job. The envs' results come back in ``tests``' order.
    """
    if jobs < 2 or len(tests) < 2:
        found: dict[str, EnvReport | str] = {}
        for env_id, (runs, command) in tests.items():
            found[env_id] = _tested(env_id, budget, runs, out, command)
            bar.close_item()
        return found
    context = multiprocessing.get_context("spawn")
    with thread_limits(), ProcessPoolExecutor(min(jobs, len(tests)), mp_context=context) as pool:
        futures = {
            pool.submit(_tested, env_id, budget, runs, out, command): env_id
            for env_id, (runs, command) in tests.items()
        }
        done: dict[str, EnvReport | str] = {}
        for future in as_completed(futures):
            try:
                done[futures[future]] = future.result()
            except Exception as exc:  # the worker died (killed, out of memory)
                done[futures[future]] = describe_error(exc)
            bar.close_item()
    return {env_id: done[env_id] for env_id in tests}


def _shown(out: Path) -> str:
    """``out`` as the page's command shows it: as given when relative, else ``OUT`` (no machine path)."""
    return str(out) if not out.is_absolute() else "OUT"


def reproduce(
    env_ids: Sequence[str],
    budget: str = "paper",
    n_seeds: SeedRequest = None,
    out: str | Path = "results/reproduce",
    progress: bool = False,
    page: str | Path | None = None,
    jobs: int = 1,
    ray: bool = False,
    storage: str | None = None,
    retrain_damaged: bool = False,
    trainer: str = "sb3",
) -> str:
    """Reproduce the paper's results of ``env_ids``; return a text report (tables and claim verdicts).

    An environment that cannot run (missing data, a missing extra) is reported with its error, in the
    output and in ``<env>-<budget>/error.txt``, and the others go on.

    Args:
        env_ids: Registered ids.
        budget: ``paper`` or ``quick``.
        n_seeds: Training seeds per algorithm: how many (the plan's first), or which (default: the paper's;
            see :func:`~gym4real.bench.seeds.seeds`).
        out: Output folder (see the module's docstring for its layout).
        progress: One progress bar over the whole plan (training runs, then the tests of each env).
        page: Also write the results page and its figures into this folder (a docs folder).
        jobs: Training runs at a time on this machine (:func:`~gym4real.results.runner.train_plan`).
        ray: Run the training runs on Ray instead (:func:`~gym4real.results.cluster.train_on_ray`).
        storage: With ``ray``: where the workers keep the run folders (default ``out``).
        retrain_damaged: Move a run folder with a damaged file aside and train that run again; without it,
            such a run is refused (its folder left untouched) and :class:`DamagedRunError` raised at the end.
        trainer: ``sb3`` (the reference), or ``jax``: the budget's PPO runs by the JAX trainer, in sections of
            their own (``<env>-<budget>-jax``, agent ``ppo-jax``).

    Raises:
        DamagedRunError: A run folder holds a damaged file (after the other runs and the page are done;
            its ``report`` is the text report).
        EnvUnavailableError: An id is not registered (checked before anything runs).
        ConfigError: An unknown budget, or fewer than one seed (checked before anything runs).
    """
    check_request(env_ids, budget, n_seeds)
    out = Path(out)
    plans: dict[str, list[Item]] = {}
    errors: dict[str, str] = {}
    for env_id in env_ids:
        try:
            plans[env_id] = [
                dataclasses.replace(item, retrain_damaged=retrain_damaged)
                for item in plan(env_id, budget, n_seeds, out, trainer)
            ]
        except Gym4RealError as exc:
            errors[env_id] = " ".join(str(exc).split())
    bar = PlanProgress(sum(len(items) for items in plans.values()) + len(plans), progress)
    everything = [item for items in plans.values() for item in items]
    if ray:
        from gym4real.results.cluster import train_on_ray

        outcomes = train_on_ray(everything, out, storage, bar)
    else:
        outcomes = train_plan(everything, bar, jobs)
    tests: dict[str, tuple[list[TrainingRun], str]] = {}
    for env_id, items in plans.items():
        mine = [o for o in outcomes if o.item.env_id == env_id]
        failed = [o for o in mine if o.run is None]
        if failed:
            errors[env_id] = describe_error(
                Gym4RealError(f"{len(failed)} training run(s) failed; first: {failed[0].error}")
            )
            bar.close_item()
            continue
        flag = seeds_flag(env_id, budget, list(dict.fromkeys(i.seed for i in items)))
        command = f"gym4real reproduce {env_id} --budget {budget} --seeds {flag} --out {_shown(out)}"
        if trainer != "sb3":
            command += f" --trainer {trainer}"
        tests[env_id] = ([o.run for o in mine if o.run is not None], command)
    lines = []
    for env_id, report in tested_envs(tests, budget, out, jobs, bar).items():
        if isinstance(report, str):  # one env's failure (missing data, a bug) does not stop the others
            errors[env_id] = report
            continue
        lines += text_report(env_id, budget, report)
    for env_id, error in errors.items():
        folder = results_folder(out, env_id, budget, trainer)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "error.txt").write_text(error + "\n")
        lines.append(f"== {env_id} ({budget}): not run: {error}")
    bar.close()
    from gym4real.results.results_page import write_page

    written = write_page(out, page)
    lines.append(f"results in {out}/ (page {written})")
    damaged = [o.error for o in outcomes if o.run is None and damaged_file(o.item.folder) is not None]
    if damaged:
        raise DamagedRunError(
            f"{len(damaged)} run folder(s) hold a damaged file: {'; '.join(map(str, damaged))}", "\n".join(lines)
        )
    return "\n".join(lines)
