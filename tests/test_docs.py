"""The docs site builds (strict) from the generated pages, and its examples run."""

from __future__ import annotations

import doctest
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_docs_examples_run() -> None:
    result = doctest.testfile(str(ROOT / "docs" / "index.md"), module_relative=False, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_site_builds_strict(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs")
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs, ignore=shutil.ignore_patterns("envs"))
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    import gym4real

    gym4real.benchmark(
        "gym4real/elevator-v0", ["longest_first"], episodes=1, out=tmp_path / "results" / "gym4real_elevator-v0"
    )
    subprocess.run(
        [sys.executable, str(docs / "gen_pages.py"), "--figures", str(tmp_path / "results")], check=True, cwd=tmp_path
    )
    pages = sorted((docs / "envs").glob("gym4real_*.md"))
    assert pages and all("## Configuration schema" in p.read_text() for p in pages)
    elevator = (docs / "envs" / "gym4real_elevator-v0.md").read_text()
    assert "![returns_boxplot](figures/gym4real_elevator-v0/returns_boxplot.png)" in elevator
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q"], check=True, cwd=tmp_path)
    assert (tmp_path / "site" / "index.html").exists()
