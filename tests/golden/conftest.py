"""Golden fixtures: numbers the reference implementation itself produced, read by every golden test.

``<domain>.json`` was written by ``regen.py`` (run by hand against Daveonwave/gym4ReaL at 774d5ce; see its
docstring for the setup and the versions each fixture records). The tests compare our
``fidelity="upstream"`` runs with them.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

HERE = Path(__file__).resolve().parent


@cache
def _load(domain: str) -> dict[str, Any]:
    return json.loads((HERE / f"{domain}.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def golden() -> Callable[[str], dict[str, Any]]:
    """``golden(domain)``: the parsed fixture ``<domain>.json`` (floats read back exactly)."""
    return _load


@pytest.fixture(scope="session")
def histdata_ticks(tmp_path_factory: pytest.TempPathFactory, load_script: Callable[[Path], ModuleType]) -> Path:
    """A folder with the synthetic HistData tick files of 2022 the trading fixture was made from."""
    ticks = load_script(HERE / "synthetic_ticks.py")
    folder = tmp_path_factory.mktemp("golden") / "histdata"
    ticks.write(folder)
    return folder
