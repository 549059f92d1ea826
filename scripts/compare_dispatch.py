"""Rerun a results section's test episodes under another CPU's kernels and compare them with ``episodes.csv``.

The dispatch settings stand in for another machine (``docs/robofeeder-determinism.md``): ``avx2-only`` forces
the kernels an AVX2 CPU without AVX-512 gets (an AMD EPYC Zen 1-3) from OpenBLAS, numpy, PyTorch, MKL and
oneDNN. Each published model's listed ``gym4real evaluate`` command runs in the page folder, and the
section's baselines run with ``gym4real bench``, each in a subprocess with the setting's variables; every
numeric column of every episode is compared to the bit with the section's rows. Prints a Markdown table.

Usage (from the repository root; ``MUJOCO_GL=egl OMP_NUM_THREADS=1 GYM4REAL_DATA_DIR=...`` as for the tests)::

    python scripts/compare_dispatch.py docs/results robofeeder-picking-v0-paper
    python scripts/compare_dispatch.py docs/results robofeeder-picking-v0-paper --setting default --seeds 0

Exits 1 when an episode differs.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from gym4real.bench.versions import cpu_model
from gym4real.rl.train import label

#: The variables of each setting (``default``: this machine's own choice).
SETTINGS: dict[str, dict[str, str]] = {
    "default": {},
    "avx2-only": {
        "OPENBLAS_CORETYPE": "Haswell",
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
        "ATEN_CPU_CAPABILITY": "avx2",
        "MKL_ENABLE_INSTRUCTIONS": "AVX2",
        "ONEDNN_MAX_CPU_ISA": "AVX2",
    },
}
_KEYS = ("policy", "seed", "episode")


def _run(command: list[str], cwd: Path, setting: str) -> None:
    env = {k: v for k, v in os.environ.items() if k not in SETTINGS["avx2-only"]} | SETTINGS[setting]
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    if done.returncode:
        sys.exit(f"`{shlex.join(command)}` failed:\n{done.stderr[-2000:]}")


def _relative(mine: pd.Series, theirs: pd.Series) -> float:
    """The largest ``|mine - theirs| / |theirs|`` (the absolute difference where ``theirs`` is 0)."""
    a, b = mine.to_numpy(dtype=float), theirs.to_numpy(dtype=float)
    scale = np.where(b == 0.0, 1.0, np.abs(b))
    return float(np.max(np.abs(a - b) / scale))


def _compare(label: str, mine: pd.DataFrame, theirs: pd.DataFrame) -> tuple[str, int]:
    """A table row: episodes compared, episodes with a differing column, the columns that differ.

    Each differing column is named with its count of episodes and its largest relative difference (what a
    model's stated ``agreement`` must cover).
    """
    mine, theirs = (f.sort_values("episode").reset_index(drop=True) for f in (mine, theirs))
    if len(mine) != len(theirs) or not len(mine):
        sys.exit(f"{label}: {len(mine)} episodes rerun, {len(theirs)} published")
    columns = [c for c in mine.columns if c in theirs.columns and c not in _KEYS and mine[c].dtype.kind in "fiub"]
    differ = pd.concat([mine[c] != theirs[c] for c in columns], axis=1)
    changed = [
        f"{c} ({int(differ[c].sum())}, up to {_relative(mine[c], theirs[c]):.1e})" for c in columns if differ[c].any()
    ]
    count = int(differ.any(axis=1).sum())
    return f"| {label} | {len(mine)} | {count} | {', '.join(changed) or 'none'} |", count


def main() -> None:
    """Rerun and compare as the module docstring says; exit 1 when an episode differs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("page", type=Path, help="the results folder (docs/results)")
    parser.add_argument("section", help="a section folder of it (robofeeder-picking-v0-paper)")
    parser.add_argument("--setting", choices=sorted(SETTINGS), default="avx2-only")
    parser.add_argument("--seeds", help="comma-separated seeds of the published models to rerun (default: all)")
    args = parser.parse_args()
    folder = args.page / args.section
    published = pd.read_csv(folder / "episodes.csv")
    env_id = json.loads((folder / "report.json").read_text())["env_id"]
    seeds = None if args.seeds is None else {int(s) for s in args.seeds.split(",")}
    rows, differing = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for model in json.loads((folder / "models.json").read_text()):
            if not model["published"] or (seeds is not None and model["seed"] not in seeds):
                continue
            out = Path(tmp) / f"{model['algo']}-{model['seed']}"
            _run(
                [*shlex.split(model["evaluate"].split(" (in the page folder)")[0]), "--out", str(out)],
                args.page,
                args.setting,
            )
            mine = pd.read_csv(out / "agent_episodes.csv")
            agent = label(model["algo"], model.get("trainer", "sb3"))  # its name in episodes.csv (ppo-jax, ...)
            theirs = published[(published["policy"] == agent) & (published["seed"] == model["seed"])]
            row, count = _compare(f"{agent} seed {model['seed']} (published model)", mine, theirs)
            rows.append(row)
            differing += count
        summary = pd.read_csv(folder / "summary.csv")
        baselines = summary.loc[summary["kind"] == "baseline", "policy"].tolist()
        out = Path(tmp) / "baselines"
        _run(
            ["gym4real", "bench", env_id, "--policies", ",".join(baselines), "--quiet", "--out", str(out)],
            Path.cwd(),
            args.setting,
        )
        mine = pd.read_csv(out / "episodes.csv")
        for policy in baselines:
            row, count = _compare(policy, mine[mine["policy"] == policy], published[published["policy"] == policy])
            rows.append(row)
            differing += count
    variables = " ".join(f"{k}={v}" for k, v in SETTINGS[args.setting].items()) or "no variables"
    print(f"{args.section} under `{args.setting}` ({variables}) on {cpu_model()}:\n")
    print("| rows | episodes | episodes that differ | columns that differ (episodes, largest relative difference) |")
    print("|---|---|---|---|")
    print("\n".join(rows))
    sys.exit(1 if differing else 0)


if __name__ == "__main__":
    main()
