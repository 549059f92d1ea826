"""Write one Markdown page per installed environment into docs/envs/ (then `mkdocs build`).

Each page opens, as Farama's environment pages do, with an episode of the env (an animated GIF, with
``--gifs``) beside a table of its spaces, reward terms and flags; then its description, presets,
datasets, baselines, protocol, docstring and the JSON schema of its configuration; when ``--figures DIR``
names a folder of ``gym4real bench`` results (``DIR/<env>/...png``, run on the test protocol: the committed
``docs/bench/``, which ``nox -s docs -- --refresh`` re-runs), the benchmark figures, each captioned with what
it shows (the policies, the episodes, the objective) from the run's ``results.json``; and the env's verdicts
on the paper's claims from the committed results page (``docs/results/index.md``). ``--pack-figures`` first
rewrites the two common figures with a palette of 128 colours (a quarter of their size, for committing them).

The GIF shows the env's best rule-based baseline: the protocol's baseline (other than ``random``) with
the best objective IQM (the score) in ``--figures`` results, else its first. It is recorded here (``gym4real
record``, no MP4) into the ignored ``docs/envs/gifs/``.

The Environments page lists every id, the multi-objective ones with their reward components. The home
page includes three snippets written into the ignored ``docs/snippets/`` (not pages of the site):
the gallery of the envs (their GIFs linking to their pages), the verdict table of the results page and
the citations (the suite's version read from gym4real-core's ``pyproject.toml``). The Architecture page's
figure, the layers of gym4real-core drawn from the import graph, goes into the ignored ``docs/diagrams/``.

    python docs/gen_pages.py [--figures docs/bench [--pack-figures]] [--gifs]
"""

from __future__ import annotations

import argparse
import inspect
import itertools
import json
import re
import shutil
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import pandas as pd

import gym4real
import gym4real.core.registry
from gym4real.bench.numbers import human, human_interval
from gym4real.bench.upper_label import label
from gym4real.core.registry import MARK, non_causal, registry, upper_reference
from gym4real.core.specs import FLAGS

DOCS = Path(__file__).resolve().parent
CORE = DOCS.parent / "packages" / "gym4real-core"
GIF_FRAMES = 60  # frames per GIF (evenly spaced steps, and the last)


def best_baseline(env_id: str, figures: Path | None) -> str:
    """The protocol's rule-based baseline with the best objective IQM in the bench results, else its first."""
    reg = registry()
    bench = reg.benchmarks.get(env_id)
    names = list(bench.policies) if bench else sorted(reg.baselines.get(env_id, {}))
    names = [n for n in names if n not in non_causal(env_id)]  # an upper reference knows the future
    candidates = [n for n in names if n != "random" and ":" not in n] or names
    summary = figures / env_id.replace("/", "_") / "summary.csv" if figures else None
    if summary is not None and summary.is_file():
        table = pd.read_csv(summary, index_col="policy")
        ranked = [
            n for n in table["objective_iqm"].sort_values(ascending=False, kind="stable").index if n in candidates
        ]
        if ranked:
            return str(ranked[0])
    return candidates[0]


def episode_gif(env_id: str, policy: str, steps: int) -> Path:
    """Record the first ``steps`` steps of the policy's seed-0 episode as a GIF in docs/envs/gifs/."""
    from gym4real.bench.record import record

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


