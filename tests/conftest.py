"""Root tests: cross-package checks. Data come from ../shared/data unless GYM4REAL_DATA_DIR is set."""

from __future__ import annotations

import importlib
import importlib.util
import os
import shlex
import sys
import textwrap
from collections.abc import Callable, Iterator, Sequence
from importlib import metadata as importlib_metadata
from pathlib import Path
from types import ModuleType
from typing import Any

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("GYM4REAL_DATA_DIR", str(ROOT.parent / "shared" / "data"))
os.environ.setdefault("GYM4REAL_OFFLINE", "1")
os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(scope="session")
def load_script() -> Callable[[Path], ModuleType]:
    """``load_script(path)``: import a Python file that is in no package (a script, a docs helper) as a module."""

    def load(path: Path) -> ModuleType:
        spec = importlib.util.spec_from_file_location(f"script_{path.stem}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module  # dataclasses of the script look their module up
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture
def data_without_training_households(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A data folder with every data file here but microgrid's training households (the real file and the
    synthetic stand-in), and an empty user cache: microgrid's published section cannot be checked."""
    from gym4real.core.datasets import dataset
    from gym4real.microgrid.data import STAND_IN

    source = Path(os.environ["GYM4REAL_DATA_DIR"])
    left_out = {STAND_IN, dataset("microgrid/demand/train").path}
    target = tmp_path / "data"
    for path in source.rglob("*"):
        relative = path.relative_to(source).as_posix()
        if path.is_file() and relative not in left_out:
            (target / relative).parent.mkdir(parents=True, exist_ok=True)
            (target / relative).symlink_to(path)
    monkeypatch.setenv("GYM4REAL_DATA_DIR", str(target))
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    return target


CARTPOLE = "gymnasium.envs.classic_control.cartpole:CartPoleEnv"


def _plugin_source(
    env_ids: Sequence[str], *, declaration: str | None = None, entry_point: str = CARTPOLE, body: str = ""
) -> str:
    from gym4real.core import PLUGIN_API_VERSION

    specs = ", ".join(f'EnvSpec(id="{i}", entry_point="{entry_point}", description="fake")' for i in env_ids)
    return (
        "from gym4real.core.hookspecs import hookimpl\n"
        "from gym4real.core.specs import EnvSpec\n"
        f"{f'plugin_api = {PLUGIN_API_VERSION!r}' if declaration is None else declaration}\n"
        "@hookimpl\n"
        "def gym4real_register_envs():\n"
        f"    return [{specs}]\n" + body
    )


@pytest.fixture(scope="session")
def plugin_source() -> Callable[..., str]:
    """``plugin_source(env_ids, declaration=, entry_point=, body=)``: source of a plugin module for
    :func:`fake_plugins`: ``declaration`` (default: the current ``plugin_api``; ``""`` declares none), a
    hook registering ``env_ids`` (each made by ``entry_point``, CartPole by default), then ``body``."""
    return _plugin_source


@pytest.fixture
def listed_evaluate(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Callable[[dict[str, Any], Path], pd.DataFrame]:
    """``listed_evaluate(model, page)``: run the ``gym4real evaluate`` command that ``models.json`` lists for a
    published ``model``, as written, in the ``page`` folder (with ``--out`` in tmp_path); its agent's episodes."""
    from gym4real.cli import main

    def run(model: dict[str, Any], page: Path) -> pd.DataFrame:
        command, where = model["evaluate"].split(" (")
        assert where == "in the page folder)"
        argv = shlex.split(command)
        assert argv[:2] == ["gym4real", "evaluate"]
        out = tmp_path / f"evaluate-{model['algo']}-seed{model['seed']}"
        monkeypatch.chdir(page)
        assert main([*argv[1:], "--out", str(out)]) == 0
        return pd.read_csv(out / "agent_episodes.csv")

    return run


class FakeDistribution(importlib_metadata.Distribution):
    """An installed distribution held in memory: a name, a version, ``gym4real.plugins`` entry points and the
    requirements it declares."""

    def __init__(self, name: str, version: str, entry_points: dict[str, str], requires: Sequence[str] = ()) -> None:
        declared = "".join(f"Requires-Dist: {r}\n" for r in requires)
        self._files = {
            "METADATA": f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n{declared}",
            "entry_points.txt": "[gym4real.plugins]\n" + "".join(f"{k} = {v}\n" for k, v in entry_points.items()),
        }

    def read_text(self, filename: str) -> str | None:
        return self._files.get(filename)

    def locate_file(self, path: str | os.PathLike[str]) -> Path:
        return Path(path)


@pytest.fixture
def fake_plugins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[..., object]]:
    """Rediscover the plugins with fake distributions beside (or instead of) the installed ones.

    ``fake_plugins((dist, version, {entry_point_name: module}[, requires]), ..., modules={module: source},
    first=True, real=True)`` writes each module under a temporary folder on ``sys.path``, lists the fake
    distributions' entry points before (``first``) or after the installed ones (none of those if ``real`` is
    false) and returns the new registry. Non-strict mode; the installed
    registry, ``sys.modules`` and Gymnasium's registry are restored afterwards.
    """
    import gymnasium

    from gym4real.core import registry as reg_mod

    installed = list(reg_mod._entry_points())
    gym_ids = set(gymnasium.registry)
    written: list[str] = []
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv("GYM4REAL_STRICT_PLUGINS", raising=False)

    def install(
        *dists: tuple[Any, ...],
        modules: dict[str, str] | None = None,
        first: bool = True,
        real: bool = True,
    ) -> reg_mod.Registry:
        for name, source in (modules or {}).items():
            path = tmp_path.joinpath(*name.split(".")).with_suffix(".py")
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(textwrap.dedent(source))
            written.append(name)
        importlib.invalidate_caches()
        fake = [ep for d in dists for ep in FakeDistribution(*d).entry_points.select(group=reg_mod.ENTRY_POINT_GROUP)]
        others = installed if real else []
        eps = [*fake, *others] if first else [*others, *fake]
        monkeypatch.setattr(reg_mod, "_entry_points", lambda: eps)
        return reg_mod.reload()

    yield install
    for name in written:
        sys.modules.pop(name, None)
    monkeypatch.undo()
    for env_id in set(gymnasium.registry) - gym_ids:
        del gymnasium.registry[env_id]
    reg_mod.reload()
    reg_mod.register_envs()
