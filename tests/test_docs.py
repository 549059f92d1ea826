"""The docs site builds (strict) from the generated pages, its examples and tutorials run, and the browser
check finds broken images, links and pages."""

from __future__ import annotations

import ast
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from types import ModuleType, SimpleNamespace

import gymnasium as gym
import pandas as pd
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
    assert "eprint = {2507.00257}" in paper and "archivePrefix = {arXiv}" in paper  # the paper's arXiv id
    assert "url    = {https://arxiv.org/abs/2507.00257}" in paper
    assert f"version = {{{version('gym4real-core')}}}" in suite
    readme = _section((ROOT / "README.md").read_text(encoding="utf-8"), "How to cite")
    assert paper in readme and suite in readme


def test_the_readmes_evaluate_path_is_the_folder_train_writes() -> None:
    """`{env}` of `evaluate` is the id's name, the folder name of `train`'s runs (and of `reproduce`'s envs)."""
    from gym4real.bench.evaluate import _filled
    from gym4real.rl.train import default_out

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    (env_id, algo, preset, seed), *_ = re.findall(
        r"gym4real train (\S+) --algo (\w+) --preset (\w+) --seed (\d+)", readme
    )
    (policy,) = re.findall(rf'gym4real evaluate "\w+={algo}:([^"]*\{{env\}}[^"]*)"', readme)
    model = "model.zip" if algo in ("ppo", "dqn") else "qtable.npz"
    assert _filled(policy, env_id, int(seed)) == str(default_out(env_id, algo, preset, int(seed)) / model)
    assert default_out("gym4real/dam-v0", "ppo", "paper", 0) == Path("runs/dam-v0/ppo-paper-seed0")


def test_the_evaluate_tutorial_installs_from_a_clean_machine_and_the_home_page_links_it() -> None:
    page = (ROOT / "docs" / "evaluate.md").read_text(encoding="utf-8")
    install = _section(page, "0. Install and get the data")
    commands = " ".join(re.findall(r"```bash\n(.*?)```", install, re.S))
    assert "pip install torch --index-url https://download.pytorch.org/whl/cpu" in commands  # the CPU build
    assert '"./packages/gym4real-core[rl]"' in commands
    envs = re.findall(r'"(gym4real/[a-z0-9-]+)"', _section(page, "1. Train your agent"))
    assert envs
    for env_id in envs:  # the domain of every environment the tutorial uses, and its data
        domain = env_id.split("/")[1].split("-")[0]
        assert f"./packages/gym4real-{domain}" in commands and (ROOT / "packages" / f"gym4real-{domain}").is_dir()
        assert re.search(rf"gym4real data fetch [a-z ]*\b{domain}\b", commands)
    assert "export GYM4REAL_DATA_DIR=" in commands
    pyproject = (ROOT / "packages" / "gym4real-core" / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r"^rl = \[", pyproject, re.M)  # the extra the page installs
    body = HOME.read_text(encoding="utf-8")
    assert "](evaluate.md)" in body  # in the page's text, not only in the navigation


@pytest.mark.slow
def test_the_evaluate_tutorials_example_output_has_the_tables_layout() -> None:
    """The page's example output is `Evaluation.table()`'s: its headers are those the code prints now."""
    page = (ROOT / "docs" / "evaluate.md").read_text(encoding="utf-8")
    (example,) = re.findall(r"It prints, for example.*?```\n(.*?)```", page, re.S)
    table = gym4real.evaluate({}, ["gym4real/wds-v0"]).table()
    headers = [line for line in table.splitlines() if line.strip().startswith(("policy", "== suite score"))]
    assert len(headers) == 3 and all(line in example.splitlines() for line in headers)
    assert "(reference runs: paper budget, gym4real.wds: reference/wds-v0.csv)" in table  # no path of this machine
    assert "== gym4real/trading-v0  (reference runs: " in example and "   P(a2c > " in example


def test_the_cluster_page_speaks_of_machines_generically() -> None:
    page = (ROOT / "docs" / "cluster.md").read_text(encoding="utf-8")
    assert "a 2-core machine" in page and "a GPU machine" in page
    assert not re.search(r"this project's|\blent\b|our machine", page)


