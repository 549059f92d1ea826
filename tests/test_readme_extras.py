"""The README's table of what each extra of core adds names every extra core declares, once each, and
``scripts/measure_extras.py`` (which measures the table) counts what an extra brings or replaces."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "measure_extras.py"


@pytest.fixture
def measure(load_script: Callable[[Path], ModuleType]) -> ModuleType:
    return load_script(SCRIPT)


def _table_extras() -> list[str]:
    """The first cell of each row of the README's table of extras, in its order."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    after = readme.split("What each extra of core adds to an install", 1)[1]
    table = re.search(r"\n\| extra \|.*?\n\|[-| ]+\|\n((?:\|.*\|\n)+)", after)
    assert table is not None, "README.md: the table of extras (header `| extra | ...`) is missing"
    return [re.fullmatch(r"\| `([\w-]+)` \|.*", row).group(1) for row in table.group(1).splitlines()]  # type: ignore[union-attr]


def test_the_readmes_table_lists_every_extra_of_core_once(measure: ModuleType) -> None:
    rows = _table_extras()
    declared = measure.extras()
    assert len(rows) == len(set(rows)), f"README.md lists an extra twice: {rows}"
    assert sorted(rows) == sorted(declared), (
        f"README.md's table of extras lists {sorted(rows)}; packages/gym4real-core/pyproject.toml declares "
        f"{sorted(declared)}: measure the missing ones with scripts/measure_extras.py"
    )


def test_an_extra_adds_what_it_brings_and_what_it_replaces(measure: ModuleType) -> None:
    mb = 10**6
    core = {"numpy": ("2.4.6", 57 * mb), "pillow": ("13.0.0", 20 * mb), "pluggy": ("1.7.0", mb)}
    # brings scipy and tqdm, replaces pillow by an older (smaller) release, keeps numpy and pluggy as they are
    full = {**core, "scipy": ("1.17.0", 143 * mb), "tqdm": ("4.67.1", 2 * mb), "pillow": ("11.3.0", 18 * mb)}
    row = measure.added("video", core, full)
    assert row.size == (143 + 2 + 18 - 20) * mb
    assert row.count == 3
    assert row.biggest == [("scipy", "1.17.0", 143 * mb), ("tqdm", "4.67.1", 2 * mb), ("pillow", "11.3.0", -2 * mb)]
    assert row.cells(top=2) == "143 MB (3 distributions) | scipy 143 MB, tqdm 2 MB"
    assert row.cells() == "143 MB (3 distributions) | scipy 143 MB, tqdm 2 MB"  # pillow shrinks: not among them