def page(env_id: str, figures: Path | None, gif: tuple[Path, str, int] | None = None) -> str:
    """The env's page; ``gif`` is its recorded episode (the file, the baseline and the steps recorded)."""
    info = gym4real.env_info(env_id)
    reg = registry()
    env = gym.make(env_id)
    doc = inspect.cleandoc(type(env.unwrapped).__doc__ or "")
    schema = json.dumps(type(env.unwrapped.config).model_json_schema(), indent=1)
    flags = " · ".join(f"**{f.replace('_', ' ')}**" for f in FLAGS if info.flags[f]) or "none"
    lines = [f"# `{env_id}`", ""]
    if gif:
        path, policy, gif_steps = gif
        lines += [
            '<figure class="episode" markdown="span">',
            f"  ![{env_id}: an episode of the {policy} baseline](gifs/{path.name})",
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
    lines += [
        f"| `{b.name}` | {b.description}"
        + ("" if b.causal else f" (**{MARK}**, {b.bound_words()}: see [How far from optimal?](../headroom.md))")
        + " |"
        for b in baselines.values()
    ]
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
        lines += paper_results(env_id)
        lines += headroom_section(env_id, figures)
    if info.datasets or any(n.startswith(env_id.split("/")[1].split("-")[0] + "/") for n in reg.datasets):
        domain = env_id.split("/")[1].split("-")[0]
        lines += ["", "## Datasets", "", "| name | path | licence |", "|---|---|---|"]
        lines += [
            f"| `{d.name}` | `{d.path}` | {d.licence} |"
            for n, d in sorted(reg.datasets.items())
            if n.startswith(domain + "/")
        ]
    lines += mo_section(env_id)
    lines += ["", "## Documentation", "", doc.replace("\n## ", "\n### "), ""]
    if figures is not None:
        lines += _figures("Benchmark figures", figures / env_id.replace("/", "_"))
    lines += _reproduction(env_id)
    lines += ["## Configuration schema", "", "```json", schema, "```", ""]
    return "\n".join(lines)


def mo_section(env_id: str) -> list[str]:
    """The multi-objective evaluation of the env's vector-reward id: objectives, reference point, reference fronts."""
    from gym4real.bench.mo_reference import summary
    from gym4real.core.mo_spec import mo_ids, mo_spec

    found = [i for i in mo_ids() if registry().multi_objective[i] == env_id]
    if not found:
        return []
    mo_id = found[0]
    spec, record = mo_spec(mo_id), summary(mo_id) or {}
    lines = [
        "",
        "## Multi-objective evaluation",
        "",
        f"`{mo_id}` is scored on these objectives, each a sum over a test episode, maximised "
        f"(`gym4real evaluate --mo ... --envs {mo_id}`; see "
        "[Evaluate your agent](../evaluate.md#multi-objective-agents)):",
        "",
        "| objective | reward components | what it measures |",
        "|---|---|---|",
        *(f"| `{o.name}` | {' + '.join(f'`{c}`' for c in o.components)} | {o.description} |" for o in spec.objectives),
        "",
    ]
    if spec.left_out:
        lines += [f"Left out: {spec.left_out}.", ""]
    if "reference_point" not in record:
        return [*lines, f"No reference shipped: {record.get('reference', 'none')}.", ""]
    point = ", ".join(f"{v:.6g}" for v in record["reference_point"])
    top = ", ".join(f"{v:.6g}" for v in record["top"])
    lines += [
        f"Reference point ({point}): {record['reference_point_rule']}. Hypervolume and EUM are computed on the "
        f"normalised scale, the reference point at 0 and random's best test episode ({top}) at 1 per objective; "
        f"EUM over the {record['weights']['count']} weights of the {record['weights']['rule']}.",
        "",
        "| reference front | kind | hypervolume | EUM |",
        "|---|---|---|---|",
        *(
            f"| `{name}` | {f['kind']} | {f['hypervolume']:.4f} | {f['eum']:.4f} |"
            for name, f in record["reference_fronts"].items()
        ),
        "",
        "Fronts: " + "; ".join(f"`{s.name}`: {s.description}" for s in spec.sweeps) + ".",
    ]
    others = {n: f for n, f in record["reference_fronts"].items() if f["kind"] != "rule_based"}
    if others:
        lines += ["", *(f"`{name}` ({f['kind']}): {f['description']}." for name, f in others.items())]
    return lines


#: What each figure of ``gym4real bench`` shows, before the run it comes from.
FIGURE_WHAT = {
    "cumulative_reward.png": "Mean cumulative objective per {step_unit}, with its 95 % band",
    "returns_boxplot.png": "Distribution of the per-episode objective",
}


def figure_caption(png: str, run: dict[str, Any]) -> str:
    """The caption of a bench figure: what it shows, the policies, the episodes and the objective.

    A non-causal upper reference is named apart from the ranked policies, as the figures draw it.

    Args:
        png: The figure's file name.
        run: The bench run's ``results.json``.
    """
    protocol = run.get("protocol")
    if not isinstance(protocol, dict):
        raise SystemExit(f"`results.json` beside {png} has no `protocol`: rerun `gym4real bench` with this version")
    what = FIGURE_WHAT.get(png, f"<code>{png}</code>").format(step_unit=run.get("step_unit", "step"))
    where = f"the test protocol ({protocol['description']})" if protocol["test"] else str(protocol["description"])
    if not run["objective"]:
        objective = "the episode return (training reward)"
    elif run["objective_is_return"]:
        objective = f"{' + '.join(run['objective'])} per episode, the same quantity as the return (training reward)"
    else:
        objective = f"{' + '.join(run['objective'])} per episode (not the return, the training reward)"
    upper = set(non_causal(run["env_id"]))
    policies = ", ".join(f"<code>{p}</code>" for p in run["ranking"] if p not in upper)
    references = [f"<code>{p}</code>" for p in run["ranking"] if p in upper]
    apart = f"; then the {MARK} {', '.join(references)}, drawn apart (black star), not ranked" if references else ""
    return (
        f"{what}. Policies {policies}, best first by the IQM of the objective{apart}; {len(run['episodes'])} episodes "
        f"each, {where}. Objective: {objective}; higher is better."
    )


def paper_results(env_id: str) -> list[str]:
    """The env's committed results (``docs/results/<name>-paper/summary.csv``, the results page's numbers): each
    policy's IQM of the objective with its 95 % interval and its mean, the paper agents and baselines best first,
    the non-causal upper references last with their kind, not ranked; empty without a paper-budget section."""
    name = env_id.split("/")[-1]
    summary = DOCS / "results" / f"{name}-paper" / "summary.csv"
    if not summary.is_file():
        return []
    table = pd.read_csv(summary)
    upper = table["policy"].isin(non_causal(env_id))
    ranked = table[~upper].sort_values("iqm", ascending=False, kind="stable")
    rows = []
    for row in [*ranked.to_dict("records"), *table[upper].to_dict("records")]:
        policy = str(row["policy"])
        if policy in non_causal(env_id):
            shown, kind = f"`{policy}`{label(env_id, policy).removeprefix(policy)}", "upper reference, not ranked"
        else:
            shown = f"`{policy}`"
            kind = f"paper agent ({row['seeds']} seeds)" if row["kind"] == "agent" else "baseline"
        score = f"{human(row['iqm'])} {human_interval(row['low'], row['high'])}"
        rows.append(f"| {shown} | {kind} | {score} | {human(row['mean'])} |")
    return [
        "",
        "## Results of the paper's agents",
        "",
        f"The committed results of `gym4real reproduce {env_id} --budget paper` (the [results page]"
        f"(../results/index.md); raw data in `docs/results/{name}-paper/`): the IQM of the per-episode objective on "
        "the test protocol (a paper agent's training seeds pooled) with its 95 % bootstrap interval, and the mean; "
        f"best first, the {MARK} last, not ranked. `gym4real bench {env_id}` prints the paper agents' and upper "
        "references' rows under its own table.",
        "",
        "| policy | kind | IQM [95 % interval] | mean |",
        "|---|---|---|---|",
        *rows,
    ]


def headroom_section(env_id: str, figures: Path | None) -> list[str]:
    """The env page's headroom: its upper references, and their score beside the best rule-based baseline's
    when the bench results (``--figures``) hold both; empty without an upper reference."""
    upper = non_causal(env_id)
    bench = registry().benchmarks.get(env_id)
    if not upper or bench is None:
        return []
    rule = [b for b in bench.rule_based if b not in upper]
    command = f"gym4real bench {env_id} --policies {','.join([*upper, *rule])}"
    kinds = {u: upper_reference(env_id, u) for u in upper}
    said = "; ".join(
        f"`{u}` is **{spec.bound_words()}**: {spec.bound_note}"
        + (", so it bounds what a controller can score here" if spec.is_bound else ", so it bounds nothing")
        for u, spec in kinds.items()
    )
    lines = [
        "",
        "## Headroom",
        "",
        f"{', '.join(f'`{u}`' for u in upper)}: the {MARK}, which knows what no agent can know in advance. {said} "
        f"(see [How far from optimal?](../headroom.md)). `{command}` measures it.",
    ]
    summary = figures / env_id.replace("/", "_") / "summary.csv" if figures else None
    if summary is not None and summary.is_file():
        table = pd.read_csv(summary, index_col="policy")
        column = "objective_mean" if "objective_mean" in table else "mean"
        shown = [p for p in [*upper, *rule] if p in table.index]
        if any(u in shown for u in upper):
            lines += ["", "| policy | mean objective |", "|---|---|"]
            lines += [f"| `{p}` | {human(table.loc[p, column])} |" for p in shown]
    return lines


def _figures(title: str, folder: Path, intro: str = "") -> list[str]:
    """The PNGs of a bench results folder, copied next to the pages and captioned, under a heading.

    Nothing without PNGs.
    """
    pngs = sorted(folder.glob("*.png")) if folder.is_dir() else []
    if not pngs:
        return []
    run = json.loads((folder / "results.json").read_text())
    lines = [f"## {title}", ""] + ([intro, ""] if intro else [])
    target = DOCS / "envs" / "figures" / folder.name
    target.mkdir(parents=True, exist_ok=True)
    for png in pngs:
        shutil.copy(png, target / png.name)
        lines += [
            '<figure markdown="span">',
            f"  ![{png.stem}](figures/{folder.name}/{png.name})",
            f"  <figcaption>{figure_caption(png.name, run)}</figcaption>",
            "</figure>",
            "",
        ]
    return lines


def pack_figures(folder: Path, colours: int = 128) -> list[Path]:
    """Rewrite the two common figures of each bench results folder under ``folder`` with a palette of
    ``colours`` colours.

    ``gym4real bench``'s curves and boxes are drawn in a few flat colours and their blends: a palette keeps
    them as drawn to the eye at about a quarter of the bytes, which is what the committed ``docs/bench/``
    holds. A domain's own figures (a heatmap's continuous colour scale) are left as drawn, and so are figures
    packed already. Returns the figures it packed.
    """
    from PIL import Image

    packed = []
    for png in sorted(png for png in folder.glob("*/*.png") if png.name in FIGURE_WHAT):
        with Image.open(png) as image:
            if image.mode == "P":  # packed already: left byte for byte
                continue
            paletted = image.convert("RGB").quantize(colors=colours, method=Image.Quantize.MEDIANCUT)
        paletted.save(png, optimize=True)
        packed.append(png)
    return packed


#: The first cells of the results page's two verdict tables: the paper's claims, and the suite's own checks.
PAPER_CLAIMS, OWN_CHECKS = "| env | paper's claim |", "| env | check of this suite's own |"


def verdict_table(env_id: str | None = None, table: str = PAPER_CLAIMS) -> list[str]:
    """A verdict table of the results page (``docs/results/index.md``), the paper's claims' by default: its head
    and rows (one env's with ``env_id``); empty when the page has no row for it."""
    results = DOCS / "results" / "index.md"
    text = results.read_text(encoding="utf-8").splitlines() if results.is_file() else []
    head = [i for i, line in enumerate(text) if line.startswith(table)]
    if not head:
        return []
    env = re.escape(env_id.split("/")[-1]) if env_id else "[a-z0-9-]+"
    end = next((i for i in range(head[0], len(text)) if not text[i].startswith("|")), len(text))
    # an env's budget, when not a plain `paper`, is under its name
    rows = [line for line in text[head[0] + 2 : end] if re.match(rf"\| `{env}`(<br>[^|]*)? \|", line)]
    return [*text[head[0] : head[0] + 2], *rows] if rows else []


def suite_score_table() -> list[str]:
    """The suite-score table of the results page (each paper agent's score on the 0 = random, 1 = best rule scale)."""
    results = DOCS / "results" / "index.md"
    text = results.read_text(encoding="utf-8").splitlines() if results.is_file() else []
    head = [i for i, line in enumerate(text) if line.startswith("| agent | envs | runs | suite score")]
    if not head:
        return []
    end = next((i for i in range(head[0], len(text)) if not text[i].startswith("|")), len(text))
    return text[head[0] : end]


def _reproduction(env_id: str) -> list[str]:
    """The env's rows of the results page's verdict tables (the paper's claims, then the suite's own checks)."""
    claims, own = verdict_table(env_id), verdict_table(env_id, OWN_CHECKS)
    if not claims and not own:
        return []
    return [
        "## Reproduction",
        "",
        f"`gym4real reproduce {env_id}`: the paper's claims checked over training seeds; tables, learning curves "
        "and figures in the [reproduced results](../results/index.md).",
        "",
        *([*claims, ""] if claims else []),
        *([*own, ""] if own else []),
    ]


def environments_index(pages: dict[str, str]) -> str:
    """The Environments page: every id with its description, then the multi-objective ids' reward vectors.

    Args:
        pages: Each single-objective id's page file name (in ``docs/envs/``).
    """
    reg = registry()
    lines = ["# Environments", "", "| id | description |", "|---|---|"]
    lines += [f"| [`{i}`]({name}) | {reg.envs[i].description} |" for i, name in pages.items()]
    mo = {i: reg.multi_objective[i] for i in gym4real.list_envs() if i in reg.multi_objective}
    if mo:
        lines += [
            "",
            "## Multi-objective ids",
            "",
            "A vector reward, one entry per reward component of the env it wraps, in this order (the entries sum "
            "to that env's scalar reward); MO-Gymnasium's wrappers apply (extra `mo`).",
            "",
            "| id | wraps | reward vector |",
            "|---|---|---|",
        ]
        for mo_id, base in mo.items():
            env = gym.make(mo_id)
            names = ", ".join(f"`{c}`" for c in env.unwrapped.components)
            env.close()
            link = f"[`{base}`]({pages[base]})" if base in pages else f"`{base}`"
            lines.append(f"| `{mo_id}` | {link} | ({names}) |")
    return "\n".join(lines) + "\n"


def gallery(pages: dict[str, str], gifs: dict[str, Path]) -> str:
    """The home page's gallery: a card per env, its GIF (when recorded) and its id linking to its page."""
    reg = registry()
    lines = ['<div class="grid cards" markdown>', ""]
    for env_id, name in pages.items():
        card = f"-   [**`{env_id}`**](envs/{name})<br>{reg.envs[env_id].description}"
        if env_id in gifs:
            card = f"-   [![{env_id}](envs/gifs/{gifs[env_id].name})](envs/{name})\n\n    " + card.removeprefix("-   ")
        lines += [card, ""]
    return "\n".join([*lines, "</div>", ""])


def suite_version() -> tuple[str, str]:
    """gym4real-core's version (its ``pyproject.toml``) and the year of that release (its CHANGELOG)."""
    version = tomllib.loads((CORE / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]
    dated = re.search(rf"^## \[{re.escape(version)}\] - (\d{{4}})-", (CORE / "CHANGELOG.md").read_text(), re.M)
    if dated is None:
        raise SystemExit(f"{CORE / 'CHANGELOG.md'} has no dated section `## [{version}] - YYYY-MM-DD`: add it")
    return version, dated.group(1)


PAPER_BIBTEX = """@misc{salaorni2025gym4real,
  title  = {{Gym4ReaL}: A Suite for Benchmarking Real-World
            Reinforcement Learning},
  author = {Salaorni, Davide and De Paola, Vincenzo and Delpero, Samuele
            and Dispoto, Giovanni and Bonetti, Paolo and Russo, Alessio
            and Calcagno, Giuseppe and Trov{\\`o}, Francesco
            and Papini, Matteo and Metelli, Alberto Maria
            and Mussi, Marco and Restelli, Marcello},
  year   = {2025},
  eprint = {2507.00257},
  archivePrefix = {arXiv},
  url    = {https://arxiv.org/abs/2507.00257}
}"""


def citation() -> str:
    """The "How to cite" text: the BibTeX of the paper and of this suite at its current version."""
    version, year = suite_version()
    suite = "\n".join(
        [
            f"@software{{gym4real{year},",
            "  title   = {{gym4real}: Realistic Reinforcement-Learning Environments",
            "             with the {Gymnasium} API},",
            "  author  = {{gym4real contributors}},",
            f"  year    = {{{year}}},",
            f"  version = {{{version}}},",
            "  note    = {Python packages gym4real-core and gym4real-<domain>}",
            "}",
        ]
    )
    return "\n".join(
        [
            "Cite the paper for the environments and the suite, at the version you used, for this implementation:",
            "",
            "```bibtex",
            PAPER_BIBTEX,
            "```",
            "",
            "```bibtex",
            suite,
            "```",
            "",
        ]
    )


#: The layers of gym4real-core, top first, as ``.importlinter`` states them; then what sits beside them.
LINT_CONFIG = DOCS.parent / ".importlinter"


def _layers() -> list[str]:
    import configparser

    config = configparser.ConfigParser()
    config.read(LINT_CONFIG)
    return config["importlinter:contract:layers"]["layers"].split()


def _group_of(module: str, layers: list[str], domains: set[str]) -> str:
    """The layer of a module, else ``domains`` (a domain's plugin) or ``beside`` (wrappers, integrations, ...)."""
    for layer in layers:
        if module == layer or module.startswith(layer + "."):
            return layer
    return "domains" if module.split(".")[1] in domains else "beside"


def import_groups() -> tuple[list[str], dict[str, list[str]], dict[tuple[str, str], int]]:
    """The layers of gym4real-core, the modules of each group and the imports between groups.

    Read from the import graph of the installed code (grimp, as lint-imports reads it). The groups are the
    layers (top first), ``domains`` (the domains' plugins) and ``beside`` (wrappers, integrations, offline
    datasets); an edge ``(a, b): n`` counts the imports from modules of ``a`` into modules of ``b`` (every import
    that can run, deferred ones included).
    """
    import importlib.util

    import grimp

    spec = importlib.util.spec_from_file_location("lint_imports", DOCS.parent / "scripts" / "lint_imports.py")
    assert spec is not None and spec.loader is not None
    runner = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(runner)
    runner.whole_namespace()
    graph = grimp.build_graph("gym4real", cache_dir=None)
    layers = _layers()
    domains = {gym4real.core.registry.domain_of(env_id) for env_id in gym4real.list_envs()}
    group_of = {m: _group_of(m, layers, domains) for m in sorted(graph.modules) if m.count(".") >= 1}
    members: dict[str, list[str]] = {g: [] for g in [*layers, "domains", "beside"]}
    for module, group in group_of.items():
        members[group].append(module)
    edges: dict[tuple[str, str], int] = {}
    for module, group in group_of.items():
        for imported in graph.find_modules_directly_imported_by(module):
            if imported in group_of and group_of[imported] != group:
                pair = (group, group_of[imported])
                edges[pair] = edges.get(pair, 0) + 1
    return layers, members, edges


#: The Architecture figure's type sizes (points) and lengths (inches; one unit of its axes is one inch).
ARCH_TITLE_PT, ARCH_TEXT_PT, ARCH_COUNT_PT = 10.0, 8.0, 8.0
ARCH_STACK_W, ARCH_SIDE_W, ARCH_GAP_X, ARCH_GAP_Y, ARCH_PAD = 5.4, 3.2, 2.2, 0.5, 0.1
ARCH_LINE, ARCH_TITLE_LINE = ARCH_TEXT_PT * 1.4 / 72, ARCH_TITLE_PT * 1.6 / 72
ARCH_LANE = 0.28  # the spacing (inches) of the vertical lanes left of the stack that carry the arrows between layers

Edge = tuple[str, str]
Point = tuple[float, float]


class ArchBox(NamedTuple):
    """A box of the Architecture figure: its lower-left corner, size (inches), title and lines of modules."""

    x: float
    y: float
    w: float
    h: float
    title: str
    lines: list[str]


def _text_width(text: str, size: float, weight: str = "normal") -> float:
    """The width in inches of one line of text at ``size`` points, as matplotlib's Agg renderer draws it."""
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    width, _, _ = RendererAgg(1, 1, 72).get_text_width_height_descent(
        text, FontProperties(size=size, weight=weight), ismath=False
    )
    return float(width) / 72


def _wrapped(names: list[str], width: float, size: float) -> list[str]:
    """``names`` joined by commas into lines no wider than ``width`` inches, a name never split; 5 % to spare
    for a browser's rendering of the SVG's text."""
    lines: list[str] = []
    line = ""
    for name in names:
        candidate = f"{line}, {name}" if line else name
        if line and _text_width(candidate + ",", size) > 0.95 * width:
            lines.append(line + ",")
            line = name
        else:
            line = candidate
    return [*lines, line] if line else lines


def arch_boxes(layers: list[str], members: dict[str, list[str]]) -> dict[str, ArchBox]:
    """The boxes: the layers stacked top first from y = 0, the domains' plugins right of the plugin host and
    the packages beside the layers right of measurement, each tall enough for its wrapped list of modules."""
    titles = {"domains": "domains (plugins)", "beside": "beside the layers"}
    sized: dict[str, tuple[float, str, list[str]]] = {}
    for group, modules in members.items():
        depth = 2 if group in ("domains", "beside") else 3
        names = sorted({".".join(m.split(".")[:depth]) for m in modules} - {group})
        short = [n.removeprefix(group + ".").removeprefix("gym4real.") for n in names if "._" not in n]
        width = ARCH_STACK_W if group in layers else ARCH_SIDE_W
        title = f"{titles.get(group, group)} ({len(modules)} modules)"
        sized[group] = (width, title, _wrapped(short, width - 2 * ARCH_PAD, ARCH_TEXT_PT))
    boxes: dict[str, ArchBox] = {}
    top = 0.0
    for layer in layers:
        width, title, lines = sized[layer]
        height = 2 * ARCH_PAD + ARCH_TITLE_LINE + ARCH_LINE * len(lines)
        top -= height
        boxes[layer] = ArchBox(0.0, top, width, height, title, lines)
        top -= ARCH_GAP_Y
    side_x = ARCH_STACK_W + ARCH_GAP_X
    for group, beside in (("domains", layers[-1]), ("beside", layers[-2])):  # the host, whose API they use; bench
        width, title, lines = sized[group]
        height = 2 * ARCH_PAD + ARCH_TITLE_LINE + ARCH_LINE * len(lines)
        y = boxes[beside].y + (boxes[beside].h - height) / 2
        if group == "beside":  # above the domains' box
            y = max(y, boxes["domains"].y + boxes["domains"].h + ARCH_GAP_Y)
        boxes[group] = ArchBox(side_x, y, width, height, title, lines)
    return boxes


def _spread(ends: Sequence[tuple[Any, float]], low: float, height: float) -> dict[Any, float]:
    """Heights for the ends of arrows on one edge, spread over ``[low, low + height]`` in their keys' order."""
    ordered = sorted(ends, key=lambda item: item[1])
    return {end: low + height * (i + 1) / (len(ordered) + 1) for i, (end, _) in enumerate(ordered)}


def _lanes(spans: dict[Edge, tuple[float, float]]) -> dict[Edge, int]:
    """A lane per arrow between layers (0 nearest the stack): the shorter ones inside, and two arrows in one
    lane only where their heights ``(low, high)`` lie a gap between boxes apart (never seeming one arrow)."""
    lanes: dict[Edge, int] = {}
    for e, (low, high) in sorted(spans.items(), key=lambda item: item[1][1] - item[1][0]):
        near = [o for o in lanes if spans[o][0] < high + ARCH_GAP_Y and low - ARCH_GAP_Y < spans[o][1]]
        taken = {lanes[o] for o in near}
        lanes[e] = min(set(range(len(spans) + 1)) - taken)
    return lanes


def arch_arrows(layers: list[str], boxes: dict[str, ArchBox], edges: dict[Edge, int]) -> dict[Edge, list[Point]]:
    """Each edge's arrow as a polyline, from its source box's edge to its target's, ending on no other box.

    Between layers: out of a box's left edge, down a lane of its own left of the stack, into the target's left
    edge; a box's arrows leave its lower half (the nearest target lowest) and enter its upper half (the
    farthest source lowest), a box that only sends or only receives spreading them over its whole edge, so
    that the lanes nest. Between the stack and a side box: straight across the gap, on the facing edges,
    ordered by the other end's height. Between the side boxes: straight up or down between their facing edges.
    """
    ends: dict[tuple[Edge, int], Point] = {}  # (edge, 0) its start, (edge, 1) its end
    centre = {g: b.y + b.h / 2 for g, b in boxes.items()}
    down = [e for e in edges if e[0] in layers and e[1] in layers]
    across = [e for e in edges if (e[0] in layers) != (e[1] in layers)]
    for group, box in boxes.items():
        if group in layers:
            leaving = [((e, 0), layers.index(e[1])) for e in down if e[0] == group]
            entering = [((e, 1), layers.index(e[0])) for e in down if e[1] == group]
            split = box.y + box.h / 2 if leaving and entering else box.y + box.h * (not entering)
            ends |= {k: (box.x, v) for k, v in _spread(leaving, box.y, split - box.y).items()}
            ends |= {k: (box.x, v) for k, v in _spread(entering, split, box.y + box.h - split).items()}
        facing = box.x + box.w if group in layers else box.x
        side = [((e, e.index(group)), centre[e[1 - e.index(group)]]) for e in across if group in e]
        ends |= {k: (facing, v) for k, v in _spread(side, box.y, box.h).items()}
    for e in edges:
        if e[0] not in layers and e[1] not in layers:
            source, target = boxes[e[0]], boxes[e[1]]
            up = source.y < target.y
            ends[e, 0] = (source.x + source.w / 2, source.y + source.h if up else source.y)
            ends[e, 1] = (target.x + target.w / 2, target.y if up else target.y + target.h)
    lanes = _lanes({e: (ends[e, 1][1], ends[e, 0][1]) for e in down})
    arrows = {e: [ends[e, 0], ends[e, 1]] for e in edges}
    for e, lane in lanes.items():
        (x0, y0), (x1, y1) = ends[e, 0], ends[e, 1]
        x = min(x0, x1) - ARCH_LANE * (lane + 1)
        arrows[e] = [(x0, y0), (x, y0), (x, y1), (x1, y1)]
    return arrows


def arch_points(polyline: list[Point], step: float = 0.01) -> Any:
    """Points along a polyline, ``step`` inches apart at most (its corners included)."""
    import numpy as np

    parts = [np.array(polyline[:1], dtype=float)]
    for a, b in itertools.pairwise(polyline):
        n = max(1, int(np.ceil(np.hypot(b[0] - a[0], b[1] - a[1]) / step)))
        parts.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(parts)


def _count_places(
    arrows: dict[Edge, list[Point]], edges: dict[Edge, int], boxes: dict[str, ArchBox]
) -> dict[Edge, Point]:
    """Where each arrow's count goes: on its longest segment, as near that segment's middle as it can while
    covering no other arrow, no box (nor the arrow heads at its edges) and no other count."""
    import numpy as np

    taken = [(b.x - 0.12, b.y - 0.12, b.x + b.w + 0.12, b.y + b.h + 0.12) for b in boxes.values()]
    places: dict[Edge, Point] = {}
    for e, polyline in arrows.items():
        half_w, half_h = _text_width(str(edges[e]), ARCH_COUNT_PT) / 2 + 0.04, ARCH_COUNT_PT / 144 + 0.03
        others = np.concatenate([arch_points(p) for k, p in arrows.items() if k != e])
        a, b = max(itertools.pairwise(polyline), key=lambda ab: np.hypot(*np.subtract(ab[1], ab[0])))
        for t in (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.1, 0.9):
            x, y = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
            rect = (x - half_w, y - half_h, x + half_w, y + half_h)
            covered = (np.abs(others[:, 0] - x) < half_w) & (np.abs(others[:, 1] - y) < half_h)
            if not covered.any() and not any(
                rect[0] < r[2] and r[0] < rect[2] and rect[1] < r[3] and r[1] < rect[3] for r in taken
            ):
                break
        taken.append(rect)
        places[e] = (float(x), float(y))
    return places


def draw_architecture(layers: list[str], members: dict[str, list[str]], edges: dict[Edge, int]) -> Any:
    """The Architecture figure (a matplotlib figure of one axes, one unit an inch): one box per layer (top:
    the command; bottom: the plugin host) listing its modules, a box of the domains' plugins and one of the
    packages beside the layers, and an arrow per pair of boxes labelled with its number of imports."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib import patches
    from matplotlib.path import Path as MplPath

    boxes = arch_boxes(layers, members)
    arrows = arch_arrows(layers, boxes, edges)
    counts = _count_places(arrows, edges, boxes)
    points = np.concatenate([*arrows.values(), [(b.x + b.w, b.y) for b in boxes.values()]])
    left, right = points[:, 0].min() - 0.3, points[:, 0].max() + 0.1
    bottom, top = points[:, 1].min() - 0.1, 0.5  # the title above the boxes
    fig = plt.figure(figsize=(right - left, top - bottom))
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_axis_off()
    ax.set_xlim(left, right)
    ax.set_ylim(bottom, top)
    title = "The layers of gym4real-core; each arrow: the number of imports from one box into another"
    ax.text((left + right) / 2, 0.25, title, size=11, ha="center", va="center")
    for group, box in boxes.items():
        colour = "#e8f0fb" if group in layers else "#f3f3f3"
        ax.add_patch(patches.FancyBboxPatch((box.x, box.y), box.w, box.h, boxstyle="round,pad=0.02", facecolor=colour))
        x, y = box.x + ARCH_PAD, box.y + box.h - ARCH_PAD
        ax.text(x, y, box.title, size=ARCH_TITLE_PT, weight="bold", va="top")
        if box.lines:
            ax.text(x, y - ARCH_TITLE_LINE, "\n".join(box.lines), size=ARCH_TEXT_PT, va="top", linespacing=1.4)
    white = {"facecolor": "white", "edgecolor": "none", "pad": 0.5}
    for e, polyline in arrows.items():
        arrow = patches.FancyArrowPatch(
            path=MplPath(polyline), arrowstyle="-|>", mutation_scale=9, shrinkA=0, shrinkB=0
        )
        arrow.set(color="#4a5a70", linewidth=0.9)
        ax.add_patch(arrow)
        ax.text(*counts[e], str(edges[e]), size=ARCH_COUNT_PT, ha="center", va="center", bbox=white)
    return fig


def architecture_figure(path: Path) -> Path:
    """Draw the layers of gym4real-core from the import graph of the installed code into ``path`` (an SVG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    matplotlib.rcParams["svg.fonttype"] = "none"  # the names stay text in the SVG (searchable, selectable)
    fig = draw_architecture(*import_groups())
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, help="folder of gym4real bench results, one subfolder per env")
    parser.add_argument(
        "--pack-figures", action="store_true", help="rewrite the common figures of --figures with a palette"
    )
    parser.add_argument("--gifs", action="store_true", help="record an episode GIF of each env's best baseline")
    parser.add_argument("--gif-steps", type=int, default=360, help="steps of the recorded episode at most")
    args = parser.parse_args()
    if args.pack_figures:
        if args.figures is None:
            parser.error("--pack-figures rewrites the PNGs of --figures DIR: name the folder")
        print(f"packed {len(pack_figures(args.figures))} figures of {args.figures}")
    out, snippets = DOCS / "envs", DOCS / "snippets"
    for folder in (out, snippets):
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir()
    pages = {env_id: env_id.replace("/", "_") + ".md" for env_id in gym4real.list_envs(multi_objective=False)}
    gifs: dict[str, Path] = {}
    for env_id, name in pages.items():
        gif = None
        if args.gifs:
            policy = best_baseline(env_id, args.figures)
            gifs[env_id] = episode_gif(env_id, policy, args.gif_steps)
            gif = (gifs[env_id], policy, args.gif_steps)
        (out / name).write_text(page(env_id, args.figures, gif))
    (out / "index.md").write_text(environments_index(pages))
    (snippets / "gallery.md").write_text(gallery(pages, gifs))
    (snippets / "verdicts.md").write_text("\n".join([*verdict_table(), ""]))
    scores = suite_score_table()
    intro = "Suite score of the paper agents (0 = `random`, 1 = the env's best rule-based baseline; details on the "
    (snippets / "suite-score.md").write_text(
        "\n".join([intro + "[results page](results/index.md#suite-score-of-the-paper-agents)):", "", *scores, ""])
        if scores
        else "No paper-budget run on the results page yet: no suite score.\n"
    )
    (snippets / "cite.md").write_text(citation())
    architecture_figure(DOCS / "diagrams" / "architecture.svg")
    print(f"wrote {len(pages)} environment pages to {out} and the home page's snippets to {snippets}")


if __name__ == "__main__":
    main()
