"""Rewrite the ``manifest.json`` of a rendered results folder from its files, keeping what its rendering found.

After an edit of published files that the page's text does not show (a model's ``note`` in a section's
``models.json``), or to record what a newer renderer records (every file's SHA-256, each section's machines),
without rendering the page again: :func:`gym4real.results.results_page.refresh_manifest`. Then
``gym4real reproduce --check`` verifies the folder against the rewritten manifest.

Usage: ``python scripts/refresh_manifest.py docs/results``
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gym4real.results.results_page import refresh_manifest


def main() -> None:
    """Refresh the manifest of each folder named on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="rendered results folders (docs/results)")
    for folder in parser.parse_args().folders:
        print(f"wrote {refresh_manifest(folder)}")


if __name__ == "__main__":
    main()
