"""The results page of ``gym4real reproduce``: Markdown tables, figures and claim verdicts.

:func:`write_page` reads every ``<env>/<budget>/`` folder of a reproduce output folder (its
``report.json``, ``summary.csv``, ``claims.json``, figures, or ``error.txt``) and writes ``results.md``
beside them, plus ``claims.json``, ``claims.md`` (the short table of verdicts) and ``summary.csv`` over all
environments. Given a page folder (a docs
folder) it writes ``index.md`` there with the figures copied under ``figures/<env>-<budget>/``.
"""

from __future__ import annotations

import json
import platform
import shutil
from pathlib import Path
from typing import Any

import pandas as pd

from gym4real.core.rl.plan import slug

_FIGURES = (
    ("cumulative_reward.png", "mean cumulative reward on the test episodes (95 % band)"),
    ("returns_boxplot.png", "test returns (all seeds' episodes)"),
    ("learning_curves.png", "learning curves: validation return during training (mean and 95 % band)"),
)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _ci(low: float, high: float) -> str:
    return f"[{low:.4g}, {high:.4g}]"


def _duration(seconds: float) -> str:
    if seconds >= 3600:
        return f"{seconds / 3600:.1f} h"
    if seconds >= 60:
        return f"{seconds / 60:.1f} min"
    return f"{seconds:.0f} s"


def _has_results(folder: Path) -> bool:
    return (folder / "report.json").exists() and not (folder / "error.txt").exists()


def _folders(out: Path) -> list[Path]:
    """Per environment: its paper-budget folder, or else why it is missing and its quick-budget folder."""
    found = []
    for env in sorted(p for p in out.iterdir() if p.is_dir() and p.name != "figures"):
        paper, quick = env / "paper", env / "quick"
        if _has_results(paper):
            found.append(paper)
            continue
        found += [f for f in (paper, quick) if (f / "report.json").exists() or (f / "error.txt").exists()]
    return found


def _what_it_runs(env_id: str, budget: str) -> str:
    """What ``gym4real reproduce ENV --budget B`` trains, tests and checks, in one sentence."""
    from gym4real.core.benchmark import protocol
    from gym4real.core.rl.plan import presets, seeds
    from gym4real.core.rl.presets import load_preset

    try:
        trained = []
        for algo, preset in presets(env_id, budget).items():
            hp = load_preset(env_id, algo, preset)
            size = f"{hp['episodes']:,} episodes" if "episodes" in hp else f"{hp['total_timesteps']:,} steps"
            trained.append(f"`{algo}` (preset `{preset}`: {size} on {hp.get('n_envs', 1)} env(s))")
        spec = protocol(env_id)
        run_seeds = ", ".join(str(s) for s in seeds(env_id, budget))
    except Exception as exc:  # the page must be written even when the registry has changed
        return f"(`gym4real reproduce {env_id} --budget {budget}` could not be planned: {exc})"
    claims = "; ".join(f'"{c.text}"' for c in spec.claims) or "none"
    return (
        f"With it in place, `gym4real reproduce {env_id} --budget {budget}` trains {', '.join(trained)} with "
        f"seed(s) {run_seeds}, tests each model beside {', '.join(spec.policies)} on the test protocol "
        f"({spec.description}), checks the claims ({claims}) and adds this section to the page."
    )


def _read(folder: Path) -> tuple[dict[str, Any], pd.DataFrame, list[dict[str, Any]]]:
    """A finished env folder's ``report.json``, ``summary.csv`` and ``claims.json``."""
    return (
        json.loads((folder / "report.json").read_text()),
        pd.read_csv(folder / "summary.csv"),
        json.loads((folder / "claims.json").read_text()),
    )


