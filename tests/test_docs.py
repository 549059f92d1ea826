"""The docs site builds (strict) from the generated pages, its examples and tutorials run, and the browser
check finds broken images, links and pages."""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from types import ModuleType

import gymnasium as gym
import pytest
from PIL import Image

import gym4real

ROOT = Path(__file__).resolve().parents[1]
HOME = ROOT / "docs" / "index.md"


def _section(text: str, heading: str) -> str:
    return text.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]


def test_home_quick_start_runs_in_about_ten_lines() -> None:
    (code,) = re.findall(r"```python\n(.*?)```", _section(HOME.read_text(encoding="utf-8"), "Quick start"), re.S)
    assert len([line for line in code.splitlines() if line.strip()]) <= 12
    assert max(len(line) for line in code.splitlines()) <= 80  # no line cut off on the page
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    first, *table = run.stdout.splitlines()
    assert sorted(ast.literal_eval(first)) == ["delivery", "waiting"]  # the printed dict of the elevator's reward terms
    rows = {line.split()[0]: line.split() for line in table if line.split()}
    assert rows["longest_first"][1] == rows["random"][1] == "2"  # episodes per policy


def test_environments_page_names_the_reward_terms_of_each_multi_objective_id(
    load_script: Callable[[Path], ModuleType],
) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    pages = {i: i.replace("/", "_") + ".md" for i in gym4real.list_envs(multi_objective=False)}
    text = gen_pages.environments_index(pages)
    mo_ids = [i for i in gym4real.list_envs() if i not in pages]
    assert mo_ids
    for mo_id in mo_ids:
        (row,) = [line for line in text.splitlines() if line.startswith(f"| `{mo_id}` |")]
        base = mo_id.replace("-mo-v", "-v")
        env = gym.make(base)
        env.reset(seed=0)
        *_, info = env.step(env.action_space.sample())
        env.close()
        assert f"[`{base}`]({pages[base]})" in row
        assert sorted(re.findall(r"`([a-z_]+)`", row.split("|")[3])) == sorted(info["reward_components"])


def test_citation_names_the_installed_suite_version_and_the_readme_carries_it(
    load_script: Callable[[Path], ModuleType],
) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    text = gen_pages.citation()
    paper, suite = re.findall(r"```bibtex\n(.*?)```", text, re.S)
    assert "title  = {{Gym4ReaL}: A Suite for Benchmarking Real-World" in paper and "year   = {2025}" in paper
    assert f"version = {{{version('gym4real-core')}}}" in suite
    readme = _section((ROOT / "README.md").read_text(encoding="utf-8"), "How to cite")
    assert paper in readme and suite in readme