def test_the_api_references_docstring_roles_become_links_to_objects_on_its_pages(
    load_script: Callable[[Path], ModuleType], monkeypatch: pytest.MonkeyPatch
) -> None:
    """mkdocstrings prints `:func:`...`` as text: the site's griffe extension rewrites every role of the
    rendered docstrings as a cross-reference to a rendered object (a link), or as code."""
    import importlib.util
    import inspect

    if importlib.util.find_spec("griffe") is None:  # the extension's base class (mkdocstrings brings griffe)
        monkeypatch.setitem(sys.modules, "griffe", ModuleType("griffe"))
        sys.modules["griffe"].Extension = object  # type: ignore[attr-defined]
    roles = load_script(ROOT / "docs" / "griffe_roles.py")
    assert "docs/griffe_roles.py" in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    roots = roles.documented()
    docstrings = []  # (docstring, its module) of every object the API pages render
    for root in roots:
        obj = roles.lookup(root)
        scope = obj.__name__ if inspect.ismodule(obj) else obj.__module__
        docstrings.append((inspect.getdoc(obj) or "", scope))
        if inspect.ismodule(obj) or inspect.isclass(obj):
            docstrings += [(inspect.getdoc(v) or "", scope) for k, v in vars(obj).items() if not k.startswith("_")]
    assert sum(len(roles.ROLE.findall(text)) for text, _ in docstrings) >= 20  # roles printed as text today
    links = set()
    for text, scope in docstrings:
        converted = roles.convert(text, roots, scope)
        assert not roles.ROLE.search(converted), converted
        link = r"\[`[^`]+`\]\[([\w.]+)\]"
        links |= set(re.findall(link, converted)) - set(re.findall(link, text))  # the roles' links
    for identifier in links:  # each names an object the pages render: a root, or a public member of one
        assert roles.lookup(identifier) is not None
        assert any(identifier == r or identifier.startswith(r + ".") for r in roots), identifier
    assert {
        "gym4real.core.errors.ConfigError",
        "gym4real.bench.suite_score",
        "gym4real.bench.benchmark.benchmark",
    } <= links