def _section(folder: Path, found: tuple[dict[str, Any], pd.DataFrame, list[dict[str, Any]]] | None) -> list[str]:
    """The page's section of one env folder; ``found`` is its :func:`_read`, None when it has no results."""
    env, budget = folder.parent.name, folder.name
    if found is None:
        error = (folder / "error.txt").read_text().strip() if (folder / "error.txt").exists() else "no results"
        return [
            f"## `gym4real/{env}`, budget `{budget}`: not run",
            "",
            f"Not run here: {error}",
            "",
            _what_it_runs(f"gym4real/{env}", budget),
            "",
        ]
    report, table, claims = found
    lines = [
        f"## `{report['env_id']}`, budget `{budget}`",
        "",
        f"Test protocol: {report['protocol']}. Objective: {' + '.join(report['objective'])} per episode.",
        "",
        *(
            [f"Command (reuses the finished runs of its output folder): `{report['command']}`", ""]
            if "command" in report
            else []
        ),
        f"Training presets {', '.join(f'`{a}/{p}`' for a, p in report['presets'].items())}; seeds "
        f"{', '.join(str(s) for s in report['seeds'])}; training wall time "
        f"{_duration(report['training_wall_time_s'])} (sum over runs), test {_duration(report['test_wall_time_s'])}"
        f"{'; code ' + report['versions']['gym4real (git)'] if 'gym4real (git)' in report['versions'] else ''}.",
        "",
        "| policy | seeds | episodes | IQM | 95 % CI | mean | std | seed IQMs | mean return | train time "
        "| env-steps/s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in table.to_dict("records"):
        agent = row["kind"] == "agent"
        lines.append(
            f"| {'**' + row['policy'] + '**' if agent else row['policy']} | {row['seeds'] if agent else '-'} "
            f"| {row['episodes']} | {_fmt(row['iqm'])} | {_ci(row['ci95_low'], row['ci95_high'])} "
            f"| {_fmt(row['mean'])} | {_fmt(row['std'])} "
            f"| {_ci(row['seed_iqm_min'], row['seed_iqm_max']) if agent else '-'} "
            f"| {_fmt(row['mean_return']) if 'mean_return' in row else '-'} "
            f"| {_duration(row['train_wall_time_s']) if agent else '-'} "
            f"| {_fmt(row['env_steps_per_s']) if agent else '-'} |"
        )
    lines += [
        "",
        "Claims of the paper:",
        "",
        "| claim | comparison | difference [95 % CI] | verdict |",
        "|---|---|---|---|",
    ]
    for c in claims:
        stat = "std" if c["statistic"] == "std" else "IQM"
        if not c["comparisons"]:
            lines.append(f"| {c['text']} | - | {c.get('reason', '')} | **{c['verdict']}** |")
        for i, comp in enumerate(c["comparisons"]):
            lines.append(
                f"| {c['text'] if i == 0 else ''} | {stat} {c['policy']} - {comp['other']} "
                f"| {_fmt(comp['difference'])} {_ci(*comp['ci95'])} | {comp['verdict']} |"
            )
        lines.append(f"| | **overall** | | **{c['verdict']}** |")
    lines.append("")
    for name, caption in _FIGURES:
        if (folder / name).exists():
            lines += [f"![{report['env_id']}: {caption}](figures/{env}-{budget}/{name})", ""]
    return lines


def _binding(claim: dict[str, Any]) -> dict[str, Any] | None:
    """The comparison that decides a claim: the worst verdict, then the interval least favourable to it."""
    comps = claim["comparisons"]
    if not comps:
        return None
    rank = {"does not hold": 0, "inconclusive": 1, "holds": 2}
    if claim["relation"] == "above":
        return min(comps, key=lambda c: (rank[c["verdict"]], c["ci95"][0]))
    if claim["relation"] == "not_above":
        return min(comps, key=lambda c: (rank[c["verdict"]], -c["ci95"][0]))
    return min(comps, key=lambda c: (rank[c["verdict"]], -c["ci95"][1]))


def claims_table(claims: list[dict[str, Any]]) -> str:
    """A short Markdown table: per claim, the verdict and the interval of its deciding comparison."""
    lines = [
        "| env | budget | paper's claim | verdict | deciding comparison: difference [95 % CI] |",
        "|---|---|---|---|---|",
    ]
    for c in claims:
        comp = _binding(c)
        stat = "std" if c["statistic"] == "std" else "IQM"
        where = (
            f"{stat} {c['policy']} - {comp['other']}: {_fmt(comp['difference'])} {_ci(*comp['ci95'])}"
            if comp
            else c.get("reason", "")
        )
        lines.append(f"| `{slug(c['env_id'])}` | {c['budget']} | {c['text']} | **{c['verdict']}** | {where} |")
    return "\n".join(lines) + "\n"


def write_page(out: Path, page: str | Path | None = None) -> Path:
    """Write ``out/results.md`` (and ``page/index.md`` with its figures) from the env folders in ``out``."""
    folders = _folders(out)
    found = {folder: _read(folder) for folder in folders if _has_results(folder)}
    claims: list[dict[str, Any]] = []
    tables = []
    versions: dict[str, str] = {}
    for folder, (report, table, env_claims) in found.items():
        versions.update({k: v for k, v in report["versions"].items() if k != "gym4real (git)"})
        claims += [{**c, "budget": folder.name} for c in env_claims]
        tables.append(table.assign(env_id=report["env_id"], budget=folder.name))
    (out / "claims.json").write_text(json.dumps(claims, indent=1))
    (out / "claims.md").write_text(claims_table(claims))
    if tables:
        pd.concat(tables).to_csv(out / "summary.csv", index=False)
    head = [
        "# Reproduced results",
        "",
        "Generated by `gym4real reproduce`: every RL algorithm of the paper trained per seed with the budget's "
        "training presets, tested on the environment's test protocol beside the baselines. Scores are the "
        "per-episode objective (*mean return* is the mean of the full reward, which the cumulative-reward figure "
        "shows); the IQM (interquartile mean over all seeds and test episodes) has a 95 % percentile-bootstrap "
        "interval over the test episodes (scipy; each resampled episode keeps every "
        "seed's score); *seed IQMs* gives the range of the per-seed IQMs; *std* is over all seeds' test episodes, "
        "so it includes the spread between seeds. A claim comparison holds when the interval of the difference "
        "lies on the claimed side of 0, does not hold when it lies on the other side, and is inconclusive "
        "otherwise; a claim holds when all its comparisons hold. Wall times and env-steps/s were measured on a "
        "shared machine and vary with its load. An environment is shown at the `paper` budget when it was run "
        "there, else at the `quick` budget (the smoke presets: seconds of training), which checks that the "
        "pipeline runs and says nothing about the paper's claims.",
        "",
        f"Versions: {', '.join(f'{k} {v}' for k, v in sorted(versions.items()))}; Python "
        f"{platform.python_version()}, {platform.machine()}.",
        "",
        claims_table(claims),
    ]
    body: list[str] = []
    for folder in folders:
        body += _section(folder, found.get(folder))
    text = "\n".join(head + body)
    (out / "results.md").write_text(text)
    shutil.rmtree(out / "figures", ignore_errors=True)
    for folder in folders:
        target = out / "figures" / f"{folder.parent.name}-{folder.name}"
        for name, _ in _FIGURES:
            if (folder / name).exists():
                target.mkdir(parents=True, exist_ok=True)
                shutil.copy(folder / name, target / name)
    written = out / "results.md"
    if page is not None:
        page = Path(page)
        page.mkdir(parents=True, exist_ok=True)
        (page / "index.md").write_text(text)
        shutil.rmtree(page / "figures", ignore_errors=True)
        if (out / "figures").exists():
            shutil.copytree(out / "figures", page / "figures")
        written = page / "index.md"
    return written
