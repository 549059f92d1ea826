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


def stand_in_presets(report: dict[str, Any]) -> list[tuple[str, str, str, int | None, int | None, str]]:
    """The section's stand-in presets: ``(algo, preset, named, its size, the named preset's size, unit)``.

    A stand-in preset is one that serves the budget in place of the preset named for it (``named``); the sizes
    are its ``total_timesteps`` (unit ``steps``) or ``episodes``, None where no preset is named for the budget.
    """
    from gym4real.bench.seeds import BUDGETS
    from gym4real.rl.presets import load_preset

    env_id, budget = report["env_id"], report["budget"]
    named = BUDGETS.get(budget, budget)
    found: list[tuple[str, str, str, int | None, int | None, str]] = []
    for algo, preset in report.get("presets", {}).items():
        if preset == named:
            continue
        try:
            mine = load_preset(env_id, algo, preset)
        except Exception:  # a preset no longer registered: named, not sized
            found.append((algo, preset, named, None, None, "steps"))
            continue
        unit = "total_timesteps" if "total_timesteps" in mine else "episodes"
        try:
            theirs = load_preset(env_id, algo, named).get(unit)
        except Exception:  # no preset named for the budget: nothing to compare with
            theirs = None
        words = "steps" if unit == "total_timesteps" else "episodes"
        found.append((algo, preset, named, mine.get(unit), theirs or None, words))
    return found


def budget_mark(report: dict[str, Any], budget: str) -> str:
    """The budget column's entry: ``paper``, with the stand-in data it read and the fraction of the paper's steps.

    ``paper (stand-in data: ...; 2.6 % of the paper's steps)`` when it read stand-in data or trained with
    stand-in presets (:func:`stand_in_presets`; per algorithm where their fractions differ).
    """
    parts = []
    data = stand_in_data(report)
    if data:
        parts.append(f"**stand-in data**: {'; '.join(data)}")
    fractions = {
        algo: f"{100 * mine / theirs:.2g} % of the paper's {unit}"
        for algo, _, _, mine, theirs, unit in stand_in_presets(report)
        if mine is not None and theirs
    }
    if fractions:
        if len(set(fractions.values())) == 1:
            parts.append(f"**{next(iter(fractions.values()))}**")
        else:
            parts.append("; ".join(f"`{algo}` **{words}**" for algo, words in fractions.items()))
    return f"{budget} ({'; '.join(parts)})" if parts else budget


def differences(report: dict[str, Any], episodes: pd.DataFrame) -> list[str]:
    """How a section's experiment differs from the paper's: stand-in data, presets (steps), test episodes.

    Empty when it read no stand-in data and trained with the presets named for its budget.
    """
    found = [f"data: {'; '.join(data)}" for data in [stand_in_data(report)] if data]
    for algo, preset, named, mine, theirs, unit in stand_in_presets(report):
        if theirs is None or mine is None:
            found.append(f"`{algo}` trained with the stand-in preset `{preset}`")
            continue
        found.append(
            f"`{algo}` trained with the stand-in preset `{preset}` in place of `{named}`: {mine:,} {unit}, "
            f"{100 * mine / theirs:.1f} % of the {theirs:,} of `{algo}/{named}`"
        )
    if found:
        tests = int(episodes.groupby(["policy", "seed"], dropna=False)["episode"].nunique().max())
        found.append(f"test: {tests} episodes of this data's test split ({report['protocol']})")
    return found


def difference_lines(report: dict[str, Any], episodes: pd.DataFrame) -> list[str]:
    """The section's paragraph on how it differs from the paper's experiment (and a blank line), if it does."""
    found = differences(report, episodes)
    return [f"**Differs from the paper's experiment:** {'; '.join(found)}.", ""] if found else []
