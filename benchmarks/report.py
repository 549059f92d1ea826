"""What every benchmark script prints and saves: a Markdown table of its rows, and the rows as JSON."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any


def report(rows: Sequence[dict[str, Any]], cols: Sequence[str], digits: int, json_path: str | None) -> None:
    """Print ``rows`` as a Markdown table of ``cols`` (floats to ``digits`` significant digits); save them as JSON."""
    print(" | ".join(cols))
    print(" | ".join("---" for _ in cols))
    for r in rows:
        print(" | ".join(f"{r[c]:.{digits}g}" if isinstance(r[c], float) else str(r[c]) for c in cols))
    if json_path:
        with open(json_path, "w") as f:
            json.dump(list(rows), f, indent=1)