def test_the_readme_states_the_batched_dams_speed_goal_that_bench_ratios_checks(
    load_script: Callable[[Path], ModuleType], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 35: bit-identical to the single env (libm's `pow`), at least 0.25x CartPoleVectorEnv(1024)."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # bench_ratios imports its folder's report.py
    bench = load_script(ROOT / "benchmarks" / "bench_ratios.py")
    goal = bench.NATIVE_THROUGHPUT_GOALS["gym4real/dam-v0"]
    assert goal == 0.25
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert f"at least {goal:g}x as fast as `CartPoleVectorEnv(1024)` by the median" in readme


def _gallery_output(script: Path) -> tuple[str, list[str]]:
    """Run a tutorial as the docs' gallery does, cell by cell, printing the repr of a cell's last expression
    when it is not None; return what it printed and the warnings it raised."""
    import ast
    import contextlib
    import io
    import warnings

    namespace: dict[str, object] = {"__name__": "__main__", "__file__": str(script)}
    printed = io.StringIO()
    with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stdout(printed):
        warnings.simplefilter("always")
        for cell in script.read_text(encoding="utf-8").split("\n# %%"):
            tree = ast.parse(cell)
            last = tree.body.pop() if tree.body and isinstance(tree.body[-1], ast.Expr) else None
            exec(compile(tree, str(script), "exec"), namespace)
            if last is not None:
                value = eval(compile(ast.Expression(last.value), str(script), "eval"), namespace)
                if value is not None:
                    print(repr(value))
    return printed.getvalue(), [f"{w.category.__name__}: {w.message}" for w in caught]


TUTORIALS = sorted((ROOT / "examples" / "tutorials").glob("tutorial_*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("script", TUTORIALS, ids=[t.stem for t in TUTORIALS])
def test_an_executed_tutorial_prints_no_path_of_this_machine_no_warning_and_no_object_address(
    script: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("minari")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    printed, warned = _gallery_output(script)
    assert not warned, warned
    assert not re.search(r" object at 0x[0-9a-f]+>", printed), printed
    for path in (str(ROOT), str(tmp_path), "/tmp/", sys.prefix):
        assert path not in printed, (path, printed)


def test_code_in_tables_is_never_broken_mid_word() -> None:
    """Material breaks inline code anywhere: the stylesheet keeps the ids of the results tables whole."""
    css = (ROOT / "docs" / "stylesheets" / "extra.css").read_text(encoding="utf-8")
    rules = dict(re.findall(r"([^{}]+?)\s*\{([^}]*)\}", re.sub(r"/\*.*?\*/", "", css, flags=re.S)))
    (body,) = [body for selector, body in rules.items() if re.search(r"\btable\b.*\bcode$", selector.strip())]
    declarations = dict(re.findall(r"([\w-]+)\s*:\s*([^;]+);", body))
    assert declarations == {"word-break": "normal", "overflow-wrap": "normal", "white-space": "nowrap"}


def test_home_verdicts_are_the_results_pages(load_script: Callable[[Path], ModuleType]) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    results = (ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8").splitlines()
    head = next(i for i, line in enumerate(results) if line.startswith("| env | paper's claim |"))
    end = next(i for i in range(head, len(results)) if not results[i].startswith("|"))
    rows = results[head + 2 : end]  # the paper's claims; this suite's own checks are a table apart
    table = gen_pages.verdict_table()
    assert rows and table[0].startswith("| env | paper's claim |") and table[2:] == rows


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


@pytest.mark.slow
def test_site_builds_strict_with_the_env_pages_in_the_nav_and_an_executed_tutorial(tmp_path: Path) -> None:
    for plugin in ("mkdocs", "mkdocs_gallery", "mkdocstrings_handlers.python", "mkdocs_literate_nav"):
        pytest.importorskip(plugin, reason="the docs session installs the site's plugins")
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs, ignore=shutil.ignore_patterns("envs", "snippets", "tutorials", "diagrams"))
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    shutil.copy(ROOT / ".importlinter", tmp_path / ".importlinter")  # the layers the Architecture page draws
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "lint_imports.py", tmp_path / "scripts" / "lint_imports.py")
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
    assert not list(site.glob("*.py")) and not (site / "bench").exists()  # the build's scripts and inputs stay out
    home = (site / "index.html").read_text()
    nav = set(re.findall(r'<a href="([^"]+)" class="md-nav__link', home))
    for env_id in ids:  # each env page: in the navigation, and in the gallery as its GIF linking to it
        page = f"envs/{env_id.replace('/', '_')}/"
        assert page in nav
        assert re.search(rf'<a href="{page}"><img alt="{env_id}" src="envs/gifs/[^"]+\.gif"', home), env_id
    assert {"tutorials/tutorial_1_step/", "results/", "api/", "api/wrappers/", "plugins/", "releases/core/"} <= nav
    assert "architecture/" in nav
    drawn = (site / "diagrams" / "architecture.svg").read_text()  # drawn by the build from the import graph
    for layer in ("gym4real.core", "gym4real.bench", "gym4real.rl", "gym4real.results", "gym4real.cli"):
        assert layer in drawn
    assert 'src="../diagrams/architecture.svg"' in (site / "architecture" / "index.html").read_text()
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


def test_an_env_page_caption_names_the_upper_reference_apart_from_the_ranked_policies(
    load_script: Callable[[Path], ModuleType],
) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    run = {
        "env_id": "gym4real/dam-v0",
        "protocol": {"test": True, "description": "the 13 test years"},
        "objective": ["deficit", "overflow", "starving"],
        "objective_is_return": False,
        "ranking": ["hindsight", "max", "ead"],  # results.json ranks every policy by its IQM
        "episodes": [{}] * 13,
        "step_unit": "day",
    }
    caption = gen_pages.figure_caption("cumulative_reward.png", run)
    assert "Policies <code>max</code>, <code>ead</code>, best first by the IQM of the objective; then the " in caption
    assert "non-causal upper reference <code>hindsight</code>, drawn apart (black star), not ranked" in caption


def test_architecture_figure_holds_each_list_in_its_box_and_no_arrow_crosses_a_text(
    load_script: Callable[[Path], ModuleType],
) -> None:
    """Issue 45: the module lists overflowed their boxes and arrows crossed them. Measured as drawn (Agg)."""
    pytest.importorskip("grimp", reason="the docs session installs import-linter")
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch
    from matplotlib.path import Path as MplPath

    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    layers, members, edges = gen_pages.import_groups()
    assert {"gym4real.cli", "gym4real.core"} <= set(layers) and edges[("domains", "gym4real.core")] > 0
    fig = gen_pages.draw_architecture(layers, members, edges)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (ax,) = fig.axes
    boxes = [p.get_window_extent(renderer) for p in ax.patches if isinstance(p, FancyBboxPatch)]
    arrows = [  # each arrow's line and head as open polylines (a closing vertex would count as a point at 0, 0)
        [MplPath(line) for line in p.get_transform().transform_path(p.get_path()).to_polygons(closed_only=False)]
        for p in ax.patches
        if isinstance(p, FancyArrowPatch)
    ]
    assert len(boxes) == len(members) and len(arrows) == len(edges)
    counts = [t for t in ax.texts if t.get_bbox_patch() is not None]
    assert sorted(int(t.get_text()) for t in counts) == sorted(edges.values())
    listed = " ".join(t.get_text() for t in ax.texts)
    for group, modules in members.items():  # every public module of a layer, each package beside, is named
        depth = 2 if group in layers else 1
        names = {m.split(".")[depth] for m in modules if m.count(".") >= depth} - {""}
        names = {n for n in names if not n.startswith("_")}
        assert names
        assert all(re.search(rf"\b{name}\b", listed) for name in names)
    for text in ax.texts:
        extent = text.get_window_extent(renderer)
        if text in counts:  # a count covers its own arrow only
            assert sum(any(line.intersects_bbox(extent, filled=False) for line in a) for a in arrows) == 1, (
                text.get_text()
            )
            continue
        inside = [
            b for b in boxes if b.x0 <= extent.x0 and extent.x1 <= b.x1 and b.y0 <= extent.y0 and extent.y1 <= b.y1
        ]
        assert inside or not any(b.overlaps(extent) for b in boxes), f"{text.get_text()!r} overflows its box"
        assert not any(line.intersects_bbox(extent, filled=False) for a in arrows for line in a), text.get_text()


BENCH = ROOT / "docs" / "bench"


def _noxfile(load_script: Callable[[Path], ModuleType], monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """The noxfile, its sessions plain functions (a stand-in for nox, which the test venvs do not install)."""
    fake = ModuleType("nox")

    def session(*args: object, **kwargs: object) -> object:
        return args[0] if args and callable(args[0]) else (lambda f: f)

    fake.session = session  # type: ignore[attr-defined]
    fake.parametrize = lambda *args, **kwargs: lambda f: f  # type: ignore[attr-defined]
    fake.options = SimpleNamespace()  # type: ignore[attr-defined]
    fake.project = SimpleNamespace(dependency_groups=lambda *a: [], load_toml=lambda path: {})  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "nox", fake)
    return load_script(ROOT / "noxfile.py")


class _Session:
    """What a nox session is asked to do: its installs, its commands (in order) and its log."""

    def __init__(self, posargs: list[str], ids: list[str]) -> None:
        self.posargs, self.ids = posargs, ids
        self.runs: list[tuple[str, ...]] = []
        self.envs: list[dict[str, str]] = []  # each run's environment
        self.logs: list[str] = []

    def install(self, *args: str, **kwargs: object) -> None:
        pass

    def log(self, message: str) -> None:
        self.logs.append(message)

    def error(self, message: str) -> None:
        raise SystemExit(message)

    def run(self, *args: str, **kwargs: object) -> str | None:
        self.runs.append(args)
        self.envs.append(dict(kwargs.get("env") or {}))  # type: ignore[call-overload]
        return " ".join(self.ids) if args[:2] == ("python", "-c") else None


def test_the_docs_session_builds_from_the_committed_bench_results_and_benchmarks_only_with_refresh(
    load_script: Callable[[Path], ModuleType], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Issue 47: the docs build re-benchmarked every env (42 minutes); now `-- --refresh` alone does."""
    noxfile = _noxfile(load_script, monkeypatch)
    monkeypatch.setenv("GYM4REAL_CHROMIUM", sys.executable)  # any binary: the session only looks it up
    assert noxfile.BENCH == BENCH
    session = _Session([], ["gym4real/dam-v0", "gym4real/wds-v0"])
    noxfile.docs(session)
    assert not [run for run in session.runs if "bench" in run]
    (pages,) = [run for run in session.runs if "docs/gen_pages.py" in run]
    assert pages[pages.index("--figures") + 1] == str(BENCH) and "--pack-figures" not in pages
    assert [run[:2] for run in session.runs] == [
        ("python", "docs/gen_pages.py"),
        ("mkdocs", "build"),
        ("python", "docs/check_site.py"),
    ]
    assert re.search(r"no benchmark runs.*CPU-minutes.*\d+ to \d+ minutes on an idle 2-core machine", session.logs[0])

    monkeypatch.setattr(noxfile, "BENCH", tmp_path / "bench")
    (tmp_path / "bench" / "gym4real_dam-v0").mkdir(parents=True)
    (tmp_path / "bench" / "gym4real_dam-v0" / "old.png").write_bytes(b"")  # a figure the new run may not draw
    session = _Session(["--refresh"], ["gym4real/dam-v0", "gym4real/wds-v0"])
    noxfile.docs(session)
    benches = [run for run in session.runs if run[:2] == ("gym4real", "bench")]
    assert [run[2] for run in benches] == session.ids
    assert [run[run.index("--out") + 1] for run in benches] == [
        str(tmp_path / "bench" / i.replace("/", "_")) for i in session.ids
    ]
    assert not (tmp_path / "bench" / "gym4real_dam-v0" / "old.png").exists()
    (pages,) = [run for run in session.runs if "docs/gen_pages.py" in run]
    assert "--pack-figures" in pages and session.runs.index(pages) > session.runs.index(benches[-1])
    assert "--refresh" in session.logs[0] and "45 minutes" in session.logs[0]

    with pytest.raises(SystemExit, match="the only option is `-- --refresh`"):
        noxfile.docs(_Session(["--refesh"], []))


def test_the_committed_bench_results_are_each_envs_current_test_protocol_and_small(
    load_script: Callable[[Path], ModuleType],
) -> None:
    """docs/bench/ holds, per single-objective env, the run of its registered protocol (its policies and
    episodes as the registry has them now), the two figures the page shows, under 1 MB in all."""
    from gym4real.bench.benchmark import _jsonable, protocol
    from gym4real.core.registry import load_object

    ids = gym4real.list_envs(multi_objective=False)
    assert sorted(p.name for p in BENCH.iterdir()) == sorted(i.replace("/", "_") for i in ids)
    for env_id in ids:
        folder = BENCH / env_id.replace("/", "_")
        run = json.loads((folder / "results.json").read_text(encoding="utf-8"))
        spec = protocol(env_id)
        plan = load_object(spec.protocol)(dict(spec.env_kwargs))
        assert (
            run["env_id"] == env_id and run["protocol"]["test"] and run["protocol"]["description"] == spec.description
        )
        assert sorted(run["ranking"]) == sorted(spec.policies), env_id
        assert run["episodes"] == [_jsonable(e) for e in plan], env_id
        summary = pd.read_csv(folder / "summary.csv", index_col="policy")
        assert sorted(summary.index) == sorted(spec.policies) and (summary["episodes"] == len(plan)).all()
        assert {"cumulative_reward.png", "returns_boxplot.png"} <= {p.name for p in folder.glob("*.png")}
    assert sum(p.stat().st_size for p in BENCH.rglob("*") if p.is_file()) < 1_000_000


def test_the_committed_elevator_bench_is_what_gym4real_bench_measures_now() -> None:
    """The committed numbers are reproduced: the elevator's protocol run again gives every episode's return."""
    committed = pd.read_csv(BENCH / "gym4real_elevator-v0" / "episodes.csv")
    fresh = gym4real.benchmark("gym4real/elevator-v0", episodes="test").per_episode()
    columns = ["policy", "episode", "seed", "return", "objective"]
    pd.testing.assert_frame_equal(
        fresh[columns].sort_values(["policy", "episode"]).reset_index(drop=True),
        committed[columns].sort_values(["policy", "episode"]).reset_index(drop=True),
        check_dtype=False,
    )


def test_the_site_leaves_out_the_build_scripts_and_the_bench_folder() -> None:
    """Issue 45: `site/` shipped docs/gen_pages.py, check_site.py and griffe_roles.py."""
    pytest.importorskip("mkdocs", reason="the docs session installs mkdocs")
    import yaml
    from mkdocs.config.config_options import PathSpec

    exclude = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))["exclude_docs"]
    spec = PathSpec().validate(exclude)  # mkdocs' own reading of `exclude_docs`
    scripts = [p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").glob("*.py")]
    assert {"gen_pages.py", "check_site.py", "griffe_roles.py"} <= set(scripts)
    assert all(spec.match_file(s) for s in scripts)
    assert spec.match_file("bench/gym4real_dam-v0/results.json")
    assert not spec.match_file("tutorials/tutorial_1_make_step_render.py")  # the tutorials' downloads stay
    assert not spec.match_file("envs/figures/gym4real_dam-v0/returns_boxplot.png")


def test_packing_the_bench_figures_keeps_them_as_drawn_at_a_fraction_of_the_bytes(
    tmp_path: Path, load_script: Callable[[Path], ModuleType]
) -> None:
    import io

    import numpy as np

    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    folder = tmp_path / "gym4real_elevator-v0"
    gym4real.benchmark("gym4real/elevator-v0", ["longest_first", "random"], episodes=3, out=folder)
    drawn = {p.name: p.read_bytes() for p in folder.glob("*.png")}
    (folder / "heatmap.png").write_bytes(drawn["cumulative_reward.png"])  # a domain's own figure: left alone
    packed = gen_pages.pack_figures(tmp_path)
    assert sorted(p.name for p in packed) == ["cumulative_reward.png", "returns_boxplot.png"]
    assert (folder / "heatmap.png").read_bytes() == drawn["cumulative_reward.png"]
    for png in packed:
        assert png.stat().st_size < 0.5 * len(drawn[png.name])
        with Image.open(png) as after, Image.open(io.BytesIO(drawn[png.name])) as before:
            difference = np.abs(np.asarray(after.convert("RGB"), int) - np.asarray(before.convert("RGB"), int))
        assert difference.mean() < 1.0 and np.percentile(difference, 99.9) < 24, png.name  # of 0-255 per channel
    again = {p.name: p.read_bytes() for p in folder.glob("*.png")}
    assert gen_pages.pack_figures(tmp_path) == [] and {p.name: p.read_bytes() for p in folder.glob("*.png")} == again


def test_the_docs_session_silences_mkdocs_gallerys_deprecated_import_and_no_other_deprecation(
    load_script: Callable[[Path], ModuleType], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 45: `mkdocs build` printed a DeprecationWarning with its stack trace (mkdocs-gallery's import of
    `mkdocs.utils.warning_filter`); the session's warning filter hides that one, and shows other deprecations."""
    pytest.importorskip("mkdocs_gallery", reason="the docs session installs mkdocs-gallery")
    noxfile = _noxfile(load_script, monkeypatch)
    code = (
        "import mkdocs_gallery.mkdocs_compatibility\n"
        "exec('import warnings; warnings.warn(\"another deprecation\", DeprecationWarning)', {'__name__': 'a.module'})"
    )
    printed = {}
    for name, filters in (("mkdocs' own", "module::DeprecationWarning"), ("the session's", noxfile.MKDOCS_WARNINGS)):
        env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"} | {"PYTHONWARNINGS": filters}
        run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
        printed[name] = run.stderr
    assert "warning_filter doesn't do anything" in printed["mkdocs' own"]  # what the build printed
    assert "warning_filter" not in printed["the session's"]
    assert "another deprecation" in printed["the session's"]
    monkeypatch.setenv("GYM4REAL_CHROMIUM", sys.executable)
    session = _Session([], [])
    noxfile.docs(session)
    (build,) = [i for i, run in enumerate(session.runs) if run[:2] == ("mkdocs", "build")]
    assert session.envs[build]["PYTHONWARNINGS"] == noxfile.MKDOCS_WARNINGS
