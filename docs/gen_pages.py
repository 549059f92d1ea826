"""Write one Markdown page per installed environment into docs/envs/ (then `mkdocs build`).

Each page opens, as Farama's environment pages do, with an episode of the env (an animated GIF, with
``--gifs``) beside a table of its spaces, reward terms and flags; then its description, presets,
datasets, baselines, protocol, docstring and the JSON schema of its configuration; when ``--figures DIR``
names a folder of ``gym4real bench`` results (``DIR/<env>/...png``), the benchmark figures; and the env's
verdicts on the paper's claims from the committed results page (``docs/results/index.md``).

The GIF shows the env's best rule-based baseline: the protocol's baseline (other than ``random``) with
the best mean objective in ``--figures`` results, else its first. It is recorded here (``gym4real
record``, no MP4) into the ignored ``docs/envs/gifs/``.

    python docs/gen_pages.py [--figures results/docs] [--gifs]
"""

from __future__ import annotations

import argparse
import inspect
import json
import shutil
from pathlib import Path

import gymnasium as gym
import pandas as pd

import gym4real
from gym4real.core.registry import registry
from gym4real.core.specs import FLAGS

DOCS = Path(__file__).resolve().parent
GIF_FRAMES = 60  # frames per GIF (evenly spaced steps, and the last)


def best_baseline(env_id: str, figures: Path | None) -> str:
    """The protocol's rule-based baseline with the best mean objective in the bench results, else its first."""
    reg = registry()
    bench = reg.benchmarks.get(env_id)
    names = list(bench.policies) if bench else sorted(reg.baselines.get(env_id, {}))
    candidates = [n for n in names if n != "random" and ":" not in n] or names
    summary = figures / env_id.replace("/", "_") / "summary.csv" if figures else None
    if summary is not None and summary.is_file():
        table = pd.read_csv(summary, index_col="policy")
        score = table["objective_mean"] if "objective_mean" in table else table["mean"]
        ranked = [n for n in score.sort_values(ascending=False).index if n in candidates]
        if ranked:
            return str(ranked[0])
    return candidates[0]


def episode_gif(env_id: str, policy: str, steps: int) -> Path:
    """Record the first ``steps`` steps of the policy's seed-0 episode as a GIF in docs/envs/gifs/."""
    from gym4real.core.record import record

    (gif,) = record(
        env_id, policy, out=DOCS / "envs" / "gifs", max_steps=steps, mp4=False, gif_frames=GIF_FRAMES, progress=False
    )
    return gif


def _space(space: gym.Space) -> str:
    """A space as one table cell: its repr on one line, or its type, shape and dtype when that is long."""
    text = " ".join(str(space).split())
    if len(text) > 120 and isinstance(space, gym.spaces.Box):
        return f"`Box(shape={space.shape}, {space.dtype})` (bounds per feature: see Observation Space)"
    return f"`{text}`".replace("|", "\\|")


def _summary(env: gym.Env, env_id: str, flags: str) -> list[str]:
    """The table beside the GIF: spaces, reward terms, flags, episode length and the call."""
    raw = env.unwrapped
    terms = getattr(raw, "reward_component_names", ())
    limit = env.spec.max_episode_steps if env.spec else None
    rows = [
        ("Make", f'`gymnasium.make("{env_id}")`'),
        ("Action space", _space(env.action_space)),
        ("Observation space", _space(env.observation_space)),
        ("Reward terms", ", ".join(f"`{t}`" for t in terms) or "the reward"),
        ("Render modes", ", ".join(f"`{m}`" for m in raw.metadata.get("render_modes", ())) or "none"),
        ("Table-1 flags", flags),
        ("Time limit", f"{limit} steps" if limit else "set by the env (see Episode End)"),
    ]
    head, *body = (f"| {k} | {v} |" for k, v in rows)
    return [head, "|---|---|", *body, ""]


def page(env_id: str, figures: Path | None, gif_steps: int | None = None) -> str:
    info = gym4real.env_info(env_id)
    reg = registry()
    env = gym.make(env_id)
    doc = inspect.cleandoc(type(env.unwrapped).__doc__ or "")
    schema = json.dumps(type(env.unwrapped.config).model_json_schema(), indent=1)
    flags = " · ".join(f"**{f.replace('_', ' ')}**" for f in FLAGS if info.flags[f]) or "none"
    lines = [f"# `{env_id}`", ""]
    if gif_steps:
        policy = best_baseline(env_id, figures)
        gif = episode_gif(env_id, policy, gif_steps)
        lines += [
            '<figure class="episode" markdown="span">',
            f"  ![{env_id}: an episode of the {policy} baseline](gifs/{gif.name})",
            f"  <figcaption>The <code>{policy}</code> baseline, seed 0, first {gif_steps} steps at most</figcaption>",
            "</figure>",
            "",
        ]
    lines += _summary(env, env_id, flags)
    env.close()
    lines += [
        info.description,
        "",
        f"Distribution `{info.distribution}` {info.version}.",
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
        lines += _figures("Benchmark figures", figures / env_id.replace("/", "_"))
    lines += _reproduction(env_id)
    lines += ["## Configuration schema", "", "```json", schema, "```", ""]
    return "\n".join(lines)


def _figures(title: str, folder: Path, intro: str = "") -> list[str]:
    """The PNGs of a results folder, copied next to the pages, under a heading (nothing without PNGs)."""
    pngs = sorted(folder.glob("*.png")) if folder.is_dir() else []
    if not pngs:
        return []
    lines = [f"## {title}", ""] + ([intro, ""] if intro else [])
    target = DOCS / "envs" / "figures" / folder.name
    target.mkdir(parents=True, exist_ok=True)
    for png in pngs:
        shutil.copy(png, target / png.name)
        lines += [f"![{png.stem}](figures/{folder.name}/{png.name})", ""]
    return lines


def _reproduction(env_id: str) -> list[str]:
    """The env's rows of the results page's verdict table (``docs/results/index.md``), when it has some."""
    results = DOCS / "results" / "index.md"
    text = results.read_text(encoding="utf-8").splitlines() if results.is_file() else []
    rows = [line for line in text if line.startswith(f"| `{env_id.split('/')[-1]}` |")]
    if not rows:
        return []
    return [
        "## Reproduction",
        "",
        f"`gym4real reproduce {env_id}`: the paper's claims checked over training seeds; tables, learning curves "
        "and figures in the [reproduced results](../results/index.md).",
        "",
        *text[text.index(next(line for line in text if line.startswith("| env | budget |"))) :][:2],
        *rows,
        "",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, help="folder of gym4real bench results, one subfolder per env")
    parser.add_argument("--gifs", action="store_true", help="record an episode GIF of each env's best baseline")
    parser.add_argument("--gif-steps", type=int, default=360, help="steps of the recorded episode at most")
    args = parser.parse_args()
    out = DOCS / "envs"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    index = ["# Environments", "", "| id | description |", "|---|---|"]
    for env_id in gym4real.list_envs(multi_objective=False):
        name = env_id.replace("/", "_") + ".md"
        (out / name).write_text(page(env_id, args.figures, args.gif_steps if args.gifs else None))
        index.append(f"| [`{env_id}`]({name}) | {registry().envs[env_id].description} |")
    (out / "index.md").write_text("\n".join(index) + "\n")
    print(f"wrote {len(index) - 4} environment pages to {out}")


if __name__ == "__main__":
    main()
