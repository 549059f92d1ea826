"""``scripts/add_upper_references.py``: upper references added to a published section, or refused when stale."""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gym4real.bench.benchmark import protocol

ROOT = Path(__file__).resolve().parents[1]


def _script():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("add_upper_references", ROOT / "scripts" / "add_upper_references.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_section_whose_protocol_changed_is_refused_and_left_as_it_was(tmp_path: Path) -> None:
    folder = tmp_path / "dam-v0-paper"
    shutil.copytree(ROOT / "docs" / "results" / "dam-v0-paper", folder)
    report = json.loads((folder / "report.json").read_text())
    report["fingerprints"]["protocol"]["episodes"] = "another protocol"
    (folder / "report.json").write_text(json.dumps(report, indent=1))
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    said = _script().add(folder)
    assert "not current" in said and "protocol" in said and "--stale" in said
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before


def test_only_a_training_file_not_found_here_leaves_a_section_comparable() -> None:
    blocking = _script()._blocking
    assert blocking(["data.microgrid/demand/train: not found here"]) == []
    assert blocking(["data.dam/inflow: 'a' -> 'b'"]) == ["data.dam/inflow: 'a' -> 'b'"]
    assert blocking(["protocol.episodes changed"]) == ["protocol.episodes changed"]


@pytest.mark.slow
def test_the_upper_reference_rows_are_added_beside_the_sections_own_rows_which_stay_as_they_were(
    tmp_path: Path,
) -> None:
    """On wds (20 test weeks), whose planner's rows the published section lacks."""
    folder = tmp_path / "wds-v0-paper"
    shutil.copytree(ROOT / "docs" / "results" / "wds-v0-paper", folder)
    own = pd.read_csv(folder / "episodes.csv")
    said = _script().add(folder)
    assert said.startswith("wds-v0-paper: added hindsight (20 test episodes"), said
    episodes = pd.read_csv(folder / "episodes.csv")
    pd.testing.assert_frame_equal(episodes.iloc[: len(own)], own)  # the section's own rows, untouched
    upper = episodes[episodes["policy"] == "hindsight"]
    assert list(upper["episode"]) == list(range(20)) and upper["seed"].isna().all()
    rules = own[own["policy"].isin(protocol("gym4real/wds-v0").rule_based)]
    best_rule = rules.groupby("policy")["objective"].mean().max()
    assert upper["objective"].mean() >= best_rule  # an upper reference: at least the best rule on average
    report = json.loads((folder / "report.json").read_text())
    assert report["upper_references"]["policies"] == ["hindsight"]
    summary = pd.read_csv(folder / "summary.csv")
    assert "hindsight" in set(summary["policy"])


def test_a_causal_baseline_is_added_beside_the_sections_rows_and_recorded_apart_from_the_upper_references(
    tmp_path: Path,
) -> None:
    """On dam (13 test years): `historical_replay`, a registered baseline outside the protocol's, added by name."""
    folder = tmp_path / "dam-v0-paper"
    shutil.copytree(ROOT / "docs" / "results" / "dam-v0-paper", folder)
    own = pd.read_csv(folder / "episodes.csv")
    before = json.loads((folder / "report.json").read_text())
    said = _script().add(folder, "abc1234", ["historical_replay"])
    assert said.startswith("dam-v0-paper: added historical_replay (13 test episodes"), said
    episodes = pd.read_csv(folder / "episodes.csv")
    pd.testing.assert_frame_equal(episodes.iloc[: len(own)], own)  # the section's own rows, untouched
    added = episodes.iloc[len(own) :]
    assert set(added["policy"]) == {"historical_replay"} and list(added["episode"]) == list(range(13))
    assert added["seed"].isna().all() and np.isfinite(added["objective"]).all()
    report = json.loads((folder / "report.json").read_text())
    assert report["upper_references"] == before["upper_references"]  # the upper references' record, untouched
    (record,) = [r for r in report["added_baselines"] if r["policies"] == ["historical_replay"]]
    assert record["code_version"] == "abc1234" and record["test_wall_time_s"] > 0
    assert record["command"] == f"python scripts/add_upper_references.py --policies historical_replay {folder}"
    assert "historical_replay" in set(pd.read_csv(folder / "summary.csv")["policy"])
    # measured again: its rows replaced by the same scores (the protocol is seeded), one record of it
    assert _script().add(folder, "def5678", ["historical_replay"]).startswith("dam-v0-paper: added")
    again = pd.read_csv(folder / "episodes.csv")
    pd.testing.assert_frame_equal(again, episodes)
    records = json.loads((folder / "report.json").read_text())["added_baselines"]
    assert [r["code_version"] for r in records if "historical_replay" in r["policies"]] == ["def5678"]


def test_an_unknown_baseline_or_a_mix_with_the_upper_references_is_refused_and_nothing_written(tmp_path: Path) -> None:
    folder = tmp_path / "dam-v0-paper"
    shutil.copytree(ROOT / "docs" / "results" / "dam-v0-paper", folder)
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    said = _script().add(folder, policies=["nope"])
    assert "['nope'] not among the baselines of gym4real/dam-v0" in said and "mpc" in said
    said = _script().add(folder, policies=["mpc", "hindsight"])
    assert "separate runs" in said
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before


def test_a_policy_measured_again_leaves_the_earlier_record_of_the_others() -> None:
    report = {"added_baselines": [{"policies": ["a", "b"], "code_version": "1"}]}
    _script()._record(report, ["b"], False, {"policies": ["b"], "code_version": "2"})
    assert report["added_baselines"] == [
        {"policies": ["a"], "code_version": "1"},
        {"policies": ["b"], "code_version": "2"},
    ]
    _script()._record(report, ["a"], False, {"policies": ["a"], "code_version": "3"})
    assert [r["code_version"] for r in report["added_baselines"]] == ["2", "3"]
    _script()._record(report, ["hindsight"], True, {"policies": ["hindsight"]})
    assert report["upper_references"] == {"policies": ["hindsight"]} and len(report["added_baselines"]) == 2


def test_a_policy_measured_again_keeps_its_place_and_a_new_one_comes_last() -> None:
    rows = [("random", None, 0, 1.0), ("ppo", 0, 0, 2.0), ("hindsight", None, 0, 3.0), ("mpc", None, 0, 4.0)]
    episodes = pd.DataFrame(rows, columns=["policy", "seed", "episode", "objective"])
    again = pd.DataFrame([("hindsight", None, 0, 3.5), ("oracle", None, 0, 5.0)], columns=episodes.columns)
    merged = _script()._merge(episodes, again)
    assert list(merged["policy"]) == ["random", "ppo", "hindsight", "mpc", "oracle"]
    assert list(merged["objective"]) == [1.0, 2.0, 3.5, 4.0, 5.0] and str(merged["seed"].dtype) == "Int64"
