"""Each domain wheel holds only its own folder; core + elevator alone list only the elevator."""

from __future__ import annotations

import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = sorted(p.parent for p in (ROOT / "packages").glob("*/pyproject.toml"))


@pytest.fixture(scope="module")
def wheels(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    pytest.importorskip("hatchling")
    out = tmp_path_factory.mktemp("wheels")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(out),
            *map(str, PACKAGES),
        ],
        check=True,
    )
    return {w.name.split("-")[0].replace("_", "-"): w for w in out.glob("*.whl")}


def _modules(wheel: Path) -> set[str]:
    with zipfile.ZipFile(wheel) as zf:
        return {n for n in zf.namelist() if not n.split("/")[0].endswith(".dist-info")}


def test_every_distribution_builds(wheels: dict[str, Path]) -> None:
    assert sorted(wheels) == sorted(p.name for p in PACKAGES)


def test_every_wheel_carries_the_licence(wheels: dict[str, Path]) -> None:
    for dist, wheel in wheels.items():
        with zipfile.ZipFile(wheel) as zf:
            licences = [n for n in zf.namelist() if n.endswith(".dist-info/licenses/LICENSE")]
            assert licences, dist
            assert "Apache License" in zf.read(licences[0]).decode()


def test_domain_wheels_hold_only_their_folder(wheels: dict[str, Path]) -> None:
    for dist, wheel in wheels.items():
        files = _modules(wheel)
        if dist == "gym4real-core":
            assert "gym4real/__init__.py" in files
            assert all(
                f.startswith(
                    (
                        "gym4real/core/",
                        "gym4real/bench/",
                        "gym4real/rl/",
                        "gym4real/results/",
                        "gym4real/cli/",
                        "gym4real/offline/",
                        "gym4real/wrappers/",
                        "gym4real/integrations/",
                        "gym4real/__init__.py",
                        "gym4real/py.typed",
                    )
                )
                for f in files
            )
        else:
            domain = dist.removeprefix("gym4real-")
            assert files and all(f.startswith(f"gym4real/{domain}/") for f in files), (dist, files)
            assert f"gym4real/{domain}/py.typed" in files


@pytest.mark.slow
def test_core_and_elevator_alone_list_only_the_elevator(wheels: dict[str, Path], tmp_path: Path) -> None:
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    python = env_dir / "bin" / "python"
    subprocess.run(
        [
            str(python),
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            str(wheels["gym4real-core"]),
            str(wheels["gym4real-elevator"]),
        ],
        check=True,
    )
    code = (
        "import gym4real, json\n"
        "ids = gym4real.list_envs()\n"
        "try:\n    gym4real.make('gym4real/wds-v0'); hint = ''\n"
        "except gym4real.core.EnvUnavailableError as e:\n    hint = str(e)\n"
        "print(json.dumps([ids, hint]))\n"
    )
    out = subprocess.run([str(python), "-c", code], capture_output=True, text=True, check=True)
    ids, hint = __import__("json").loads(out.stdout.strip().splitlines()[-1])
    assert ids == ["gym4real/elevator-v0"]
    assert "pip install gym4real-wds" in hint
