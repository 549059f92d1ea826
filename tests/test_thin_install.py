"""The thin install (issue 45): core and one domain, without what only measurement, training and publishing need.

In a fresh venv, ``pip install ./packages/gym4real-core ./packages/gym4real-wds`` (from PyPI, as a user would)
installs at most :data:`MOST` distributions, none of them matplotlib, scipy or tqdm (core's ``bench`` extra);
``gym4real list``, ``gym4real info`` and ``gymnasium.make`` work there, and a command that measures names the
extra to install.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The most distributions the thin install of core and wds may bring (38 with matplotlib, scipy and tqdm in core).
MOST = 28
#: What only the harness needs: core's `bench` extra, and the libraries matplotlib brings.
HARNESS = {"matplotlib", "scipy", "tqdm", "contourpy", "cycler", "fonttools", "kiwisolver", "pyparsing"}


def _run(*args: str | Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=900, env=env, check=False)


@pytest.mark.slow
def test_core_and_wds_install_thin_and_list_info_and_make_work(tmp_path: Path) -> None:
    where = tmp_path / "venv"
    venv.create(where, with_pip=True)
    python, gym4real = where / "bin" / "python", where / "bin" / "gym4real"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "PYTHON"))}
    report = tmp_path / "report.json"
    packages = ROOT / "packages"
    done = _run(
        python,
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
        "--report",
        report,
        packages / "gym4real-core",
        packages / "gym4real-wds",
        env=env,
    )
    assert done.returncode == 0, done.stderr
    installed = sorted(item["metadata"]["name"].lower() for item in json.loads(report.read_text())["install"])
    assert len(installed) <= MOST, installed
    assert not set(installed) & HARNESS, installed
    assert {"gym4real-core", "gym4real-wds", "pillow"} <= set(installed)  # pillow: the envs' frames

    listed = _run(gym4real, "list", env=env)
    assert listed.returncode == 0, listed.stderr
    rows = {line.split()[0]: line for line in listed.stdout.splitlines()}
    assert sorted(rows) == ["gym4real/wds-mo-v0", "gym4real/wds-v0"] and "unavailable" not in listed.stdout
    for env_id in ("gym4real/wds-v0", "gym4real/wds-mo-v0"):
        info = _run(gym4real, "info", env_id, env=env)
        assert info.returncode == 0, info.stderr
        assert "observation" in info.stdout and "could not be made" not in info.stdout, info.stdout
    code = (
        "import sys, gymnasium as gym, gym4real\n"
        "env = gym.make('gym4real/wds-v0')\n"
        "env.reset(seed=0)\n"
        "obs, reward, *_ = env.step(env.action_space.sample())\n"
        "frame = gym.make('gym4real/wds-v0', render_mode='rgb_array')\n"
        "frame.reset(seed=0)\n"
        "assert frame.render().ndim == 3\n"
        "assert not {'matplotlib', 'scipy', 'tqdm'} & set(sys.modules)\n"
        "print(float(reward))\n"
    )
    made = _run(python, "-c", code, env=env)
    assert made.returncode == 0, made.stderr

    measured = _run(gym4real, "bench", "gym4real/wds-v0", "--episodes", "1", "--out", tmp_path / "out", env=env)
    assert measured.returncode == 2
    err = measured.stderr.strip()
    assert (
        err.startswith("gym4real: error: `gym4real bench` needs the `bench` extra of gym4real-core (")
        and "\n" not in err
    )
    assert f'pip install "{packages / "gym4real-core"}[bench]"' in err, err  # core came from this checkout
    assert not (tmp_path / "out").exists()
    api = _run(python, "-c", "import gym4real; gym4real.evaluate", env=env)
    assert "gym4real.core.errors.MissingDependencyError: `gym4real.evaluate` needs the `bench` extra" in api.stderr


def test_the_harness_libraries_are_an_extra_of_core_not_its_dependencies() -> None:
    import tomllib

    project = tomllib.loads((ROOT / "packages" / "gym4real-core" / "pyproject.toml").read_text())["project"]
    names = {dep.split(">")[0].split("=")[0].split("<")[0].strip().lower() for dep in project["dependencies"]}
    assert not names & {"matplotlib", "scipy", "tqdm"}
    assert {dep.split(">")[0] for dep in project["optional-dependencies"]["bench"]} == {"matplotlib", "scipy", "tqdm"}
    assert "gym4real-core[bench]" in project["optional-dependencies"]["rl"]  # training draws its learning curves


#: A fresh interpreter where the `bench` extra's libraries cannot be imported (as in a thin install).
WITHOUT_BENCH = "import sys\nfor name in ('matplotlib', 'scipy', 'tqdm'):\n    sys.modules[name] = None\n"


@pytest.mark.parametrize(
    "argv",
    [
        ["list"],
        ["info", "gym4real/dam-mo-v0"],
        ["record", "gym4real/elevator-v0", "--policy", "random", "--max-steps", "5", "--no-mp4", "--out", "videos"],
    ],
)
def test_list_info_and_record_need_no_library_of_the_bench_extra(argv: list[str], tmp_path: Path) -> None:
    code = WITHOUT_BENCH + f"from gym4real.cli import main\nraise SystemExit(main({argv!r}))"
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=tmp_path, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "could not be made" not in done.stdout and "bench" not in done.stderr


def test_a_command_that_measures_without_the_bench_extra_names_it(tmp_path: Path) -> None:
    argv = ["bench", "gym4real/elevator-v0", "--episodes", "1", "--quiet", "--out", "out"]
    code = WITHOUT_BENCH + f"from gym4real.cli import main\nraise SystemExit(main({argv!r}))"
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=tmp_path, check=False
    )
    err = done.stderr.strip()
    assert done.returncode == 2 and "\n" not in err, err
    # the installed metadata holds the extra here, so the first import of one of its libraries is what names it
    missing = re.search(r"needs the `bench` extra of gym4real-core \((\w+) not installed\)", err)
    assert err.startswith("gym4real: error: `") and missing and missing.group(1) in {"scipy", "matplotlib", "tqdm"}
    assert "[bench]" in err and "pip install" in err
