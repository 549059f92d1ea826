"""A griffe extension of the API reference: the docstrings' Sphinx roles as mkdocstrings cross-references.

The sources cross-reference with Sphinx roles (``:func:`~gym4real.core.registry.env_spec```,
``:class:`ConfigError```), which mkdocstrings prints as literal text. This extension rewrites each role of a
docstring before it is rendered: a target rendered on the API pages becomes a link (``[`ConfigError`]
[gym4real.core.errors.ConfigError]``, the Markdown cross-reference of mkdocs-autorefs); any other target
(private, external, or not on the API pages) becomes inline code, never a link the strict build could not
resolve. A target is looked up as Python would from the docstring's module (a name of that module, or a
full dotted path), by importing it; the pages render the objects they name with ``::: identifier`` and,
for a module or class, its public members defined there.

mkdocs.yml loads it with ``extensions: [docs/griffe_roles.py]`` (the path from the repository root).
"""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path
from typing import Any

import griffe

API_PAGES = Path(__file__).resolve().parent / "api"
#: A Sphinx role: ``:func:`target```, ``:class:`~path.Name```, ``:py:meth:`Title <path>```.
ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const|term):`(?P<body>[^`]+)`")


def documented(pages: Path = API_PAGES) -> list[str]:
    """The identifiers the API pages render with ``::: identifier``."""
    found = []
    for page in sorted(pages.glob("*.md")):
        found += re.findall(r"^:::\s+([\w.]+)", page.read_text(encoding="utf-8"), re.M)
    return found


def lookup(path: str) -> Any:
    """The object a dotted path names (its longest importable module, then attributes), or None."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            if not hasattr(obj, name):
                return None
            obj = getattr(obj, name)
        return obj
    return None


def canonical(obj: Any, found_as: str) -> str:
    """Where ``obj`` is defined: its module and qualified name (``found_as`` for data, which has neither)."""
    if inspect.ismodule(obj):
        return obj.__name__
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if isinstance(module, str) and isinstance(qualname, str) and "<" not in qualname:
        return f"{module}.{qualname}"
    return found_as


def has_docstring(obj: Any) -> bool:
    """Whether mkdocstrings renders ``obj`` as a member: a module, class or function with a docstring of its own.

    Data (a constant, whose ``#:`` comment griffe does not read) and objects without a docstring are not
    rendered; a dataclass's ``__doc__`` that only repeats its signature is not a docstring.
    """
    if not (inspect.ismodule(obj) or inspect.isclass(obj) or inspect.isroutine(obj)):
        return False
    doc = vars(obj).get("__doc__") if inspect.isclass(obj) else obj.__doc__
    return isinstance(doc, str) and bool(doc) and not (inspect.isclass(obj) and doc.startswith(f"{obj.__name__}("))


def anchor(target: str, scope: str | None, roots: list[str]) -> str | None:
    """The identifier of the rendered object a role's ``target`` names from module ``scope``, or None."""
    for candidate in ([f"{scope}.{target}"] if scope else []) + [target]:
        obj = lookup(candidate)
        if obj is None:
            continue
        path = canonical(obj, candidate)
        for root in roots:
            base = canonical(lookup(root), root)
            if path == base:
                return root
            rest = path.removeprefix(base + ".")
            if rest != path and not any(part.startswith("_") for part in rest.split(".")) and has_docstring(obj):
                return f"{root}.{rest}"
        return None
    return None


def convert(text: str, roots: list[str], scope: str | None = None) -> str:
    """Every role of ``text`` (a docstring of module ``scope``) as a cross-reference or as inline code."""

    def replace(match: re.Match[str]) -> str:
        body = match.group("body").strip()
        titled = re.fullmatch(r"(?P<title>.+?)\s*<(?P<target>[^>]+)>", body)
        if titled:
            title, target = titled.group("title"), titled.group("target")
        else:
            target = body.lstrip("~").lstrip(".")
            title = target.rsplit(".", 1)[-1] if body.startswith("~") else target
        identifier = anchor(target, scope, roots) if re.fullmatch(r"[\w.]+", target) else None
        return f"[`{title}`][{identifier}]" if identifier else f"`{title}`"

    return ROLE.sub(replace, text)


class SphinxRoles(griffe.Extension):
    """Rewrites the Sphinx roles of every docstring griffe loads (see the module's docstring)."""

    def __init__(self) -> None:
        self.roots = documented()

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        """Convert the roles of ``obj``'s docstring, looked up from its module."""
        if obj.docstring is not None:
            scope = obj.path if obj.is_module else obj.module.path
            obj.docstring.value = convert(obj.docstring.value, self.roots, scope)
