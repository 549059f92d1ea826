"""`gym4real reproduce`: the whole pipeline on a cheap environment, reuse of finished runs, unrunnable envs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.bench.benchmark import BenchmarkResult
from gym4real.bench.seeds import presets, seeds
from gym4real.results.plan import plan
from gym4real.results.reproduce import pooled, reproduce

VERDICTS = {"holds", "refuted", "inconclusive"}


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    # only the trading plugin: `--all` then means one environment
    env = {**os.environ, "GYM4REAL_DISABLE_PLUGINS": "dam,elevator,microgrid,robofeeder,wds"}
    return subprocess.run(
        [sys.executable, "-m", "gym4real.cli", "reproduce", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


@pytest.mark.slow
def test_reproduce_all_quick_writes_the_page_and_reuses_finished_runs(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    out, page = tmp_path / "out", tmp_path / "docs"
    args = ("--all", "--budget", "quick", "--seeds", "1", "--out", str(out), "--page", str(page), "--quiet")
    first = _cli(*args)
    assert first.returncode == 0, first.stderr
    folder = out / "trading-v0-quick"
    runs = sorted((out / "trading-v0" / "quick").glob("runs/*/seed*/run.json"))
    assert [p.parent.parent.name for p in runs] == ["dqn", "ppo"]
    claims = json.loads((out / "claims.json").read_text())
    assert len(claims) == 4 and {c["verdict"] for c in claims} <= VERDICTS
    for claim in claims:
        assert claim["budget"] == "quick" and claim["rule"]
        for comp in claim["comparisons"]:
            assert comp["low"] <= comp["estimate"] <= comp["high"] and comp["rule"]
    summary = pd.read_csv(folder / "summary.csv").set_index("policy")
    assert summary.loc[["dqn", "ppo"], "seeds"].tolist() == [1, 1] and summary["episodes"].nunique() == 1
    episodes = pd.read_csv(folder / "episodes.csv")
    assert list(episodes.columns[:5]) == ["policy", "seed", "episode", "objective", "return"]
    assert {"pnl", "fees"} <= set(episodes.columns) and episodes.loc[episodes["policy"] == "flat", "seed"].isna().all()
    assert np.allclose(episodes["objective"], episodes["pnl"] + episodes["fees"])
    runs_csv = pd.read_csv(folder / "runs.csv")
    assert runs_csv["algo"].tolist() == ["dqn", "ppo"] and (runs_csv["env_steps"] > 0).all()
    assert json.loads(runs_csv["settings"][0])["algo"] == "dqn"
    manifest = json.loads((page / "manifest.json").read_text())
    assert manifest["sections"] == {"trading-v0-quick": manifest["code_version"]} and "numpy" in manifest["versions"]
    text = (page / "index.md").read_text()
    assert "`gym4real/trading-v0`, budget `quick`: pipeline check, not a verdict" in text
    assert str(tmp_path) not in text  # no machine path: the command shows OUT
    for link in ("cumulative_reward.png", "returns_boxplot.png", "learning_curves.png", "performance_profile.png"):
        assert f"](trading-v0-quick/{link})" in text
        assert (page / "trading-v0-quick" / link).read_bytes()[:4] == b"\x89PNG"
    curves = pd.read_csv(folder / "learning_curves.csv")
    assert set(curves["algo"]) == {"dqn", "ppo"} and (curves["low"] <= curves["high"]).all()

    stamps = [p.stat().st_mtime_ns for p in runs]
    second = _cli(*args)
    assert second.returncode == 0, second.stderr
    assert [p.stat().st_mtime_ns for p in runs] == stamps  # finished runs are reused, not trained again
    assert json.loads((out / "claims.json").read_text()) == claims


def test_an_env_that_cannot_run_is_reported_and_named_on_the_page(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if "gym4real/microgrid-v0" not in gym4real.list_envs():
        pytest.skip("microgrid not installed")
    # a user cache without the synthetic training households (this machine's may hold them): nothing to train on
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "empty-cache"))
    text = reproduce(["gym4real/microgrid-v0"], budget="paper", out=tmp_path / "out")
    error = (tmp_path / "out" / "microgrid-v0-paper" / "error.txt").read_text()
    assert "not run" in text and "demand/train" in error
    page = (tmp_path / "out" / "results.md").read_text()
    assert "`gym4real/microgrid-v0`, budget `paper`: not run" in page
    assert "gym4real reproduce gym4real/microgrid-v0 --budget paper" in page
    assert str(tmp_path) not in page and not list((tmp_path / "out" / "microgrid-v0-paper").glob("*.png"))


def test_the_plan_uses_the_papers_seeds_and_stand_in_presets(tmp_path: Path) -> None:
    assert seeds("gym4real/dam-v0", "paper") == [123, 0, 1, 2, 3]  # the paper's one seed, topped up to five
    assert seeds("gym4real/dam-v0", "quick") == [123]
    assert seeds("gym4real/elevator-v0", "paper", 3) == [42, 0, 1]
    assert seeds("gym4real/trading-v0", "paper") == [32517, 84029, 10473, 67288, 91352, 47605]
    assert seeds("gym4real/trading-v0", "quick") == [32517, 84029]
    assert presets("gym4real/trading-v0", "paper") == {"dqn": "hourly", "ppo": "hourly"}
    assert presets("gym4real/elevator-v0", "quick") == {"qlearning": "smoke", "sarsa": "smoke"}
    items = plan("gym4real/elevator-v0", "paper", 1, tmp_path)
    assert [(i.algo, i.seed) for i in items] == [("qlearning", 42), ("sarsa", 42)]
    assert items[0].folder == tmp_path / "elevator-v0" / "paper" / "runs" / "qlearning" / "seed42"


def test_the_commands_of_the_published_page_train_its_seeds() -> None:
    sections = sorted((Path(__file__).parents[1] / "docs" / "results").glob("*-paper/report.json"))
    assert len(sections) == 8
    for path in sections:
        report = json.loads(path.read_text())
        n = int(report["command"].split("--seeds ")[1].split()[0])
        assert sorted(seeds(report["env_id"], "paper", n)) == report["seeds"], path.parent.name
        assert sorted(seeds(report["env_id"], "paper")) == report["seeds"], path.parent.name  # the full plan


def test_pooling_an_algorithms_seeds_keeps_the_results_step_unit_and_objective() -> None:
    result = BenchmarkResult(
        "gym4real/dam-v0",
        [{"seed": 0}, {"seed": 1}],
        returns={"max": [1.0, 2.0], "ppo:a": [3.0, 4.0], "ppo:b": [5.0, 6.0]},
        components={p: {"deficit": [-1.0, -2.0]} for p in ("max", "ppo:a", "ppo:b")},
        rewards={p: [np.zeros(2), np.ones(2)] for p in ("max", "ppo:a", "ppo:b")},
        final_info={p: {} for p in ("max", "ppo:a", "ppo:b")},
        objective=("deficit",),
        step_unit="day",  # the figures' x label; a pooled copy without it labelled them "step"
    )
    out = pooled(result, {"max": ["max"], "ppo": ["ppo:a", "ppo:b"]})
    assert (out.step_unit, out.objective) == ("day", ("deficit",))
    assert out.returns == {"max": [1.0, 2.0], "ppo": [3.0, 4.0, 5.0, 6.0]}
    assert out.components["ppo"] == {"deficit": [-1.0, -2.0, -1.0, -2.0]} and len(out.rewards["ppo"]) == 4
    assert len(out.episodes) == 4


def test_the_learning_curve_band_stops_where_fewer_than_two_seeds_remain(tmp_path: Path) -> None:
    from gym4real.results.reproduce import _curves
    from gym4real.rl.train import TrainingRun

    runs = []
    for seed, length in ((0, 4), (1, 2)):  # seed 1 stopped early
        folder = tmp_path / f"seed{seed}"
        folder.mkdir()
        values = np.arange(length, dtype=float) * (seed + 1)
        pd.DataFrame(
            {"episodes": 1000 * (np.arange(length) + 1), "mean_return": values, "ci95_low": values, "ci95_high": values}
        ).to_csv(folder / "curve.csv", index=False)
        runs.append(
            TrainingRun(
                "gym4real/elevator-v0", "qlearning", "paper", seed, folder / "q.npz", folder / "curve.csv", 1.0, 1, 1
            )
        )
    _curves(runs, tmp_path)
    curve = pd.read_csv(tmp_path / "learning_curves.csv")
    assert curve["seeds"].tolist() == [2, 2, 1, 1]
    two = curve[curve["seeds"] == 2]
    assert (two["low"] <= two["mean"]).all() and (two["mean"] <= two["high"]).all()
    assert two["mean"].tolist() == [0.0, 1.5]
    assert curve.loc[curve["seeds"] == 1, ["mean", "low", "high"]].isna().all().all()  # no one-seed "band"
    assert (tmp_path / "learning_curves.png").read_bytes()[:4] == b"\x89PNG"


def test_an_unknown_id_or_no_seed_is_refused_before_anything_runs(tmp_path: Path) -> None:
    from gym4real.core.errors import EnvUnavailableError

    with pytest.raises(EnvUnavailableError, match="Did you mean `gym4real/trading-v0`"):
        reproduce(["gym4real/trading-v0", "gym4real/trading-v9"], budget="quick", out=tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing trained, no page
    for args in (["gym4real/trading-v9", "--plan"], ["gym4real/trading-v9"]):
        done = _cli(*args, "--out", str(tmp_path / "cli"))
        assert done.returncode == 2 and "unknown environment `gym4real/trading-v9`" in done.stderr, done.stderr
    for args in (["gym4real/trading-v0", "--seeds", "0", "--plan"], ["gym4real/trading-v0", "--seeds", "0"]):
        done = _cli(*args, "--out", str(tmp_path / "cli"))
        assert done.returncode == 2 and "must be at least 1" in done.stderr, done.stderr
        assert "for the one seed 0 write `--seeds 0,`" in done.stderr, done.stderr
    assert not (tmp_path / "cli").exists()


def test_seeds_is_a_count_or_a_list_of_seeds_in_reproduce_as_in_evaluate(tmp_path: Path) -> None:
    """`--seeds N`: the plan's first N seeds; `--seeds a,b,c`: these (one: `S,`); anything else is refused."""
    from gym4real.bench.seeds import parse_seeds
    from gym4real.core.errors import ConfigError

    assert parse_seeds("3") == 3 and parse_seeds("0,7") == [0, 7] and parse_seeds("7,") == [7]
    for bad in ("", "x", "0,,1", "1.5", "-1,"):
        with pytest.raises(ConfigError, match="neither a number of seeds"):
            parse_seeds(bad)
    assert seeds("gym4real/trading-v0", "paper", [0, 7]) == [0, 7]
    algos = presets("gym4real/trading-v0", "quick")
    assert [i.seed for i in plan("gym4real/trading-v0", "quick", [7], tmp_path)] == [7] * len(algos)

    def planned(*args: str) -> list[tuple[str, str]]:
        done = _cli("gym4real/trading-v0", *args, "--plan", "--out", str(tmp_path))
        assert done.returncode == 0, done.stderr
        return sorted((r.split()[1], r.split()[3]) for r in done.stdout.splitlines() if r.startswith("trading-v0 "))

    assert planned("--budget", "quick", "--seeds", "0,7") == sorted(
        (f"{algo}/{preset}", s) for algo, preset in algos.items() for s in ("0", "7")
    )
    assert {s for _, s in planned("--seeds", "2")} == {"32517", "84029"}  # a count: the paper's first two
    done = _cli("gym4real/trading-v0", "--seeds", "0,0", "--plan", "--out", str(tmp_path))
    assert done.returncode == 2 and "none twice" in done.stderr, done.stderr


def test_all_means_the_envs_with_a_paper_comparison(tmp_path: Path) -> None:
    env = {**os.environ, "GYM4REAL_DISABLE_PLUGINS": "elevator,microgrid,robofeeder,trading,wds"}
    done = subprocess.run(
        [sys.executable, "-m", "gym4real.cli", "reproduce", "--all", "--plan", "--out", str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "dam-v0 ppo/paper" in done.stdout and "dam-mo-v0" not in done.stdout  # the -mo id trains nothing


def test_the_test_phase_runs_the_baselines_a_claim_names_beside_the_protocols_and_the_upper_references() -> None:
    from gym4real.results.reproduce import tested_baselines

    # dam's own check "PPO beats MPC" names `mpc`, outside the protocol's baselines
    assert tested_baselines("gym4real/dam-v0") == ["random", "mean", "max", "ead", "historical", "mpc", "hindsight"]
    assert tested_baselines("gym4real/wds-v0") == ["random", "p78", "p79", "default", "mpc", "hindsight"]
    assert tested_baselines("gym4real/trading-v0")[-1] == "hindsight" and "mpc" not in tested_baselines(
        "gym4real/trading-v0"
    )
