"""The import graph of the gym4real modules has no circle: a lower module never imports an upper one.

Every import that can run counts, at a module's top level or deferred into a function (a deferred import
back into the module that called you is still a circle); imports under ``if TYPE_CHECKING:`` are
type-only and do not.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _modules(root: Path) -> dict[str, Path]:
    found = {}
    for src in sorted(root.glob("packages/*/src")):
        for file in src.rglob("*.py"):
            parts = file.relative_to(src).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = file
    return found


def _runtime_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement that can run: at the top level or deferred into a function, not type-only."""
    found: list[ast.Import | ast.ImportFrom] = []
    pending: list[ast.AST] = [tree]
    while pending:
        node = pending.pop()
        if isinstance(node, ast.Import | ast.ImportFrom):
            found.append(node)
        elif isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            pending += node.orelse
        else:
            pending += ast.iter_child_nodes(node)
    return found


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the gym4real modules it imports (at import time or later)."""
    modules = _modules(root)
    graph: dict[str, set[str]] = {}
    for name, file in modules.items():
        package = name if file.name == "__init__.py" else name.rpartition(".")[0]
        edges = graph.setdefault(name, set())
        for node in _runtime_imports(ast.parse(file.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                    base = ".".join([*anchor, *([base] if base else [])])
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            edges.update(t for t in targets if t in modules and t != name)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_the_circle_finder_finds_a_circle_and_only_a_circle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert circles(graph) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_the_graph_counts_runtime_imports_and_not_type_only_ones(tmp_path: Path) -> None:
    package = tmp_path / "packages" / "gym4real-x" / "src" / "gym4real" / "x"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from . import b\n")
    (package / "b.py").write_text("try:\n    from gym4real.x.c import thing\nexcept ImportError:\n    pass\n")
    (package / "c.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .a import A\nthing = 1\n"
    )
    graph = import_graph(tmp_path)
    assert graph == {
        "gym4real.x": set(),
        "gym4real.x.a": {"gym4real.x.b"},
        "gym4real.x.b": {"gym4real.x.c"},
        "gym4real.x.c": set(),
    }
    assert circles(graph) == []
    (package / "c.py").write_text("def late():\n    import gym4real.x.a\nthing = 1\n")
    assert circles(import_graph(tmp_path)) == [["gym4real.x.a", "gym4real.x.b", "gym4real.x.c"]]


def test_no_module_imports_itself_back_at_import_time() -> None:
    assert circles(import_graph()) == []
