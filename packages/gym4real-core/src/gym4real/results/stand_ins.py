"""Where a results section stands in for the paper's experiment: its data and its training presets.

A section at the ``paper`` budget may run on stand-in data (a registered file that
``DatasetSpec.stand_in_for`` the paper's, or a synthetic file read in place of a missing one) and with
stand-in presets (``TrainingSpec.budget``: a preset that serves the ``paper`` budget in place of the one
named ``paper``). :func:`budget_mark` labels the budget column of the page's tables, and
:func:`differences` says, in the section, how the experiment differs from the paper's, from the section's
``report.json`` and ``episodes.csv`` and the registered presets.
"""

from __future__ import annotations

from typing import Any

import pandas as pd


def stand_in_data(report: dict[str, Any]) -> list[str]:
    """The stand-in data a section read, one short phrase each (a file's description up to its first comma)."""
    from gym4real.core.registry import registry

    datasets, found = registry().datasets, []
    for row in report.get("data_files", []):
        spec = datasets.get(row["name"])
        if spec is not None and spec.stand_in_for:
            found.append(spec.description.split(",", 1)[0] or f"`{row['name']}`")
        elif row.get("read_instead"):
            found.append(f"synthetic `{row['name']}`")
    return list(dict.fromkeys(found))


def budget_mark(report: dict[str, Any], budget: str) -> str:
    """The budget column's entry: ``paper``, or ``paper (stand-in data: ...)`` when it read stand-in data."""
    data = stand_in_data(report)
    return f"{budget} (**stand-in data**: {'; '.join(data)})" if data else budget


def differences(report: dict[str, Any], episodes: pd.DataFrame) -> list[str]:
    """How a section's experiment differs from the paper's: stand-in data, presets (steps), test episodes.

    Empty when it read no stand-in data and trained with the presets named for its budget.
    """
    from gym4real.bench.seeds import BUDGETS
    from gym4real.rl.presets import load_preset

    env_id, budget = report["env_id"], report["budget"]
    named = BUDGETS.get(budget, budget)
    found = [f"data: {'; '.join(data)}" for data in [stand_in_data(report)] if data]
    for algo, preset in report.get("presets", {}).items():
        if preset == named:
            continue
        try:
            mine, theirs = load_preset(env_id, algo, preset), load_preset(env_id, algo, named)
        except Exception:  # no preset named for the budget: nothing to compare with
            found.append(f"`{algo}` trained with the stand-in preset `{preset}`")
            continue
        unit = "total_timesteps" if "total_timesteps" in mine else "episodes"
        if theirs.get(unit):
            found.append(
                f"`{algo}` trained with the stand-in preset `{preset}` in place of `{named}`: {mine[unit]:,} "
                f"{'steps' if unit == 'total_timesteps' else 'episodes'}, {100 * mine[unit] / theirs[unit]:.1f} % "
                f"of the {theirs[unit]:,} of `{algo}/{named}`"
            )
    if found:
        tests = int(episodes.groupby(["policy", "seed"], dropna=False)["episode"].nunique().max())
        found.append(f"test: {tests} episodes of this data's test split ({report['protocol']})")
    return found


def difference_lines(report: dict[str, Any], episodes: pd.DataFrame) -> list[str]:
    """The section's paragraph on how it differs from the paper's experiment (and a blank line), if it does."""
    found = differences(report, episodes)
    return [f"**Differs from the paper's experiment:** {'; '.join(found)}.", ""] if found else []
