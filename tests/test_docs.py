"""The docs site builds (strict) from the generated pages, and its examples run."""

from __future__ import annotations

import doctest
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]


def test_docs_examples_run() -> None:
    result = doctest.testfile(str(ROOT / "docs" / "index.md"), module_relative=False, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_site_builds_strict_with_an_episode_gif_on_every_page(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs")
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs, ignore=shutil.ignore_patterns("envs"))
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    import gym4real

    result = gym4real.benchmark(
        "gym4real/elevator-v0",
        ["longest_first", "shortest_first"],
        episodes=1,
        out=tmp_path / "results" / "gym4real_elevator-v0",
    )
    best = max(result.returns, key=lambda p: result.returns[p][0])
    gen = [sys.executable, str(docs / "gen_pages.py"), "--figures", str(tmp_path / "results"), "--gifs"]
    subprocess.run([*gen, "--gif-steps", "3"], check=True, cwd=tmp_path)
    pages = sorted((docs / "envs").glob("gym4real_*.md"))
    assert len(pages) == len(gym4real.list_envs(multi_objective=False))  # no page of a vector-reward variant
    for page in pages:
        text = page.read_text()
        assert "## Configuration schema" in text
        (gif,) = re.findall(r"\]\((gifs/[^)]+\.gif)\)", text)
        with Image.open(docs / "envs" / gif) as image:
            assert 2 <= image.n_frames <= 4  # the reset and up to 3 steps
    elevator = (docs / "envs" / "gym4real_elevator-v0.md").read_text()
    assert f"gifs/elevator-v0-{best}-seed0.gif" in elevator  # the better of the two baselines
    assert "![returns_boxplot](figures/gym4real_elevator-v0/returns_boxplot.png)" in elevator
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q"], check=True, cwd=tmp_path)
    assert (tmp_path / "site" / "index.html").exists()


def test_browser_check_reports_a_console_error_a_broken_image_and_an_empty_page(
    tmp_path: Path, load_script: Callable[[Path], ModuleType]
) -> None:
    pytest.importorskip("playwright", reason="the docs session installs Playwright")
    check_site = load_script(ROOT / "docs" / "check_site.py")
    chromium = check_site.find_chromium(None)
    if chromium is None:
        pytest.skip(check_site.INSTALL)
    text = "<p>" + "words " * 40 + "</p>"
    pixel = tmp_path / "site" / "dot.gif"
    pixel.parent.mkdir()
    Image.new("RGB", (2, 2), "red").save(pixel)
    pages = {
        "index.html": f"<article><h1>Fine</h1>{text}<img src='dot.gif'></article>",
        "a/index.html": f"<article><h1>Bad</h1>{text}<img src='../missing.gif'><script>console.error('boom')</script>",
        "b/index.html": "<article><p>nothing</p></article>",
    }
    for rel, body in pages.items():
        (tmp_path / "site" / rel).parent.mkdir(exist_ok=True)
        (tmp_path / "site" / rel).write_text(f"<!doctype html><html><body>{body}</body></html>")
    problems = check_site.check(tmp_path / "site", tmp_path / "shots", chromium)
    assert not [p for p in problems if p.startswith("index.html")]
    bad = [p for p in problems if p.startswith("a/index.html")]
    assert any("console error: boom" in p for p in bad)
    assert any("broken image" in p and "missing.gif" in p for p in bad)
    assert any("HTTP 404" in p for p in bad)
    assert [p for p in problems if p.startswith("b/index.html")] == [
        "b/index.html: page did not render (h1: False, 7 characters of text)"
    ]
    assert sorted(p.name for p in (tmp_path / "shots").glob("*.png")) == ["a_index.png", "b_index.png", "index.png"]
