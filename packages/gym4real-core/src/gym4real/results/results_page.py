"""The results page of ``gym4real reproduce``: Markdown tables, figures and claim verdicts.

:func:`write_page` reads every ``<env>-<budget>/`` folder of a reproduce output folder (its raw data
``episodes.csv`` and ``runs.csv``, ``report.json``, the statistics computed from ``episodes.csv`` --
``summary.csv``, ``improvement.csv``, ``claims.json`` -- its figures, or ``error.txt``) and writes beside
them ``results.md``, ``claims.json``, ``claims.md`` (the short table of verdicts), ``manifest.json``
(the code version, package versions and data files) and, for an env with the sections of two PPO trainers,
``trainers.json`` (:mod:`~gym4real.results.trainer_comparison`: the other trainer against SB3). Given a page
folder (a docs folder) it writes ``index.md`` there with the same files, each env folder copied without its
training runs, so that the page folder alone regenerates the page (``write_page(page)``).
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from gym4real.bench import stats
from gym4real.bench.numbers import human
from gym4real.results import analysis, summary_figure, trainer_comparison, workspace
from gym4real.results.artefacts import (
    FOLDER,
    MANIFEST,
    PAGE,
    RENDERED,
    DamagedResultsError,
    read_json,
    section_name,
    trainer_of,
)
from gym4real.results.claims import QUANTITIES, RULES, VERDICTS
from gym4real.results.fingerprints import section_changes
from gym4real.results.headroom_page import headroom_table
from gym4real.results.page_manifest import files_sha256, imported_by_all, section_record
from gym4real.results.provenance import RUNS_TEXT
from gym4real.results.published_models import FOLDER as MODELS
from gym4real.results.section_provenance import (
    code_versions,
    currency_line,
    machine_caveat,
    models_lines,
    run_provenance,
)
from gym4real.results.stand_ins import budget_mark, difference_lines
from gym4real.rl.train import label

#: The files of a results folder that the page folder holds.
PUBLISHED = (
    "episodes.csv",
    "runs.csv",
    "summary.csv",
    "improvement.csv",
    "claims.json",
    "report.json",
    "learning_curves.csv",
    "error.txt",
    workspace.PLACEMENTS,
    "models.json",
)
_FIGURES = (
    ("cumulative_reward.png", "mean cumulative objective on the test episodes (95 % band)"),
    ("returns_boxplot.png", "per-episode objective (all seeds' episodes)"),
    ("performance_profile.png", "performance profile: fraction of runs x episodes above each score"),
    ("learning_curves.png", "learning curves: validation return during training (each seed, mean, 95 % band)"),
    (
        workspace.HEATMAP,
        "success rate over the workspace, per policy of the success claim: each test episode placed where its "
        "object lay (`placements.csv`, read by resetting the env with the test protocol's seeds), its success "
        "from `episodes.csv`",
    ),
)
QUICK = "pipeline check, not a verdict"


def _fmt(v: Any, scale: float = 0.0) -> str:
    """A number written for people (:func:`~gym4real.bench.numbers.human`); float noise (``stats.RTOL``) as 0."""
    if isinstance(v, float):
        return human(stats.snap(v, scale))
    return str(v)


def _ci(low: float, high: float, scale: float = 0.0) -> str:
    return f"[{_fmt(float(low), scale)}, {_fmt(float(high), scale)}]"


def _duration(seconds: float) -> str:
    if seconds >= 3600:
        return f"{seconds / 3600:.1f} h"
    if seconds >= 60:
        return f"{seconds / 60:.1f} min"
    return f"{seconds:.0f} s"


def no_paths(text: str) -> str:
    """``text`` without machine paths: an absolute path is shown by its last component."""
    return re.sub(r"(?<![\w.:/])(?:~/(?:[\w.@+-]+/)*|/(?:[\w.@+-]+/)+)(?=[\w.@+-])", "", text)


def _has_results(folder: Path) -> bool:
    return (folder / "episodes.csv").exists() and not (folder / "error.txt").exists()


def _folders(out: Path) -> list[Path]:
    """Per environment and trainer: its paper-budget folder, or else why it is missing and its quick-budget folder.

    The sections of the JAX trainer's runs (``<env>-<budget>-jax``) follow the env's SB3 sections.
    """
    envs = sorted({(m["env"], m["trainer"] or "") for p in out.iterdir() if p.is_dir() and (m := FOLDER.match(p.name))})
    found = []
    for env, trainer in envs:
        paper, quick = (out / section_name(env, budget, trainer or "sb3") for budget in ("paper", "quick"))
        if _has_results(paper):
            found.append(paper)
            continue
        found += [f for f in (paper, quick) if _has_results(f) or (f / "error.txt").exists()]
    return found


def _what_it_runs(env_id: str, budget: str) -> str:
    """What ``gym4real reproduce ENV --budget B`` trains, tests and checks, in one sentence."""
    from gym4real.bench.benchmark import protocol
    from gym4real.bench.seeds import presets, seeds
    from gym4real.rl.presets import load_preset

    try:
        trained = []
        for algo, preset in presets(env_id, budget).items():
            hp = load_preset(env_id, algo, preset)
            size = f"{hp['episodes']:,} episodes" if "episodes" in hp else f"{hp['total_timesteps']:,} steps"
            trained.append(f"`{algo}` (preset `{preset}`: {size} on {hp.get('n_envs', 1)} env(s))")
        spec = protocol(env_id)
        run_seeds = ", ".join(str(s) for s in seeds(env_id, budget))
    except Exception as exc:  # the page must be written even when the registry has changed
        return f"(`gym4real reproduce {env_id} --budget {budget}` could not be planned: {no_paths(str(exc))})"
    claims = "; ".join(f'"{c.text}"' for c in spec.claims) or "none"
    return (
        f"With it in place, `gym4real reproduce {env_id} --budget {budget}` trains {', '.join(trained)} with "
        f"seed(s) {run_seeds}, tests each model beside {', '.join(spec.policies)} on the test protocol "
        f"({spec.description}), checks the claims ({claims}) and adds this section to the page."
    )


def _data_read(report: dict[str, Any]) -> list[str]:
    """The line on the data files a section's runs read, each stand-in named as one (and a blank line).

    A registered file that is a stand-in (``DatasetSpec.stand_in_for``) is named; so is a file that was not
    found at run time, with the stand-in its domain reads in its place (``gym4real.<domain>.standin``,
    written by ``gym4real data synthesize <domain>``) where there is one.
    """
    from gym4real.core.datasets import stand_in_replacing
    from gym4real.core.registry import registry

    datasets, rows = registry().datasets, report.get("data_files", [])
    if not rows:
        return []
    stand_ins = [
        f"`{row['name']}` stands in for {spec.stand_in_for}"
        for row in rows
        if (spec := datasets.get(row["name"])) is not None and spec.stand_in_for
    ]
    for row in rows:
        if row.get("found") == "no":
            module = stand_in_replacing(row["name"])
            if module is not None:
                domain = row["name"].split("/", 1)[0]
                stand_ins.append(
                    f"`{row['name']}` was not found at run time: a preset that trains on it read the synthetic "
                    f"stand-in `{module.PATH}` instead (`gym4real data synthesize {domain}`; {_stand_in_hash(row)})"
                )
            else:
                stand_ins.append(f"`{row['name']}` was not found at run time")
    line = f"Data: {len(rows)} files, each with its SHA-256 in `manifest.json`."
    return [line + (f" **Stand-ins and missing files:** {'; '.join(stand_ins)}." if stand_ins else ""), ""]


def _stand_in_hash(row: dict[str, Any]) -> str:
    """Where the SHA-256 of the stand-in a run read in place of ``row``'s file is recorded."""
    read = row.get("read_instead")
    if read is None:  # recorded before reproduce named the stand-in it read
        return "its provenance and SHA-256 in the `.json` beside it, not recorded with this run"
    when = f", recorded {read['recorded']}" if read.get("recorded") else ""
    return f"SHA-256 `{read['sha256'][:12]}…` in `manifest.json`{when}"