def test_home_verdicts_are_the_results_pages(load_script: Callable[[Path], ModuleType]) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    results = (ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8").splitlines()
    head = next(i for i, line in enumerate(results) if line.startswith("| env | budget | paper's claim |"))
    end = next(i for i in range(head, len(results)) if not results[i].startswith("|"))
    rows = results[head + 2 : end]  # the paper's claims; this suite's own checks are a table apart
    table = gen_pages.verdict_table()
    assert rows and table[0].startswith("| env | budget | paper's claim |") and table[2:] == rows


def test_home_suite_scores_are_the_results_pages(load_script: Callable[[Path], ModuleType]) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    results = (ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8")
    rows = [line for line in results.splitlines() if re.match(r"\| [a-z_]+ \| `[a-z0-9-]+`", line)]
    table = gen_pages.suite_score_table()
    assert table[2:] == rows  # each paper agent's row, or none before a paper-budget run


TUTORIAL = '''"""# Step the elevator

A tutorial as the docs session runs them.
"""

# %%
import gymnasium as gym

import gym4real  # noqa: F401

env = gym.make("gym4real/elevator-v0")
obs, info = env.reset(seed=0)
print("queues at the reset:", obs["floor_queues"])
'''


def test_site_builds_strict_with_the_env_pages_in_the_nav_and_an_executed_tutorial(tmp_path: Path) -> None:
    for plugin in ("mkdocs", "mkdocs_gallery", "mkdocstrings_handlers.python", "mkdocs_literate_nav"):
        pytest.importorskip(plugin, reason="the docs session installs the site's plugins")
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs, ignore=shutil.ignore_patterns("envs", "snippets", "tutorials"))
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    (tmp_path / "packages").symlink_to(ROOT / "packages")  # the API reference's sources and the changelogs
    tutorials = tmp_path / "examples" / "tutorials"
    tutorials.mkdir(parents=True)
    shutil.copy(ROOT / "examples" / "tutorials" / "README.md", tutorials / "README.md")
    (tutorials / "tutorial_1_step.py").write_text(TUTORIAL)

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
    ids = gym4real.list_envs(multi_objective=False)
    assert len(pages) == len(ids)  # no page of a vector-reward variant
    for page in pages:
        text = page.read_text()
        assert "## Configuration schema" in text
        (gif,) = re.findall(r"\]\((gifs/[^)]+\.gif)\)", text)
        with Image.open(docs / "envs" / gif) as image:
            if "robofeeder" in page.name:  # every frame of up to 3 whole picks
                assert image.n_frames > 4
            else:
                assert 2 <= image.n_frames <= 4  # the reset and up to 3 steps
    elevator = (docs / "envs" / "gym4real_elevator-v0.md").read_text()
    assert f"gifs/elevator-v0-{best}-seed0.gif" in elevator  # the better of the two baselines
    assert "![returns_boxplot](figures/gym4real_elevator-v0/returns_boxplot.png)" in elevator
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q"], check=True, cwd=tmp_path)

    site = tmp_path / "site"
    home = (site / "index.html").read_text()
    nav = set(re.findall(r'<a href="([^"]+)" class="md-nav__link', home))
    for env_id in ids:  # each env page: in the navigation, and in the gallery as its GIF linking to it
        page = f"envs/{env_id.replace('/', '_')}/"
        assert page in nav
        assert re.search(rf'<a href="{page}"><img alt="{env_id}" src="envs/gifs/[^"]+\.gif"', home), env_id
    assert {"tutorials/tutorial_1_step/", "results/", "api/", "api/wrappers/", "plugins/", "releases/core/"} <= nav
    tutorial = re.sub(r"<[^>]+>", "", (site / "tutorials" / "tutorial_1_step" / "index.html").read_text())
    assert "queues at the reset: [0 0 0 0]" in tutorial  # executed by the build: its output is on the page
    assert "gym4real.wrappers.challenge" in (site / "api" / "wrappers" / "index.html").read_text()
    assert "Changelog of gym4real-wds" in (site / "releases" / "wds" / "index.html").read_text()


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
    links = "<a href='a/#fine'>a</a><a href='dot.gif'>dot</a><a href='https://example.org/x'>out</a>"
    broken = "<a href='../missing/'>gone</a><a href='../#nowhere'>no anchor</a>"
    pages = {
        "index.html": f"<article><h1>Fine</h1>{text}<img src='dot.gif'>{links}</article>",
        "a/index.html": (
            f"<article><h1 id='fine'>Bad</h1>{text}<img src='../missing.gif'>{broken}"
            "<script>console.error('boom')</script>"
        ),
        "b/index.html": "<article><p>nothing</p></article>",
        "envs/e/index.html": f"<article><h1>An env</h1>{text}<a href='../../b/'>b</a></article>",
    }
    for rel, body in pages.items():
        (tmp_path / "site" / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "site" / rel).write_text(f"<!doctype html><html><body>{body}</body></html>")
    problems = check_site.check(tmp_path / "site", tmp_path / "shots", chromium)
    assert not [p for p in problems if p.startswith("index.html")]
    bad = [p for p in problems if p.startswith("a/index.html")]
    assert any("console error: boom" in p for p in bad)
    assert any("broken image" in p and "missing.gif" in p for p in bad)
    assert any("HTTP 404" in p for p in bad)
    assert any("broken link" in p and "/missing/ (no such file in the site)" in p for p in bad)
    assert any("broken link" in p and "no element with id `nowhere` on index.html" in p for p in bad)
    assert [p for p in problems if p.startswith("b/index.html")] == [
        "b/index.html: page did not render (h1: False, 7 characters of text)"
    ]
    assert not [p for p in problems if p.startswith("envs/")]
    shots = sorted(p.name for p in (tmp_path / "shots").glob("*.png"))
    assert shots == ["a_index.png", "b_index.png", "env.png", "envs_e_index.png", "home.png", "index.png"]


def test_env_page_figures_are_captioned_with_policies_episodes_and_objective(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, load_script: Callable[[Path], ModuleType]
) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    monkeypatch.setattr(gen_pages, "DOCS", tmp_path / "docs")  # the copies of the figures go there
    folder = tmp_path / "results" / "gym4real_dam-v0"
    gym4real.benchmark("gym4real/dam-v0", ["ead", "max"], episodes="test", out=folder)
    lines = gen_pages._figures("Benchmark figures", folder)
    captions = [line for line in lines if "<figcaption>" in line]
    assert len(captions) == len(list(folder.glob("*.png"))) == 2
    for caption in captions:
        assert "Policies <code>max</code>, <code>ead</code>, best first by the IQM of the objective" in caption
        assert "13 episodes each, the test protocol (the 13 test years" in caption
        assert "Objective: deficit + overflow + starving per episode (not the return, the training reward)" in caption
    assert "Mean cumulative objective per day" in captions[0] and "per-episode objective" in captions[1]
    assert all(
        (tmp_path / "docs" / "envs" / "figures" / folder.name / png.name).is_file() for png in folder.glob("*.png")
    )
    assert gen_pages.best_baseline("gym4real/dam-v0", tmp_path / "results") == "max"  # by the objective's IQM
