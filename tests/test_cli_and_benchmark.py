"""The CLI and the benchmark harness, end to end on the elevator."""

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
from gym4real.cli import main
from gym4real.core.errors import EnvUnavailableError, PolicyError
from gym4real.core.registry import registry


def test_unknown_id_suggests_the_nearest() -> None:
    with pytest.raises(EnvUnavailableError, match="Did you mean `gym4real/elevator-v0`"):
        gym4real.make("gym4real/elevatr-v0")


def test_not_installed_domain_gives_the_pip_install_from_this_checkout(monkeypatch: pytest.MonkeyPatch) -> None:
    reg = registry()
    monkeypatch.setattr(reg, "distributions", {k: v for k, v in reg.distributions.items() if k != "dam"})
    monkeypatch.setattr(reg, "envs", {k: v for k, v in reg.envs.items() if not k.startswith("gym4real/dam")})
    dam = Path(__file__).resolve().parents[1] / "packages" / "gym4real-dam"
    with pytest.raises(EnvUnavailableError) as err:  # this venv has core editable from this checkout
        gym4real.make("gym4real/dam-v0")
    assert f"`pip install -e {dam}`" in str(err.value)


def test_a_core_not_from_a_checkout_gives_both_install_forms(monkeypatch: pytest.MonkeyPatch) -> None:
    from gym4real.core import install_hint

    monkeypatch.setattr(install_hint, "_core_checkout", lambda: None)
    hint = install_hint.install_command("gym4real-dam")
    assert "`pip install ./packages/gym4real-dam` from a gym4real checkout" in hint
    assert "`pip install gym4real-dam` once it is on PyPI" in hint


def test_benchmark_with_callable_and_baseline(tmp_path: Path) -> None:
    always_open = lambda obs: 1  # noqa: E731
    result = gym4real.benchmark("gym4real/elevator-v0", ["longest_first", always_open], episodes=2, out=tmp_path)
    assert set(result.returns) == {"longest_first", "<lambda>"}
    assert all(len(v) == 2 for v in result.returns.values())
    for name in ("episodes.csv", "summary.csv", "results.json", "cumulative_reward.png", "returns_boxplot.png"):
        assert (tmp_path / name).stat().st_size > 0
    summary = pd.read_csv(tmp_path / "summary.csv", index_col="policy")
    # the elevator's protocol names no objective: its score is the return
    assert summary.loc["longest_first", "objective_mean"] == pytest.approx(np.mean(result.returns["longest_first"]))
    record = json.loads((tmp_path / "results.json").read_text())
    assert record["returns"]["longest_first"] == result.returns["longest_first"]
    lo, hi = summary.loc["longest_first", ["objective_low", "objective_high"]]
    assert lo <= summary.loc["longest_first", "objective_iqm"] <= hi


def test_benchmark_is_reproducible() -> None:
    a = gym4real.benchmark("gym4real/elevator-v0", ["random"], episodes=2, seed=5)
    b = gym4real.benchmark("gym4real/elevator-v0", ["random"], episodes=2, seed=5)
    assert a.returns == b.returns


def test_unknown_policy_is_a_clear_error() -> None:
    with pytest.raises(PolicyError, match="longest_first"):
        gym4real.benchmark("gym4real/elevator-v0", ["longest"], episodes=1)


def test_cli_list_info_and_one_line_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    assert "gym4real/elevator-v0" in capsys.readouterr().out
    assert main(["bench", "gym4real/elevatr-v0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gym4real: error:") and "\n" not in err and "Traceback" not in err


def test_cli_bench_writes_table_and_figures(tmp_path: Path) -> None:
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "gym4real.cli",
            "bench",
            "gym4real/elevator-v0",
            "--episodes",
            "2",
            "--policies",
            "longest_first,shortest_first",
            "--out",
            str(tmp_path),
            "--quiet",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "longest_first" in out.stdout and "iqm" in out.stdout
    assert (tmp_path / "returns_boxplot.png").exists()


def test_cli_data_list_and_verify(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if not registry().datasets:
        pytest.skip("no installed domain registers data")
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path))  # a stand-in in the user's cache would be listed
    assert main(["data", "list"]) == 0
    absent = _absent()
    listed = capsys.readouterr().out.splitlines()
    assert listed[0].split() == ["name", "size", "status", "found", "in"]
    stand_ins = [s for s in registry().datasets.values() if s.stand_in_for]
    # header, rows, a line per stand-in, searched, summary, fix
    assert len(listed) == 1 + len(registry().datasets) + len(stand_ins) + 2 + bool(absent)
    for spec in stand_ins:
        assert f"{spec.name} is a stand-in for {spec.stand_in_for}" in listed
    assert main(["data", "verify"]) == (2 if absent else 0)
    out, err = capsys.readouterr()
    rows = out.splitlines()[1 : 1 + len(registry().datasets)]
    assert sum(" ok " in r for r in rows) == len(registry().datasets) - absent
    assert sum(" missing " in r for r in rows) == absent
    assert (f"{absent} missing" in err) if absent else err == ""


