"""The layers of gym4real-core and the rules of the domain plugins hold (import-linter, ``.importlinter``).

``scripts/lint_imports.py`` runs ``lint-imports`` over every installed portion of the namespace; a broken
contract fails it. A second check makes sure the contracts are not vacuous: the graph it reads holds the
domains and every layer, and a module that imported a layer above it would break the layers contract.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNNER = ROOT / "scripts" / "lint_imports.py"

pytest.importorskip("importlinter")


def _lint(cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(RUNNER), "--no-cache"], cwd=cwd, capture_output=True, text=True, check=False
    )


def test_lint_imports_keeps_every_contract() -> None:
    result = _lint(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout
    contracts = ("Layers", "plugin host imports nothing above it", "independent", "Domains reach measurement")
    for contract in (*contracts, "import no library of core's bench extra", "only in the harness's hooks"):
        assert contract in result.stdout


def _graph(external: bool = False) -> object:
    """grimp's graph of every installed portion of ``gym4real`` (with the third-party packages it imports)."""
    import importlib.util

    import grimp

    spec = importlib.util.spec_from_file_location("lint_imports", RUNNER)
    assert spec is not None and spec.loader is not None
    runner = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(runner)
    runner.whole_namespace()
    return grimp.build_graph("gym4real", include_external_packages=external, cache_dir=None)


def test_a_core_module_importing_measurement_breaks_the_layers(tmp_path: Path) -> None:
    """The same contracts, on the graph plus one upward import: lint-imports names it and fails."""
    graph: Any = _graph()
    domains = {"dam", "elevator", "microgrid", "robofeeder", "trading", "wds"}
    assert {f"gym4real.{d}" for d in domains} <= graph.modules
    for layer in ("core", "bench", "rl", "results", "cli"):
        assert f"gym4real.{layer}" in graph.modules
    assert not graph.find_illegal_dependencies_for_layers(
        layers=("gym4real.cli", "gym4real.results", "gym4real.rl", "gym4real.bench", "gym4real.core")
    )
    graph.add_import(importer="gym4real.core.registry", imported="gym4real.bench.stats")
    broken = graph.find_illegal_dependencies_for_layers(
        layers=("gym4real.cli", "gym4real.results", "gym4real.rl", "gym4real.bench", "gym4real.core")
    )
    assert {(d.importer, d.imported) for d in broken} == {("gym4real.core", "gym4real.bench")}


def test_the_host_imports_no_library_of_the_bench_extra_and_one_import_would_show() -> None:
    """The thin install's contract is not vacuous: the graph sees third-party imports (measurement's matplotlib)."""
    graph: Any = _graph(external=True)
    assert {"matplotlib", "scipy", "tqdm"} <= graph.modules
    for source in ("gym4real.core", "gym4real.wrappers"):
        for library in ("matplotlib", "scipy", "tqdm"):
            assert graph.find_shortest_chain(importer=source, imported=library, as_packages=True) is None
    graph.add_import(importer="gym4real.core.canvas", imported="matplotlib")
    chain = graph.find_shortest_chain(importer="gym4real.core", imported="matplotlib", as_packages=True)
    assert chain == ("gym4real.core.canvas", "matplotlib")