class Section:
    """The files of one finished results folder."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.name = folder.name
        self.budget = FOLDER.match(folder.name)["budget"]  # type: ignore[index]
        self.trainer = trainer_of(folder.name)
        self.report: dict[str, Any] = json.loads((folder / "report.json").read_text())
        self.episodes = pd.read_csv(folder / "episodes.csv")
        self.summary = pd.read_csv(folder / "summary.csv")
        self.improvement = pd.read_csv(folder / "improvement.csv")
        self.claims: list[dict[str, Any]] = json.loads((folder / "claims.json").read_text())
        self.runs = pd.read_csv(folder / "runs.csv", dtype=RUNS_TEXT) if (folder / "runs.csv").exists() else None
        self.scale = float(self.episodes["objective"].abs().max())
        self.stale = section_changes(folder)

    @property
    def version(self) -> str:
        """The code version that produced the folder."""
        return str(self.report["code_version"])


def _trained_by(trainer: str) -> str:
    """What a section's title says of its trainer: nothing for SB3 (the reference), else its agent's label."""
    return "" if trainer == "sb3" else f", trainer `{label('ppo', trainer)}` (PPO trained by {trainer.upper()})"


#: Each verdict's mark, so that the three are told apart at a glance (an emoji keeps its colour in any view);
#: a claim whose policy has no test scores in the section (a JAX section's claims about ``dqn``) is not checked.
SYMBOLS = {"holds": "✅", "refuted": "❌", "inconclusive": "❔", "not checked": "➖"}


def _verdict(verdict: str, budget: str, bold: bool = True) -> str:
    """A verdict as a table cell: its mark and its word (bold, unless a quick budget's pipeline check)."""
    mark = SYMBOLS[verdict]
    if budget == "quick":
        return f"{mark} {verdict} ({QUICK})"
    return f"{mark} **{verdict}**" if bold else f"{mark} {verdict}"


_STATISTIC = {"iqm": "IQM", "mean": "success rate", "spread": "spread"}


def _difference(c: dict[str, Any], comp: dict[str, Any], scale: float) -> str:
    """A comparison's difference with its interval: ``IQM ppo - max: 8,087 [3,760, 17,300]``."""
    stat = _STATISTIC.get(comp["statistic"], comp["statistic"])
    scale = 1.0 if comp["statistic"] == "mean" and c.get("quantity") == "success" else scale
    return f"{stat} {comp['a']} - {comp['b']}: {_fmt(comp['estimate'], scale)} {_ci(comp['low'], comp['high'], scale)}"


def _comparison(c: dict[str, Any], comp: dict[str, Any], scale: float) -> str:
    """A comparison in full: its difference, the objective beside, each seed's own interval and the margin."""
    scale = 1.0 if comp["statistic"] == "mean" and c.get("quantity") == "success" else scale
    text = _difference(c, comp, scale)
    if "objective" in comp:  # the objective, shown beside a claim on another quantity
        o = comp["objective"]
        text += f" (objective IQM beside: {_fmt(o['estimate'])} {_ci(o['low'], o['high'])})"
    if "seeds" in comp:
        counts = Counter(s["verdict"] for s in comp["seeds"])
        text += "; seeds' own intervals: " + ", ".join(f"{counts[v]} {v}" for v in VERDICTS if counts[v])
        text += "".join(
            f"; seed {s['seed']}: {_fmt(s['estimate'], scale)} {_ci(s['low'], s['high'], scale)}"
            for s in comp["seeds"]
            if s["verdict"] == "refuted"
        )
    if c.get("margin") is not None:
        text += f" (margin {_fmt(float(c['margin']))}, detectable ±{_fmt(comp['detectable'], scale)})"
    return text


def _rule(c: dict[str, Any]) -> str:
    """The rule column of a claim: its rule; a negative claim's also says its positive's and the margin reading."""
    if "positive_verdict" not in c:
        return str(c["rule"])
    margin = c["margin_reading"]
    positive = next((x for x in c["comparisons"] if x["b"] == c.get("deciding")), None)
    why = f" ({positive['rule']})" if positive and c["positive_verdict"] != "holds" else ""
    return (
        f"negation: its positive claim is {c['positive_verdict']}{why}; margin reading (second, stricter): "
        f"{margin['verdict']} ({margin['rule']}, against {margin['deciding']})"
    )


def _shows(section: Section, claim: dict[str, Any]) -> str:
    """What the run shows about a check of this suite's own, in plain numbers (objective IQMs, success per seed)."""
    rows = section.summary.sort_values("iqm", ascending=False)
    ranked = ", ".join(f"`{r['policy']}` {_fmt(float(r['iqm']), section.scale)}" for r in rows.to_dict("records"))
    text = f"What the run shows: the IQMs of the objective rank {ranked}."
    if "success" in section.episodes.columns:
        mine = section.episodes[section.episodes["policy"] == claim["policy"]]
        rates = (mine["success"] > 0).groupby(mine["seed"]).mean()
        if len(rates):
            text += (
                f" `{claim['policy']}`'s success rate per seed: {rates.min():.0%} to {rates.max():.0%}"
                f" ({', '.join(f'{r:.0%}' for r in rates)})."
            )
    return text


def _upper_references_line(report: dict[str, Any]) -> list[str]:
    """The line saying who measured the rows added to a section after it was published (upper references, baselines).

    ``report.json`` records them (``scripts/add_upper_references.py``): the upper references under
    ``upper_references``, causal baselines (``mpc``) under ``added_baselines``.
    """
    records = [(r, "upper references") for r in [report.get("upper_references")] if r]
    records += [(r, "baselines") for r in report.get("added_baselines", [])]
    if not records:
        return []
    parts = [
        f"{what} {', '.join(f'`{p}`' for p in r['policies'])} at code version `{r['code_version']}` "
        f"(`{r['command']}`, test {_duration(r['test_wall_time_s'])})"
        for r, what in records
    ]
    text = "; ".join(parts)
    return [f"Measured later, on the same test protocol: {text}; the other rows are this section's own.", ""]


def trainer_comparisons(sections: list[Section]) -> list[dict[str, Any]]:
    """Each section of a trainer other than SB3 against the SB3 section of its env and budget (issue 43).

    Where both sections hold their PPO agent's runs (``ppo-jax`` and ``ppo``): the record of
    :func:`~gym4real.results.trainer_comparison.compare` with the env, budget and both sections' names, computed
    from the two ``episodes.csv``.
    """
    reference = {(s.report["env_id"], s.budget): s for s in sections if s.trainer == "sb3"}
    found = []
    for s in sections:
        sb3 = reference.get((s.report["env_id"], s.budget))
        if s.trainer == "sb3" or sb3 is None:
            continue
        if "ppo" not in set(sb3.episodes["policy"]) or label("ppo", s.trainer) not in set(s.episodes["policy"]):
            continue
        files = (f"{sb3.name}/episodes.csv", f"{s.name}/episodes.csv")
        record = trainer_comparison.compare(sb3.episodes, s.episodes, s.trainer, files)
        found.append(
            {"env_id": s.report["env_id"], "budget": s.budget, "reference": sb3.name, "section": s.name, **record}
        )
    return found


def _trainer_title(comparisons: list[dict[str, Any]]) -> str:
    """The heading of the trainer comparisons: ``JAX trainer against SB3``."""
    return f"{' and '.join(sorted({c['trainer'].upper() for c in comparisons}))} trainer against SB3"


def _trainer_difference(c: dict[str, Any], scale: float) -> str:
    """A trainer comparison's difference with its interval: ``-648.1 [-1,371, -39.68]``."""
    return f"{_fmt(c['estimate'], scale)} {_ci(c['low'], c['high'], scale)}"


def trainer_table(comparisons: list[dict[str, Any]], scales: dict[str, float]) -> list[str]:
    """The page's table of the trainer comparisons (:func:`trainer_comparisons`); empty without one.

    ``scales``: section name -> its scores' magnitude (float noise below it is shown as 0).
    """
    if not comparisons:
        return []
    lines = [
        f"## {_trainer_title(comparisons)}",
        "",
        f"Issue 43's *{trainer_comparison.CLAIM}*: per env with sections of both trainers, the IQM of the "
        "per-episode objective of each trainer's PPO (all its seeds' test episodes) with its 95 % interval, and "
        "the difference other trainer - SB3 with its 95 % two-level interval: the test episodes drawn once for "
        "both agents (they play the same episodes), each trainer's training seeds drawn on their own (independent "
        f"runs). The rules are under [Methods](#methods); `{trainer_comparison.FILE}` holds these numbers.",
        "",
        "| env | IQM SB3 `ppo` [95 % CI] | IQM other trainer [95 % CI] | difference other - SB3 [95 % CI] "
        "| verdict | rule |",
        "|---|---|---|---|---|---|",
    ]
    for c in comparisons:
        scale = scales.get(c["reference"], 0.0)
        env = c["env_id"].split("/", 1)[-1]
        under = "" if c["budget"] == "paper" else f"<br>{c['budget']}"
        lines.append(
            f"| `{env}`{under} | {_fmt(c['b_iqm'], scale)} {_ci(c['b_low'], c['b_high'], scale)} "
            f"| `{c['a']}` {_fmt(c['a_iqm'], scale)} {_ci(c['a_low'], c['a_high'], scale)} "
            f"| {_trainer_difference(c, scale)} | {_verdict(c['verdict'], c['budget'])} | {c['rule']} |"
        )
    return [*lines, ""]


def _against_sb3(c: dict[str, Any], scale: float) -> list[str]:
    """A section's line on its trainer against SB3 (:func:`trainer_comparisons`)."""
    return [
        f"Against SB3 (section `{c['reference']}`, *{trainer_comparison.CLAIM}*, the table "
        f"*{_trainer_title([c])}* above): IQM `{c['a']}` - `{c['b']}` {_trainer_difference(c, scale)} at "
        f"{_fmt(float(c['level']))}: {_verdict(c['verdict'], c['budget'])} ({c['rule']}).",
        "",
    ]


def _section(folder: Path, section: Section | None, comparison: dict[str, Any] | None = None) -> list[str]:
    """The page's section of one env folder; ``section`` is None when it has no results.

    ``comparison``: the section's trainer against SB3 (:func:`trainer_comparisons`), for a section of another trainer.
    """
    m = FOLDER.match(folder.name)
    env, budget, by = m["env"], m["budget"], _trained_by(trainer_of(folder.name))  # type: ignore[index]
    if section is None:
        error = (folder / "error.txt").read_text().strip() if (folder / "error.txt").exists() else "no results"
        return [
            f"## `gym4real/{env}`, budget `{budget}`{by}: not run",
            "",
            f"Not run here: {no_paths(error)}",
            "",
            _what_it_runs(f"gym4real/{env}", budget),
            "",
        ]
    report, scale, name = section.report, section.scale, section.name
    title = f"## `{report['env_id']}`, budget `{budget}`{by}" + (f": {QUICK}" if budget == "quick" else "")
    lines = [title, ""]
    lines += [currency_line(section.stale, report.get("fingerprints_verified")), ""]
    runs = section.runs
    train_s = float(runs["wall_s"].sum()) if runs is not None and len(runs) else 0.0
    lines += [
        f"Test protocol: {report['protocol']}. Objective (the score): {' + '.join(report['objective'])} per episode.",
        "",
        *_data_read(report),
        *difference_lines(report, section.episodes),
        f"Command (reuses the finished runs of its output folder): `{report['command']}`",
        "",
        f"{code_versions(runs, section.version)}; training presets "
        f"{', '.join(f'`{a}/{p}`' for a, p in report['presets'].items())}; seeds "
        f"{', '.join(str(s) for s in report['seeds'])}; training wall time {_duration(train_s)} (sum over runs), "
        f"test {_duration(report['test_wall_time_s'])}. Raw data: "
        + ", ".join(f"[{f}]({name}/{f})" for f in ("episodes.csv", "runs.csv", "summary.csv", "improvement.csv"))
        + ".",
        "",
        *_upper_references_line(report),
        *models_lines(folder, name),
        "| policy | seeds | episodes | IQM | 95 % interval | mean | spread | mean return | train time | env-steps/s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    notes = []
    for row in section.summary.to_dict("records"):
        agent = row["kind"] == "agent"
        mine = runs[runs["algo"] == row["policy"]] if runs is not None and agent else None
        cost = (
            f"{_duration(float(mine['wall_s'].sum()))} | "
            f"{_fmt(float((mine['env_steps'] + mine['eval_steps']).sum() / mine['wall_s'].sum()))}"
            if mine is not None and len(mine)
            else "- | -"
        )
        lines.append(
            f"| {row['policy']} | {row['seeds'] if agent else '-'} | {row['episodes']} | {_fmt(row['iqm'], scale)} "
            f"| {_ci(row['low'], row['high'], scale)} | {_fmt(row['mean'], scale)} | {_fmt(row['spread'], scale)} "
            f"| {_fmt(row['mean_return'])} | {cost} |"
        )
        if isinstance(row.get("identical_to"), str) and row["identical_to"]:
            notes.append(
                f"`{row['policy']}` is identical to `{row['identical_to']}` in every test episode: the two "
                "policies take the same score in each (to 1e-6 of the scores' magnitude), so every statistic of "
                "theirs is equal."
            )
    lines += ["", *(f"Note: {n}" for n in notes), *([""] if notes else [])]
    seeds = analysis.per_seed(section.episodes, runs)
    if len(seeds):
        lines += ["Per training seed (a failed seed shows here; the pooled IQM can hide it):", ""]
        lines += [
            "| policy | seed | IQM | mean | validation-selected checkpoint | trained by | resumed |",
            "|---|---|---|---|---|---|---|",
        ]
        for row in seeds.to_dict("records"):
            kept = row.get("selected_at")
            at = f"{int(kept):,} {row['selected_unit']}" if kept == kept and kept is not None else "-"
            trained_by, resumed = run_provenance(runs, row["policy"], row["seed"])
            lines.append(
                f"| {row['policy']} | {row['seed']} | {_fmt(row['iqm'], scale)} | {_fmt(row['mean'], scale)} | {at} "
                f"| {trained_by} | {resumed} |"
            )
        lines.append("")
    if len(section.improvement):
        lines += [
            "Probability of improvement (a run of the agent scores more than the baseline on the same test episode):",
            "",
            "| agent | baseline | P(agent > baseline) [95 % interval] |",
            "|---|---|---|",
        ]
        for row in section.improvement.to_dict("records"):
            lines.append(
                f"| {row['agent']} | {row['baseline']} | {_fmt(float(row['p']))} {_ci(row['low'], row['high'])} |"
            )
        lines.append("")
    for own in (False, True):
        claims = [c for c in section.claims if c.get("paper", True) is not own]
        if not claims:
            continue
        title = "This suite's own checks (not claims of the paper):" if own else "Claims of the paper:"
        lines += [
            title,
            "",
            "| claim | comparison: difference [interval] | level | verdict | rule |",
            "|---|---|---|---|---|",
        ]
        for c in claims:
            if not c["comparisons"]:
                lines.append(f"| {c['text']} | - | - | {_verdict(c['verdict'], budget)} | {c['rule']} |")
                continue
            for i, comp in enumerate(c["comparisons"]):
                lines.append(
                    f"| {c['text'] if i == 0 else ''} | {_comparison(c, comp, scale)} | {_fmt(float(comp['level']))} "
                    f"| {_verdict(comp['verdict'], budget, bold=False)} | {comp['rule']} |"
                )
            lines.append(
                f"| | **claim** | {_fmt(float(c['family_level']))} | {verdict_cell(c, machine_caveat(report))} "
                f"| {_rule(c)} |"
            )
        lines.append("")
        lines += [_shows(section, c) for c in claims if own] + ([""] if own else [])
    if comparison is not None:
        lines += _against_sb3(comparison, scale)
    for file, caption in _FIGURES:
        if (folder / file).exists():
            lines += [f"![{report['env_id']}: {caption}]({name}/{file})", ""]
    return lines


def learned_words(c: dict[str, Any]) -> str:
    """What a claim's agent learned, when every seed of it scores as a baseline in every test episode; else ``""``."""
    same = c.get("identical_to")
    if not same:
        return ""
    return (
        f"`{c['policy']}` learned nothing beyond `{same}`: every seed scores exactly as `{same}` in every test "
        f"episode, so the verdict is about `{same}`'s policy"
    )


def verdict_cell(c: dict[str, Any], caveat: str = "") -> str:
    """A claim's verdict with what its agent learned (:func:`learned_words`) and the section's caveat, if any."""
    notes = [n for n in (learned_words(c), caveat) if n]
    return _verdict(c["verdict"], c["budget"]) + "".join(f"; {n}" for n in notes)


def _headline(text: str) -> str:
    """A claim's own words, without the parenthesis and reading that follow them (where the paper makes it)."""
    return text.split(" (", 1)[0]


def _short_notes(c: dict[str, Any], caveat: str) -> str:
    """What a verdict cell of the short table says under the verdict: its caveat and what its agent learned."""
    notes = [f"`{c['policy']}` scores as `{c['identical_to']}`"] if c.get("identical_to") else []
    notes += ["machine-dependent"] if caveat else []
    return "<br>" + "; ".join(notes) if notes else ""


def _claim_section(c: dict[str, Any]) -> str:
    """The section a claim's record was decided in (:func:`~gym4real.results.artefacts.section_name`)."""
    return section_name(c["env_id"], c["budget"], c.get("trainer", "sb3"))


def _agent(c: dict[str, Any]) -> str:
    """The PPO agent of a claim record's trainer: ``ppo-jax`` for the JAX trainer (:func:`~gym4real.rl.train.label`)."""
    return label("ppo", c.get("trainer", "sb3"))


def claims_table(
    claims: list[dict[str, Any]],
    scales: dict[str, float] | None = None,
    own: bool = False,
    marks: dict[str, str] | None = None,
    caveats: dict[str, str] | None = None,
) -> str:
    """Per claim of the paper (``own``: per own check): a short Markdown table, then each claim in full.

    The table has four narrow columns: the env (with its budget under it unless a plain ``paper``, and the
    agent of its trainer when not SB3's: ``trainer `ppo-jax```), the claim's
    own words, the verdict with its mark (:data:`SYMBOLS`; a caveat or what the agent learned under it) and the
    deciding difference with its interval. A details block below gives each claim in full: where the paper
    makes it, the budget, the verdict with its notes, the rule that decided it and the deciding comparison with
    the seeds' own intervals and the margin.

    ``marks``: section name -> its budget column's entry (:func:`~gym4real.results.stand_ins.budget_mark`);
    ``caveats``: section name -> the caveat its verdicts carry (:func:`~gym4real.results.section_provenance.
    machine_caveat`).
    """
    claims = [c for c in claims if c.get("paper", True) is not own]
    if not claims:
        return ""
    column = "check of this suite's own" if own else "paper's claim"
    lines = [f"| env | {column} | verdict | deciding difference [interval] |", "|---|---|---|---|"]
    details = []
    for c in claims:
        env = c["env_id"].split("/", 1)[-1]
        key = _claim_section(c)
        scale = (scales or {}).get(key, 0.0)
        comp = next((x for x in c["comparisons"] if x["b"] == c.get("deciding")), None)
        budget = (marks or {}).get(key, c["budget"])
        caveat = (caveats or {}).get(key, "")
        under = [] if budget == "paper" else [c["budget"] + (", stand-in" if budget != c["budget"] else "")]
        under += [f"trainer `{_agent(c)}`"] if c.get("trainer", "sb3") != "sb3" else []
        lines.append(
            f"| `{env}`{''.join(f'<br>{u}' for u in under)} | {_headline(c['text'])} "
            f"| {_verdict(c['verdict'], c['budget'])}{_short_notes(c, caveat)} "
            f"| {_difference(c, comp, scale) if comp else '-'} |"
        )
        details.append(
            f"- `{env}`: {c['text']}. Verdict: {verdict_cell(c, caveat)}. Budget: {budget}. Rule: {_rule(c)}. "
            f"Deciding comparison: {_comparison(c, comp, scale) if comp else '-'}."
        )
    summary = (
        f"<summary>Each {'check' if own else 'claim'} in full: where it is made, the budget, the rule that decided "
        "it, the seeds' own intervals, the margin and the caveats</summary>"
    )
    return "\n".join([*lines, "", '<details markdown="1">', summary, "", *details, "", "</details>", ""])


def _verdicts(
    claims: list[dict[str, Any]], scales: dict[str, float], marks: dict[str, str], caveats: dict[str, str]
) -> list[str]:
    """The verdict tables (the paper's claims, then this suite's own checks) and the three verdicts' definitions."""
    paper = Counter(c.get("trainer", "sb3") for c in claims if c.get("paper", True))
    others = "".join(f", and {n} on the runs of the {t.upper()} trainer" for t, n in paper.items() if t != "sb3")
    own = claims_table(claims, scales, own=True, marks=marks, caveats=caveats)
    legend = " · ".join(f"{SYMBOLS[word]} **{word}**" for word in VERDICTS)
    return [
        f"## Verdicts on the paper's claims ({paper['sb3']}{others})",
        "",
        f"{legend} (defined below the tables); each claim in full under its table.",
        "",
        claims_table(claims, scales, marks=marks, caveats=caveats),
        *(
            [
                "Checks of this suite's own, outside the paper's claims: the paper does not make them.",
                "",
                own,
            ]
            if own
            else []
        ),
        "The verdicts (each with the rule that decided it; the rules, statistics and levels are under "
        "[Methods](#methods)):",
        "",
        *(f"- {SYMBOLS[word]} **{word}**: {words}." for word, words in VERDICTS.items()),
        "",
    ]


def _summary_figure(sections: list[Section], out: Path) -> list[str]:
    """The page's opening figure (every agent and baseline per env, :mod:`summary_figure`) and its link."""
    panels = [
        (s.report["env_id"], " + ".join(s.report["objective"]), s.summary)
        for s in sections
        if s.budget == "paper" and s.trainer == "sb3"  # the reference trainer's: one panel per env
    ]
    if summary_figure.write(panels, out) is None:
        return []
    return [
        f"![Every agent and baseline per env: IQM of the objective and its 95 % interval]({summary_figure.FILE})",
        "",
    ]


def _method(comparisons: bool = False) -> list[str]:
    """The page's Methods; ``comparisons``: with the rules of the trainer comparisons (the page has one)."""
    return [
        "## Methods",
        "",
        "Generated by `gym4real reproduce` from the files beside this page alone: every RL algorithm of the "
        "paper trained per seed with the budget's training presets, then tested on the environment's test "
        "protocol beside the baselines. `<env>-<budget>/episodes.csv` holds every test score (one row per "
        "policy, seed and episode); every number below about test scores is computed from it "
        "(`gym4real.results.analysis`), `runs.csv` holds each training run and its settings, and "
        "`manifest.json` the code version, package versions and the SHA-256 of the data files.",
        "",
        "**Statistics.** A policy's score in a test episode is the per-episode objective. The IQM "
        "(interquartile mean over all seeds and test episodes) has a 95 % two-level (seed, episode) "
        "percentile-bootstrap interval: each replicate draws the test episodes with replacement, the same ones "
        "for every policy, and an RL algorithm's training seeds with replacement, so that the interval covers "
        "the variability of training as well as of the test episodes; a baseline's episodes are resampled only. "
        f"Every interval takes enough replicates that {stats.TAIL} lie beyond each of its ends "
        f"({stats.replicates_at(0.95):,} at 95 %, more at a claim's Bonferroni level), so that its ends do not "
        "depend on the bootstrap's seed (rerun with five seeds, no verdict changes and no deciding end moves by 5 % "
        "of its interval's width). *Spread* is the standard deviation across test episodes, per seed, averaged "
        "over seeds. The probability "
        "of improvement is rliable's P(agent > baseline): the chance that a run of the agent scores more than "
        "the baseline on the same test episode (ties count one half). Numbers below 1e-9 of the scores' "
        "magnitude are float noise and shown as 0. Wall times and env-steps/s were measured on a shared machine "
        "and vary with its load.",
        "",
        f"**Budgets.** An environment is shown at the `paper` budget when it was run there, else at the `quick` "
        f"budget (the smoke presets: seconds of training), whose verdicts are a *{QUICK}*.",
        "",
        "**Quantities of the claims.** A claim compares one per-episode quantity:",
        "",
        *(f"- *{name}*: {words}." for name, words in QUANTITIES.items()),
        "",
        "**Rules of the verdicts.** Each claim comparison is the difference of a statistic (policy - other) "
        "with its interval; a *consistently* claim also takes each training seed's own interval (that seed's "
        "test episodes resampled, paired with the other policy), and a seed counts as better or worse only when "
        "its interval says so. No verdict rests on a point estimate. The rule that decided each verdict is named "
        "beside it:",
        "",
        *(f"- *{name}*: {words}." for name, words in RULES.items()),
        "",
        *(
            [
                f"**Rules of the trainer comparisons** (*{trainer_comparison.CLAIM}*, issue 43). The difference "
                "IQM(other trainer's PPO) - IQM(SB3's PPO) of the objective takes a 95 % two-level interval (the "
                "test episodes drawn once for both, each trainer's seeds on their own):",
                "",
                *(f"- *{name}*: {words}." for name, words in trainer_comparison.RULES.items()),
                "",
            ]
            if comparisons
            else []
        ),
    ]


def suite_scores(sections: list[Section]) -> list[str]:
    """The page's suite-score section: each paper agent's scores on the paper-budget envs of the page.

    Computed from the sections' ``episodes.csv`` alone, on the scale of :mod:`gym4real.bench.suite_score`
    (0 = ``random``, 1 = the env's best rule-based baseline), the same numbers ``gym4real evaluate`` prints
    beside a user's agent: per env, and aggregated over the envs each agent was trained on. Agents trained on
    different envs are in separate tables: their aggregates average different envs and are not ranked.
    """
    from gym4real.bench import suite_score
    from gym4real.bench.benchmark import protocol
    from gym4real.bench.episodes import score_matrices

    runs: dict[str, dict[str, tuple[np.ndarray, suite_score.Scale]]] = {}
    scales: list[str] = []
    for section in sections:
        if section.budget != "paper":
            continue
        env_id = section.report["env_id"]
        scores, seeds = score_matrices(section.episodes, section.name)
        anchors = {p: m for p, m in scores.items() if not seeds[p]}
        env_scale = suite_score.scale(env_id, anchors, protocol(env_id).rule_based)
        if not env_scale.usable:
            scales.append(f"`{env_id}`: no scale ({env_scale.note})")
            continue
        scales.append(f"`{env_id}`: 0 = random, 1 = `{env_scale.best}`")
        for policy, matrix in scores.items():
            if seeds[policy]:
                runs.setdefault(policy, {})[env_id] = (matrix, env_scale)
    if not runs:
        return []
    lines = [
        "## Suite score of the paper agents",
        "",
        "Each run (a training seed on an env) scores the IQM of its test episodes on the env's scale: 0 is the "
        "`random` baseline, 1 the env's best rule-based baseline (what a practitioner would deploy without "
        "learning; the scale does not reach the optimum: the headroom table below measures the distance to the upper "
        "references). Per env: the IQM of the agent's episodes there (all seeds), normalised. An agent's suite "
        "score is the IQM of its runs over the envs it was trained on, with a stratified bootstrap (seeds and test "
        "episodes resampled within each env), and its shortfall below the best rule (the mean shortfall of the runs "
        "below 1: rliable's *optimality gap* with the best rule as the target, not a gap to an optimum). Agents "
        "trained on different envs average different envs: each set of envs has its own table, and agents are "
        "compared per env, never by aggregates over different envs. `gym4real evaluate` puts your agent on the same "
        "scale. Scales: "
        + "; ".join(dict.fromkeys(scales))  # an env's scale once, whatever trainers' sections it has
        + ".",
        "",
    ]
    groups: dict[tuple[str, ...], list[str]] = {}
    for policy in sorted(runs):
        groups.setdefault(tuple(runs[policy]), []).append(policy)
    for envs, policies in groups.items():
        names = [f"`{e.split('/', 1)[-1]}`" for e in envs]
        lines += [
            f"Trained on {', '.join(names)}:",
            "",
            f"| agent | runs | {' | '.join(names)} | suite score (IQM) [95 % CI] | shortfall below the best rule "
            "[95 % CI] |",
            "|---|---|" + "---|" * len(envs) + "---|---|",
        ]
        for policy in policies:
            score = suite_score.summary(runs[policy])
            per_env = " | ".join(_fmt(float(score["per_env"][e])) for e in envs)
            lines.append(
                f"| {policy} | {score['runs']} | {per_env} | {_fmt(float(score['iqm']))} "
                f"{_ci(score['low'], score['high'])} | {_fmt(float(score['shortfall']))} "
                f"{_ci(score['shortfall_low'], score['shortfall_high'])} |"
            )
        lines.append("")
    return lines


def manifest(sections: list[Section], version: str) -> dict[str, Any]:
    """``manifest.json``: the page's code version, each section's, package versions, platform, data files.

    ``rendered_by`` is the code that wrote the page; ``provenance`` holds per section its command,
    fingerprints, the distributions it imported, its models and the SHA-256 of every file it publishes
    (:mod:`~gym4real.results.page_manifest`); ``imported`` is their union. ``code_version`` is the commit that
    tested the most sections; ``versions`` and ``platform`` hold every value of the sections' reports (a
    distribution at two versions as ``0.2.0 / 0.3.0``, platforms joined by ``; ``), so that neither gives one
    section's as the page's.
    """
    from gym4real.bench.versions import code_version

    records = {s.name: section_record(s.folder, s.report, published_files(s.folder), s.stale) for s in sections}
    versions: dict[str, set[str]] = {}
    for s in sections:
        for name, value in s.report["versions"].items():
            versions.setdefault(name, set()).add(str(value))
    return {
        "code_version": version,
        "rendered_by": code_version(),
        "sections": {s.name: s.version for s in sections},
        "imported": imported_by_all(records),
        "provenance": records,
        "versions": {name: " / ".join(sorted(values)) for name, values in sorted(versions.items())},
        "platform": "; ".join(sorted({str(s.report["platform"]) for s in sections})),
        "data_files": {s.name: s.report["data_files"] for s in sections},
    }


def _versions_line(record: dict[str, Any]) -> str:
    """The page's line of code versions, package versions and platforms, from its :func:`manifest`."""
    tested = sorted(set(record["sections"].values()))
    if len(tested) == 1:
        where = f"every section tested at `{tested[0]}`"
    else:
        where = f"sections tested at {', '.join(f'`{v}`' for v in tested)} (each names its own)"
    listed = ", ".join(f"{name} {value}" for name, value in record["versions"].items())
    return (
        f"Rendered by code version `{record['rendered_by']}`; {where} (`manifest.json`). "
        f"Versions (the sections' own, every one named): {listed}; {record['platform']}."
    )


def page_files(out: Path, text: str) -> dict[str, str]:
    """The page's own files with their SHA-256: ``claims.json``, the summary figure, ``index.md``, ``trainers.json``.

    ``trainers.json``: the trainer comparisons (:mod:`~gym4real.results.trainer_comparison`), where the page has one.

    ``text`` is the page, which an output folder holds as ``results.md``.
    """
    files = [p for name in ("claims.json", summary_figure.FILE, trainer_comparison.FILE) if (p := out / name).exists()]
    return {**files_sha256(files, out), PAGE: hashlib.sha256(text.encode()).hexdigest()}


def refresh_manifest(folder: str | Path) -> Path:
    """Rewrite ``manifest.json`` of a rendered folder from its files, keeping what its rendering found.

    For an edit of files whose text the page does not show (a model's ``note`` in ``models.json``) and for a
    manifest written before it recorded a file or field: every file's SHA-256 and what each section's files
    record (models, imported distributions, machines, versions) are read again from the folder; the code
    versions and each section's currency are the rendering's, as the manifest recorded them. Nothing else
    is written. ``python scripts/refresh_manifest.py docs/results``.

    Raises:
        DamagedResultsError: The manifest or a section's ``report.json`` cannot be read, or the sections of
            the folder are not those the manifest lists: render the page again instead.
    """
    folder = Path(folder)
    old = read_json(folder / MANIFEST, MANIFEST)
    here = {p.name for p in folder.iterdir() if p.is_dir() and FOLDER.match(p.name)}
    if not isinstance(old, dict) or not isinstance(old.get("provenance"), dict) or set(old["provenance"]) != here:
        raise DamagedResultsError(
            f"`{folder / MANIFEST}` does not list the sections of `{folder}` ({', '.join(sorted(here))}): render the "
            "page again (`gym4real reproduce ... --page`) rather than refresh its manifest"
        )
    records = {}
    for name, before in old["provenance"].items():
        report = read_json(folder / name / "report.json", f"{name}/report.json")
        records[name] = section_record(folder / name, report, published_files(folder / name), list(before["stale"]))
    text = (folder / PAGE if (folder / PAGE).is_file() else folder / RENDERED).read_text()
    record = {**old, "imported": imported_by_all(records), "provenance": records, "files": page_files(folder, text)}
    (folder / MANIFEST).write_text(json.dumps(record, indent=1))
    return folder / MANIFEST


def published_files(folder: Path) -> list[Path]:
    """The files of a results folder that the page folder holds: data, statistics, figures and models."""
    files = [folder / f for f in PUBLISHED] + [folder / f for f, _ in _FIGURES]
    models = sorted(p for p in (folder / MODELS).rglob("*") if p.is_file()) if (folder / MODELS).is_dir() else []
    return [f for f in files if f.exists()] + models


def _publish(folder: Path, page: Path) -> None:
    """Copy a results folder's published files, figures and models into ``page/<env>-<budget>/``."""
    target = page / folder.name
    if target.resolve() == folder.resolve():
        return
    shutil.rmtree(target, ignore_errors=True)
    for file in published_files(folder):
        copy = target / file.relative_to(folder)
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(file, copy)


def write_page(out: Path, page: str | Path | None = None) -> Path:
    """Write ``out/results.md`` (and ``page/index.md`` with its files) from the results folders in ``out``."""
    out = Path(out)
    folders = _folders(out)
    sections = {folder: Section(folder) for folder in folders if _has_results(folder)}
    counts = Counter(s.version for s in sections.values())
    version = counts.most_common(1)[0][0] if counts else "none"
    # every claim of the reference trainer's sections; another trainer's where it was checked on its agent (its
    # records name the trainer): a claim about an agent that trainer does not train shows in its section alone
    claims = [c for s in sections.values() for c in s.claims if s.trainer == "sb3" or c["verdict"] != "not checked"]
    comparisons = trainer_comparisons(list(sections.values()))
    scales = {s.name: s.scale for s in sections.values()}
    marks = {s.name: budget_mark(s.report, s.budget) for s in sections.values()}
    caveats = {s.name: machine_caveat(s.report) for s in sections.values()}
    record = manifest(list(sections.values()), version)
    others = [s.name for s in sections.values() if s.stale]
    head = [
        "# Reproduced results",
        "",
        *([f"**Stale sections, flagged below: {', '.join(others)}.**", ""] if others else []),
        *_verdicts(claims, scales, marks, caveats),
        *trainer_table(comparisons, scales),
        _versions_line(record),
        "",
        *_summary_figure(list(sections.values()), out),
        *suite_scores(list(sections.values())),
        *headroom_table(list(sections.values())),
    ]
    body: list[str] = []
    against = {c["section"]: c for c in comparisons}
    for folder in folders:
        body += _section(folder, sections.get(folder), against.get(folder.name))
    text = "\n".join(head + body + _method(bool(comparisons)))
    (out / "results.md").write_text(text)
    (out / "claims.json").write_text(json.dumps(claims, indent=1))
    if comparisons:
        (out / trainer_comparison.FILE).write_text(json.dumps(comparisons, indent=1))
    else:  # a page without two trainers' sections of an env: no comparison file left from an earlier one
        (out / trainer_comparison.FILE).unlink(missing_ok=True)
    (out / "claims.md").write_text(
        claims_table(claims, scales, marks=marks, caveats=caveats) + claims_table(claims, scales, True, marks, caveats)
    )
    record["files"] = page_files(out, text)
    (out / MANIFEST).write_text(json.dumps(record, indent=1))
    if page is None:
        return out / "results.md"
    page = Path(page)
    page.mkdir(parents=True, exist_ok=True)
    (page / "index.md").write_text(text)
    for name in ("claims.json", MANIFEST, summary_figure.FILE, trainer_comparison.FILE):
        if (out / name).exists() and (page / name).resolve() != (out / name).resolve():
            shutil.copy(out / name, page / name)
    if not (out / trainer_comparison.FILE).exists():
        (page / trainer_comparison.FILE).unlink(missing_ok=True)
    shutil.rmtree(page / "figures", ignore_errors=True)  # the layout before raw data: figures/<env>-<budget>/
    for folder in folders:
        _publish(folder, page)
    return page / "index.md"