def test_a_missing_data_file_is_reported_before_any_progress_bar_is_drawn(tmp_path: Path) -> None:
    if "gym4real/dam-v0" not in gym4real.list_envs():
        pytest.skip("gym4real-dam is not installed")
    env = {k: v for k, v in os.environ.items() if k != "GYM4REAL_DATA_DIR"}
    env |= {"GYM4REAL_CACHE_DIR": str(tmp_path), "GYM4REAL_OFFLINE": "1"}
    cmd = [sys.executable, "-m", "gym4real.cli", "bench", "gym4real/dam-v0", "--episodes", "1"]
    run = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    assert run.returncode == 2
    assert "episode/s]" not in run.stderr  # no progress bar drawn before the error
    [error] = [line for line in run.stderr.splitlines() if "gym4real: error:" in line]
    assert error.startswith("gym4real: error: data file `dam/"), run.stderr
    assert "GYM4REAL_DATA_DIR (not set)" in error and "github.com/Daveonwave/gym4ReaL at commit 774d5ce" in error


def _absent() -> int:
    from gym4real.core import datasets

    missing = 0
    for name in registry().datasets:
        try:
            datasets.resolve(name, download=False)
        except gym4real.core.DataFileError:
            missing += 1
    return missing


def test_every_cli_argument_has_help_and_algo_lists_its_choices() -> None:
    import argparse

    from gym4real.cli import _parser
    from gym4real.rl.presets import ALGOS

    def parsers(parser: argparse.ArgumentParser, path: str) -> list[tuple[str, argparse.ArgumentParser]]:
        found = [(path, parser)]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                helps = {a.dest: a.help for a in action._choices_actions}
                for name, child in action.choices.items():
                    assert helps.get(name), f"`{path} {name}` has no help line"
                    found += parsers(child, f"{path} {name}")
        return found

    for path, parser in parsers(_parser(), "gym4real"):
        for action in parser._actions:
            if not isinstance(action, argparse._SubParsersAction):
                assert action.help, f"`{path}` argument {action.dest} has no help text"
    train = dict(parsers(_parser(), "gym4real"))["gym4real train"]
    algo = next(a for a in train._actions if a.dest == "algo")
    assert tuple(algo.choices) == ALGOS and all(name in algo.help for name in ALGOS)


def test_cli_info_is_a_readable_summary_and_json_on_request(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "gym4real/elevator-v0"]) == 0
    lines = capsys.readouterr().out.splitlines()
    fields = {line.split()[0]: line for line in lines[1:] if not line.startswith(" ")}
    assert lines[0].startswith("gym4real/elevator-v0: ")
    assert fields["action"].split()[1] == "Discrete(3)"  # the elevator's three actions: up, down, stay
    assert "(3600) steps" in fields["episode"]  # episode end: the default duration
    assert "default, test" in fields["presets"] and "longest_first" in fields["baselines"]
    assert "one step = one second" in " ".join(lines)
    assert main(["info", "gym4real/elevator-v0", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["interface"]["action_space"] == "Discrete(3)"
    assert record["flags"]["provably_efficient"] is True


def test_cli_info_text_has_no_rest_double_backticks(capsys: pytest.CaptureFixture[str]) -> None:
    """The docstring's ``sim_horizon`` reads as sim_horizon in a terminal; --json keeps the docstring's text."""
    assert main(["info", "gym4real/dam-v0", "--json"]) == 0
    episode_end = json.loads(capsys.readouterr().out)["interface"]["episode_end"]
    assert "``sim_horizon``" in episode_end
    assert main(["info", "gym4real/dam-v0"]) == 0
    text = capsys.readouterr().out
    assert "``" not in text
    assert " ".join(episode_end.replace("``", "").split()) in " ".join(text.split())


def test_info_of_a_box_with_infinite_bounds_says_them_without_a_numpy_warning() -> None:
    """trading-v0's observation bounds are infinite: their range was inf - inf (a RuntimeWarning on the terminal)."""
    import warnings

    import gymnasium as gym

    from gym4real.core.info import space_text

    inf = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert space_text(gym.spaces.Box(-inf, inf, (8,), np.float64)) == "Box(-inf..inf, (8,), float64)"
        mixed = gym.spaces.Box(np.array([-inf] * 7 + [0.0]), np.full(8, inf), dtype=np.float64)
        assert space_text(mixed) == "Box(-inf..inf, (8,), float64; bounds vary by entry)"
        done = subprocess.run(
            [sys.executable, "-W", "error::RuntimeWarning", "-m", "gym4real.cli", "info", "gym4real/trading-v0"],
            capture_output=True,
            text=True,
            check=False,
        )
    assert done.returncode == 0 and "Warning" not in done.stderr, done.stderr


def test_a_reader_that_goes_away_is_not_an_error() -> None:
    """`gym4real list | head`: the closed pipe ends the command quietly, with no error line."""
    child = subprocess.Popen(
        [sys.executable, "-m", "gym4real.cli", "list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    assert child.stdout is not None and child.stderr is not None
    child.stdout.close()  # before the child has imported anything, so its first write finds the pipe closed
    err = child.stderr.read().decode()
    assert child.wait(timeout=120) == 0
    assert "Broken pipe" not in err and "error" not in err
