"""The committed results page and the README's verdict table come from the same reproduce run."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def _verdict_rows(text: str) -> list[str]:
    return [line for line in text.splitlines() if re.match(r"\| `[a-z0-9-]+` \| (paper|quick) \|", line)]


def test_the_readme_verdicts_are_the_results_pages() -> None:
    readme = _verdict_rows((ROOT / "README.md").read_text(encoding="utf-8"))
    page = _verdict_rows((ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8"))
    assert readme and readme == page


def test_every_figure_the_results_page_shows_is_committed() -> None:
    page = ROOT / "docs" / "results"
    links = re.findall(r"\]\((figures/[^)]+\.png)\)", (page / "index.md").read_text(encoding="utf-8"))
    assert links
    for link in links:
        assert (page / link).read_bytes()[:4] == b"\x89PNG", link


def test_each_env_page_shows_its_verdicts_from_the_results_page(load_script: Callable[[Path], ModuleType]) -> None:
    gen_pages = load_script(ROOT / "docs" / "gen_pages.py")
    page = _verdict_rows((ROOT / "docs" / "results" / "index.md").read_text(encoding="utf-8"))
    for env_id in ("gym4real/dam-v0", "gym4real/wds-v0"):
        section = gen_pages._reproduction(env_id)
        assert section[0] == "## Reproduction" and "(../results/index.md)" in section[2]
        name = env_id.split("/")[-1]
        assert _verdict_rows("\n".join(section)) == [row for row in page if row.startswith(f"| `{name}` |")]
    assert gen_pages._reproduction("gym4real/no-such-v0") == []
