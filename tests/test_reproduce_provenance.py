"""`gym4real reproduce`: damaged run files, published models, fingerprints (`--check`, `--stale`), manifest."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from gym4real.bench.versions import NOT_RECORDED
from gym4real.results import fingerprints
from gym4real.results.provenance import RUNS_TEXT
from gym4real.results.published_models import sha256_of
from gym4real.results.results_page import refresh_manifest

ROOT = Path(__file__).parents[1]
RESULTS = ROOT / "docs" / "results"


def _cli(*args: str, plugins: str = "elevator") -> subprocess.CompletedProcess[str]:
    others = {"dam", "elevator", "microgrid", "robofeeder", "trading", "wds"} - set(plugins.split(","))
    env = {**os.environ, "GYM4REAL_DISABLE_PLUGINS": ",".join(sorted(others))}
    return subprocess.run(
        [sys.executable, "-m", "gym4real.cli", "reproduce", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def _snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    return {
        p.relative_to(folder).as_posix(): (p.read_bytes(), p.stat().st_mtime_ns)
        for p in folder.rglob("*")
        if p.is_file()
    }


@pytest.fixture(scope="module")
def elevator_quick(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An output folder of `reproduce gym4real/elevator-v0 --budget quick --seeds 1` (tabular, seconds)."""
    out = tmp_path_factory.mktemp("reproduce") / "out"
    done = _cli("gym4real/elevator-v0", "--budget", "quick", "--seeds", "1", "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    return out


def test_a_truncated_qtable_stops_reproduce_naming_the_file_and_leaves_the_folder(
    elevator_quick: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    shutil.copytree(elevator_quick, out)
    run = out / "elevator-v0" / "quick" / "runs" / "qlearning" / "seed42"
    table = run / "qtable.npz"
    table.write_bytes(table.read_bytes()[: table.stat().st_size // 2])
    before = _snapshot(run)
    done = _cli("gym4real/elevator-v0", "--budget", "quick", "--seeds", "1", "--out", str(out), "--quiet")
    assert done.returncode != 0
    assert "qtable.npz" in done.stderr and "elevator-v0 qlearning seed 42" in done.stderr, done.stderr
    assert "--retrain-damaged" in done.stderr
    assert _snapshot(run) == before  # the damaged folder is left untouched, bytes and times

    again = _cli(
        "gym4real/elevator-v0", "--budget", "quick", "--seeds", "1", "--out", str(out), "--quiet", "--retrain-damaged"
    )
    assert again.returncode == 0, again.stderr
    aside = [p for p in run.parent.iterdir() if p.name.startswith("seed42.damaged-")]
    assert len(aside) == 1 and _snapshot(aside[0]).keys() == before.keys()
    assert (aside[0] / "qtable.npz").read_bytes() == before["qtable.npz"][0]
    first = elevator_quick / "elevator-v0" / "quick" / "runs" / "qlearning" / "seed42" / "qtable.npz"
    with np.load(run / "qtable.npz") as fresh, np.load(first) as old:  # trained again, to the same table
        assert np.array_equal(fresh["q"], old["q"])


@pytest.mark.parametrize(
    ("name", "cut"),
    [("run.json", 10), ("checkpoint.npz", 40), ("checkpoint/state.json", 5), ("curve.csv", 61), ("curve.csv", 55)],
)
def test_every_damaged_run_file_is_named_with_its_run(tmp_path: Path, name: str, cut: int) -> None:
    from gym4real.results.run_files import DamagedRunError, check_run_folder

    run = tmp_path / "seed3"
    (run / "checkpoint").mkdir(parents=True)
    (run / "run.json").write_text(json.dumps({"model": "qtable.npz", "wall_time_s": 1.0}))
    (run / "checkpoint" / "state.json").write_text(json.dumps({"timesteps": 4096, "slot": "a"}))
    np.savez(run / "checkpoint.npz", q=np.arange(100.0), episode=np.array(7))
    curve = pd.DataFrame({"timesteps": [2048, 4096], "mean_return": [-12.5, -9.25], "eval_episodes": [5, 5]})
    curve.to_csv(run / "curve.csv", index=False)  # 62 bytes: cut at 61 drops its last line break, at 55 mid-row
    check_run_folder(run, "dam-v0 ppo seed 3")  # whole files pass
    path = run / name
    path.write_bytes(path.read_bytes()[:cut])
    before = _snapshot(run)
    with pytest.raises(DamagedRunError, match=rf"run `dam-v0 ppo seed 3`: its file `{name}`"):
        check_run_folder(run, "dam-v0 ppo seed 3")
    assert _snapshot(run) == before


def test_a_truncated_learning_curve_of_a_finished_run_stops_reproduce_naming_it(
    elevator_quick: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    shutil.copytree(elevator_quick, out)
    curve = out / "elevator-v0" / "quick" / "runs" / "sarsa" / "seed42" / "curve.csv"
    curve.write_bytes(curve.read_bytes()[:-7])
    done = _cli("gym4real/elevator-v0", "--budget", "quick", "--seeds", "1", "--out", str(out), "--quiet")
    assert done.returncode != 0, done.stdout
    assert "curve.csv" in done.stderr and "elevator-v0 sarsa seed 42" in done.stderr, done.stderr
    assert "--retrain-damaged" in done.stderr


def test_a_section_lists_and_publishes_its_models_and_evaluate_reruns_them(
    elevator_quick: Path, listed_evaluate: Callable[[dict[str, Any], Path], pd.DataFrame]
) -> None:
    section = elevator_quick / "elevator-v0-quick"
    listing = json.loads((section / "models.json").read_text())
    assert [(m["algo"], m["seed"], m["published"]) for m in listing] == [("qlearning", 42, True), ("sarsa", 42, True)]
    episodes = pd.read_csv(section / "episodes.csv")
    for model in listing:
        path = section / model["path"]
        assert [f["sha256"] for f in model["files"]] == [sha256_of(path)]
        trained = elevator_quick / "elevator-v0" / "quick" / "runs" / model["algo"] / "seed42" / "qtable.npz"
        assert model["trained_table"]["sha256"] == sha256_of(trained)  # published as its greedy policy:
        with np.load(trained) as full, np.load(path) as greedy:  # the same action in every state, smaller
            assert np.array_equal(np.argmax(full["q"], axis=1), np.argmax(greedy["q"], axis=1))
            assert set(np.unique(greedy["q"])) <= {0, 1}
        assert path.stat().st_size < trained.stat().st_size
        mine = listed_evaluate(model, elevator_quick)  # the command as models.json lists it
        assert set(mine["seed"]) == {42}
        mine = mine.sort_values("episode")
        theirs = episodes[(episodes["policy"] == model["algo"]) & (episodes["seed"] == 42)].sort_values("episode")
        assert mine["objective"].tolist() == theirs["objective"].tolist()  # exactly, episode by episode
    manifest = json.loads((elevator_quick / "manifest.json").read_text())
    files = manifest["provenance"]["elevator-v0-quick"]["files"]
    assert files["elevator-v0-quick/models/qlearning-seed42/qtable.npz"] == listing[0]["files"][0]["sha256"]
    for relative, digest in files.items():  # every published file, hashed as it is
        assert sha256_of(elevator_quick / relative) == digest
    assert {"episodes.csv", "runs.csv", "report.json", "models.json"} <= {Path(f).name for f in files}


def test_the_manifest_lists_the_distributions_the_runs_imported(elevator_quick: Path) -> None:
    from importlib import metadata

    manifest = json.loads((elevator_quick / "manifest.json").read_text())
    imported = manifest["provenance"]["elevator-v0-quick"]["imported"]
    assert imported == manifest["imported"]
    for dist in ("numpy", "gymnasium", "pydantic", "PyYAML", "matplotlib", "pandas"):  # all used by a run
        assert imported[dist] == metadata.version(dist), dist
    assert "torch" not in imported  # a tabular section never imports torch
    runs = pd.read_csv(elevator_quick / "elevator-v0-quick" / "runs.csv", dtype=RUNS_TEXT)
    assert runs["resumes"].tolist() == ["[]", "[]"] and runs["trained_by"].str.len().gt(0).all()


def test_runs_and_test_phase_record_the_cpu_model_and_the_manifest_the_machines(elevator_quick: Path) -> None:
    """The manifest named no machine: the CPU model of whatever trained and tested each section."""
    from gym4real.bench.versions import cpu_model

    cpu = cpu_model()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists() and "model name" in cpuinfo.read_text():
        names = {
            " ".join(line.split(":", 1)[1].split())
            for line in cpuinfo.read_text().splitlines()
            if line.startswith("model name")
        }
        assert cpu in names
    run = json.loads(
        (elevator_quick / "elevator-v0" / "quick" / "runs" / "qlearning" / "seed42" / "run.json").read_text()
    )
    assert run["cpu"] == cpu
    section = elevator_quick / "elevator-v0-quick"
    assert pd.read_csv(section / "runs.csv")[["started_on", "cpu"]].values.tolist() == [[cpu, cpu], [cpu, cpu]]
    assert json.loads((section / "report.json").read_text())["cpu"] == cpu
    manifest = json.loads((elevator_quick / "manifest.json").read_text())
    assert manifest["provenance"]["elevator-v0-quick"]["machines"] == {"trained_on": {cpu: 2}, "tested_on": cpu}


def test_the_published_manifest_says_not_recorded_where_no_file_records_a_machine_or_an_import() -> None:
    manifest = json.loads((RESULTS / "manifest.json").read_text())
    for name, record in manifest["provenance"].items():
        report = json.loads((RESULTS / name / "report.json").read_text())
        runs = pd.read_csv(RESULTS / name / "runs.csv")
        if "cpu" not in runs.columns:  # trained before runs recorded their machine
            assert record["machines"]["trained_on"] == {"not recorded": len(runs)}, name
        assert record["machines"]["tested_on"] == report.get("cpu", "not recorded"), name
        assert record["imported"] == report.get("imported", "not recorded"), name


def test_the_committed_manifest_is_what_its_files_record(tmp_path: Path) -> None:
    """Rewriting the page's manifest from its files changes nothing: every hash, model listing and record in it
    is that of the committed files (a ``models.json`` edited without its manifest fails here)."""
    page = tmp_path / "results"
    shutil.copytree(RESULTS, page)
    refresh_manifest(page)
    assert (page / "manifest.json").read_text() == (RESULTS / "manifest.json").read_text()


def test_stale_leaves_a_section_that_is_only_not_checkable_here(
    tmp_path: Path, data_without_training_households: Path
) -> None:
    """A section whose data is missing here is not retrained by ``--stale``: nothing changed, the data is missing."""
    from gym4real.results.currency import reproduce_stale

    out = tmp_path / "out"
    shutil.copytree(RESULTS / "microgrid-v0-paper", out / "microgrid-v0-paper")
    said = reproduce_stale(out)
    assert said.startswith("microgrid-v0-paper: not checkable here, not rerun: ")
    assert "`gym4real data synthesize microgrid`" in said and not (out / "microgrid-v0").exists()


@pytest.mark.slow
def test_a_fresh_section_is_current_and_a_changed_fingerprint_makes_it_stale(
    elevator_quick: Path, tmp_path: Path
) -> None:
    done = _cli("--check", str(elevator_quick))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "elevator-v0-quick: current"
    out = tmp_path / "out"
    shutil.copytree(elevator_quick, out)
    report_path = out / "elevator-v0-quick" / "report.json"
    report = json.loads(report_path.read_text())
    report["fingerprints"]["trainer"]["trainer_version"] = 0
    report["fingerprints"]["protocol"]["episodes_sha256"] = "0" * 64
    report_path.write_text(json.dumps(report))
    assert _cli("--check", str(out)).returncode == 5  # report.json is not the file the manifest lists
    refresh_manifest(out)  # as if the section had been made by an earlier version of the code
    done = _cli("--check", str(out))
    assert done.returncode == 3, done.stderr
    line = done.stdout.strip()
    assert line.startswith("elevator-v0-quick: stale: ")
    assert "protocol.episodes_sha256 changed" in line and "trainer.trainer_version: 0 -> 1" in line
    assert "1 of 1 sections are stale" in done.stderr

    runs = out / "elevator-v0" / "quick" / "runs"
    stale = _cli("--stale", "--out", str(out), "--quiet")
    assert stale.returncode == 0, stale.stderr
    assert "elevator-v0-quick: stale" in stale.stdout and "trained again" in stale.stdout
    assert len(list(runs.parent.glob("runs.stale-*"))) == 1 and (runs / "qlearning" / "seed42" / "run.json").exists()
    assert _cli("--check", str(out)).returncode == 0
    assert "current, not rerun" in _cli("--stale", "--out", str(out), "--quiet").stdout


def test_a_protocol_change_alone_retests_the_finished_runs(elevator_quick: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(elevator_quick, out)
    report_path = out / "elevator-v0-quick" / "report.json"
    report = json.loads(report_path.read_text())
    report["fingerprints"]["protocol"]["episodes"] = 1
    report_path.write_text(json.dumps(report))
    refresh_manifest(out)
    run = out / "elevator-v0" / "quick" / "runs" / "qlearning" / "seed42" / "qtable.npz"
    stamp = run.stat().st_mtime_ns
    done = _cli("--stale", "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    assert "protocol.episodes: 1 -> " in done.stdout and "trained again" not in done.stdout
    assert run.stat().st_mtime_ns == stamp  # reused, not trained again
    assert _cli("--check", str(out)).returncode == 0


def test_changes_name_each_part_that_differs() -> None:
    recorded = {"protocol": {"episodes": 13}, "data": {"dam/mef": "a" * 64}, "trainer": {"torch": "2.13.0"}}
    installed = {"protocol": {"episodes": 13}, "data": {"dam/mef": "b" * 64}, "trainer": {"torch": "2.14.0"}}
    assert fingerprints.changes(recorded, installed) == ["data.dam/mef changed", "trainer.torch: '2.13.0' -> '2.14.0'"]
    assert fingerprints.changes(recorded, recorded) == []
    assert fingerprints.changes(None, installed) == ["no fingerprints recorded"]


def test_a_data_file_found_nowhere_here_is_named_missing_not_changed() -> None:
    rows = [{"name": "microgrid/demand/train", "sha256": "86d0" * 16, "found": "no"}]  # nor a stand-in here
    installed = {"data": fingerprints.data_fingerprint(rows)}
    recorded = {"data": {"microgrid/demand/train": "29e7" * 16}}  # the stand-in the run read
    assert fingerprints._differences(recorded["data"], installed["data"], "data") == [
        "data.microgrid/demand/train: not found here"
    ]


def test_the_committed_sections_verification_sentences_read_as_words() -> None:
    """Issue 45: "the SHA-256 of the 0 data files" and "rerun by ba1df74-dirty" were printed on the page."""
    for report in sorted(RESULTS.glob("*/report.json")):
        for part, sentence in json.loads(report.read_text()).get("fingerprints_verified", {}).items():
            assert "-dirty" not in sentence, (report.parent.name, part)
            assert " of the 0 data files" not in sentence, (report.parent.name, part)


def test_a_section_names_the_commits_that_trained_its_runs_apart_from_its_test_phase() -> None:
    """A section tested again at a later commit (its runs reused) says where its runs were trained, not the test's."""
    from gym4real.results.section_provenance import code_versions

    runs = pd.DataFrame(
        {"algo": ["ppo", "ppo", "dqn"], "seed": [0, 1, 0], "trained_by": ["aaa1111", "bbb2222", "aaa1111"]}
    )
    assert code_versions(runs, "ccc3333") == "Trained at code versions `aaa1111`, `bbb2222` (test phase at `ccc3333`)"
    assert code_versions(runs.iloc[[0, 2]], "aaa1111") == "Trained at code version `aaa1111`"
    assert code_versions(None, "ccc3333") == "Trained at code version `ccc3333`"
    unknown = pd.DataFrame({"algo": ["ppo"], "seed": [0], "trained_by": [NOT_RECORDED]})
    assert code_versions(unknown, "ccc3333") == "Trained at code version `ccc3333`"
    assert code_versions(runs.drop(columns="trained_by"), "ccc3333") == "Trained at code version `ccc3333`"
