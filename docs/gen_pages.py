"""Write one Markdown page per installed environment into docs/envs/ (then `mkdocs build`).

Each page holds the env's docstring, its Table-1 flags, presets, datasets, baselines, protocol, the
JSON schema of its configuration and, when ``--figures DIR`` names a folder of ``gym4real bench``
results (``DIR/<env>/...png``), the benchmark figures.

    python docs/gen_pages.py [--figures results]
"""

from __future__ import annotations

import argparse
import inspect
import json
import shutil
from pathlib import Path

import gymnasium as gym

import gym4real
from gym4real.core.registry import registry
from gym4real.core.specs import FLAGS

DOCS = Path(__file__).resolve().parent


def page(env_id: str, figures: Path | None) -> str:
    info = gym4real.env_info(env_id)
    reg = registry()
    env = gym.make(env_id)
    doc = inspect.cleandoc(type(env.unwrapped).__doc__ or "")
    schema = json.dumps(type(env.unwrapped.config).model_json_schema(), indent=1)
    env.close()
    flags = " · ".join(f"**{f.replace('_', ' ')}**" for f in FLAGS if info.flags[f]) or "none"
    lines = [
        f"# `{env_id}`",
        "",
        info.description,
        "",
        f"Distribution `{info.distribution}` {info.version}.",
        "",
        f"Table-1 flags: {flags}",
        "",
        f"Presets: {', '.join(f'`{p}`' for p in info.presets)}",
        "",
    ]
    baselines = reg.baselines.get(env_id, {})
    lines += ["## Baselines", "", "| name | description |", "|---|---|"]
    lines += [f"| `{b.name}` | {b.description} |" for b in baselines.values()]
    bench = reg.benchmarks.get(env_id)
    if bench:
        lines += [
            "",
            "## Evaluation protocol",
            "",
            bench.description or "",
            "",
            f"`gym4real bench {env_id}` (policies {', '.join(bench.policies)}).",
        ]
    if info.datasets or any(n.startswith(env_id.split("/")[1].split("-")[0] + "/") for n in reg.datasets):
        domain = env_id.split("/")[1].split("-")[0]
        lines += ["", "## Datasets", "", "| name | path | licence |", "|---|---|---|"]
        lines += [
            f"| `{d.name}` | `{d.path}` | {d.licence} |"
            for n, d in sorted(reg.datasets.items())
            if n.startswith(domain + "/")
        ]
    lines += ["", "## Documentation", "", doc.replace("\n## ", "\n### "), ""]
    if figures is not None:
        folder = figures / env_id.replace("/", "_")
        pngs = sorted(folder.glob("*.png")) if folder.is_dir() else []
        if pngs:
            lines += ["## Benchmark figures", ""]
            target = DOCS / "envs" / "figures" / folder.name
            target.mkdir(parents=True, exist_ok=True)
            for png in pngs:
                shutil.copy(png, target / png.name)
                lines += [f"![{png.stem}](figures/{folder.name}/{png.name})", ""]
    lines += ["## Configuration schema", "", "```json", schema, "```", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, help="folder of gym4real bench results, one subfolder per env")
    args = parser.parse_args()
    out = DOCS / "envs"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    index = ["# Environments", "", "| id | description |", "|---|---|"]
    for env_id in gym4real.list_envs():
        name = env_id.replace("/", "_") + ".md"
        (out / name).write_text(page(env_id, args.figures))
        index.append(f"| [`{env_id}`]({name}) | {registry().envs[env_id].description} |")
    (out / "index.md").write_text("\n".join(index) + "\n")
    print(f"wrote {len(gym4real.list_envs())} environment pages to {out}")


if __name__ == "__main__":
    main()
