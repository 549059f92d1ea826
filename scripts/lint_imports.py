"""Run import-linter (``lint-imports``) on the whole ``gym4real`` namespace: every installed distribution.

``.importlinter`` holds the contracts (the layers of core, the domains' independence and plugin API).
import-linter's graph builder (grimp) reads a package's folders from its import spec. ``gym4real`` is a
pkgutil-style namespace: core owns ``gym4real/__init__.py`` and each domain distribution adds its folder to
``gym4real.__path__`` when the package is imported, which the spec of a package not yet imported does not
show. :func:`whole_namespace` imports ``gym4real`` and gives its spec the joined path; run as a script, this
then runs ``lint-imports`` with the arguments it was given (``nox -s lint`` and
``tests/test_import_layers.py``). The docs build draws the layers from the same graph (``docs/gen_pages.py``).
"""

from __future__ import annotations

import sys


def whole_namespace() -> None:
    """Let grimp see every installed portion of ``gym4real`` (core's folder and each domain's)."""
    import gym4real

    spec = gym4real.__spec__
    assert spec is not None and spec.submodule_search_locations is not None
    spec.submodule_search_locations[:] = list(gym4real.__path__)


if __name__ == "__main__":
    from importlinter.cli import lint_imports_command

    whole_namespace()
    lint_imports_command(sys.argv[1:], prog_name="lint-imports")
