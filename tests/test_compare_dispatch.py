"""``scripts/compare_dispatch.py``: a section's episodes rerun under AVX2-only kernels, compared to the bit."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).parents[1]
SECTION = "elevator-v0-paper"  # the cheapest section with published models (Q-tables): about 20 s


def test_a_changed_episode_is_the_one_reported_and_the_others_equal(tmp_path: Path) -> None:
    """Every row but the one changed in ``episodes.csv`` reruns bit for bit; the changed one is named, exit 1."""
    shutil.copytree(ROOT / "docs" / "results" / SECTION, tmp_path / SECTION)
    episodes = pd.read_csv(tmp_path / SECTION / "episodes.csv")
    changed = episodes.index[episodes["policy"] == "longest_first"][3]
    episodes.loc[changed, "return"] += 1.0
    relative = 1.0 / abs(episodes.loc[changed, "return"])  # the rerun's difference from the changed number
    episodes.to_csv(tmp_path / SECTION / "episodes.csv", index=False)
    script = [sys.executable, str(ROOT / "scripts" / "compare_dispatch.py"), str(tmp_path), SECTION, "--seeds", "42"]
    bin_dir = str(Path(sys.executable).parent)  # the `gym4real` command of this environment
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"}
    done = subprocess.run(script, capture_output=True, text=True, env=env, check=False, timeout=600)
    assert done.returncode == 1, done.stderr[-2000:]
    rows = {line.split(" | ")[0].strip("| "): line for line in done.stdout.splitlines() if line.startswith("| ")}
    assert rows["longest_first"] == f"| longest_first | 30 | 1 | return (1, up to {relative:.1e}) |"
    for label in ("qlearning seed 42 (published model)", "sarsa seed 42 (published model)", "random", "hindsight"):
        assert rows[label].endswith("| 30 | 0 | none |"), rows[label]
