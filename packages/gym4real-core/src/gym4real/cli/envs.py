"""``gym4real list`` and ``gym4real info``: the installed environments and what each one is."""

from __future__ import annotations

import argparse
import inspect
import json
import re
import sys
import textwrap
from dataclasses import asdict
from typing import Any

import numpy as np

from gym4real.cli.common import ENV_ID_HELP, command
from gym4real.core.info import env_info
from gym4real.core.registry import base_env, registry


def _list(args: argparse.Namespace) -> None:
    from gym4real.core.install_hint import pip_install, unmet_requirements
    from gym4real.core.registry import list_envs, plugin_errors, registry

    reg = registry()
    unmet = {plugin: unmet_requirements(dist) for plugin, dist in reg.metadata.items()}
    for env_id in list_envs():
        plugin = reg.owners[env_id]
        if missing := unmet.get(plugin):
            dist = reg.distributions[plugin][0]
            what = f"unavailable: {dist} needs {', '.join(missing)}, not installed here: `{pip_install(missing)}`"
        else:
            what = reg.envs[env_id].description
        print(f"{env_id:34s} {what}")
    for err in plugin_errors():
        print(f"(unavailable) {err}", file=sys.stderr)


def _info(args: argparse.Namespace) -> None:
    record = summary(args.env_id)
    print(json.dumps(record, indent=2, default=str) if args.json else summary_text(record))


def docstring_section(doc: str, title: str) -> str:
    """The text of a ``## <title>`` section of a Gymnasium-style env docstring, on one line ('' if absent)."""
    lines = inspect.cleandoc(doc).splitlines()
    heading = f"## {title}".lower()
    start = next((i + 1 for i, line in enumerate(lines) if line.strip().lower() == heading), None)
    if start is None:
        return ""
    end = next((i for i in range(start, len(lines)) if lines[i].startswith("## ")), len(lines))
    return " ".join(" ".join(lines[start:end]).split())


def space_text(space: Any) -> str:
    """A space as ``str()`` gives it, a long Box by its bounds' range: ``Box(-33.5..254, (27,), float32)``."""
    import gymnasium as gym

    if isinstance(space, gym.spaces.Box) and space.shape and int(np.prod(space.shape)) > 6:
        same = all(np.all(bound == bound.flat[0]) for bound in (space.low, space.high))  # infinite bounds too
        varied = "" if same else "; bounds vary by entry"
        return f"Box({space.low.min():g}..{space.high.max():g}, {space.shape}, {space.dtype}{varied})"
    return str(space)


def env_interface(env_id: str) -> dict[str, Any]:
    """What an instance of the env (default preset) shows: its spaces, time limit and how an episode ends.

    Raises:
        Gym4RealError: The env cannot be made (a missing data file, a missing dependency): its error.
    """
    import gymnasium as gym

    env = gym.make(env_id)
    try:
        out: dict[str, Any] = {
            "observation_space": space_text(env.observation_space),
            "action_space": space_text(env.action_space),
        }
        if env.spec is not None and env.spec.max_episode_steps is not None:
            out["max_episode_steps"] = env.spec.max_episode_steps
        if env.has_wrapper_attr("reward_space"):
            out["reward_space"] = str(env.get_wrapper_attr("reward_space"))
        # a vector reward's entries in order (its `components`), else the terms that sum to the scalar reward
        terms = getattr(env.unwrapped, "components", None) or getattr(env.unwrapped, "reward_component_names", ())
        if terms:
            out["reward_components"] = list(terms)
        inner = getattr(env.unwrapped, "env", env).unwrapped  # a vector-reward variant's episodes are its env's
        out["episode_end"] = docstring_section(type(inner).__doc__ or "", "Episode End")
    finally:
        env.close()
    return out


def summary(env_id: str) -> dict[str, Any]:
    """Everything ``gym4real info`` shows, as plain JSON-ready data (the interface's error if it cannot be made)."""
    record: dict[str, Any] = asdict(env_info(env_id))
    protocol = registry().benchmarks.get(base_env(env_id))
    if protocol is not None:
        record["benchmark"] = {
            "description": protocol.description,
            "policies": list(protocol.policies),
            "objective": list(protocol.objective),
            "step_unit": protocol.step_unit,
        }
    record["training_data"] = _training_data(env_id)
    if env_id in registry().multi_objective:
        from gym4real.bench.mo_reference import summary as mo_summary

        if (evaluation := mo_summary(env_id)) is not None:
            record["multi_objective"] = evaluation
    try:
        record["interface"] = env_interface(env_id)
    except Exception as exc:  # a summary without the spaces beats no summary: say why they are missing
        record["interface"] = {"error": " ".join(f"{type(exc).__name__}: {exc}".split())}
    return record


def _training_data(env_id: str) -> str | None:
    """The domain's word on its training data when part of it is a stand-in (``gym4real.<d>.standin.status``)."""
    from gym4real.core.datasets import standin_module

    module = standin_module(env_id.split("/", 1)[-1].split("-", 1)[0])
    return None if module is None else str(module.status())


def _listing(names: list[str] | tuple[str, ...], most: int = 8) -> str:
    shown = ", ".join(names[:most]) or "none"
    return shown + (f", ... ({len(names)} in all)" if len(names) > most else "")


def _baselines(record: dict[str, Any]) -> str:
    """The baselines, each non-causal one marked as the upper reference it is, with its kind (exact, ...)."""
    from gym4real.core.registry import MARK, upper_reference

    upper = list(record.get("non_causal", ()))
    text = _listing([b for b in record["baselines"] if b not in upper])
    return text + "".join(
        f"; {b} ({MARK}, {upper_reference(record['id'], b).bound_words()}: knows what no agent can know in advance)"
        for b in upper
    )


def plain(text: str) -> str:
    """Text for a terminal: the reST literals of docstrings without their double backticks."""
    return re.sub(r"``(.+?)``", r"\1", text)


def summary_text(record: dict[str, Any], width: int = 100) -> str:
    """The :func:`summary` of an env as labelled lines, wrapped at ``width`` characters (reST markup removed)."""
    flags = [f.replace("_", " ") for f, on in record["flags"].items() if on]
    iface = record["interface"]
    rows = [
        ("distribution", f"{record['distribution']} {record['version']}"),
        ("flags", ", ".join(flags) or "none"),
    ]
    if "error" in iface:
        rows.append(("spaces", f"unavailable: the env could not be made ({iface['error']})"))
    else:
        rows += [("observation", iface["observation_space"]), ("action", iface["action_space"])]
        terms = ", ".join(iface.get("reward_components", ()))
        if "reward_space" in iface:
            reward = f"{iface['reward_space']}, one entry each: {terms}" if terms else iface["reward_space"]
        else:
            reward = f"a float, the sum of: {terms}" if terms else "a float"
        rows.append(("reward", reward))
        steps = f" (time limit {iface['max_episode_steps']} steps)" if "max_episode_steps" in iface else ""
        rows.append(("episode end", (iface["episode_end"] or "see the env's docstring") + steps))
    rows.append(("presets", f"{', '.join(record['presets'])} (default: {record['presets'][0]})"))
    rows.append(("baselines", _baselines(record)))
    if "benchmark" in record:
        bench = record["benchmark"]
        text = f"{bench['description']}; policies {', '.join(bench['policies'])}; one step = one {bench['step_unit']}"
        if bench["objective"]:
            text += f"; objective {' + '.join(bench['objective'])}"
        rows.append(("benchmark", text))
    if "multi_objective" in record:
        mo = record["multi_objective"]
        rows.append(("objectives", "; ".join(f"{o['name']} = {' + '.join(o['components'])}" for o in mo["objectives"])))
        if "reference_point" in mo:
            point = ", ".join(f"{v:.6g}" for v in mo["reference_point"])
            fronts = ", ".join(f"{n} {f['hypervolume']:.3f}" for n, f in mo["reference_fronts"].items())
            rows.append(("reference point", f"({point}): {mo['reference_point_rule']}"))
            rows.append(("reference fronts", f"hypervolume (normalised): {fronts}"))
        else:
            rows.append(("reference point", mo["reference"]))
    rows.append(("training", _listing(record["trainings"])))
    domain = record["id"].split("/", 1)[-1].split("-", 1)[0]
    rows.append(("datasets", f"{_listing(record['datasets'], 4)} (`gym4real data list {domain}`)"))
    if record.get("training_data"):
        rows.append(("training data", record["training_data"]))
    rows += [(str(key), str(value)) for key, value in record["extra"].items()]
    label = max(len(k) for k, _ in rows) + 2
    lines = [plain(f"{record['id']}: {record['description']}")]
    for key, value in rows:
        lines += textwrap.wrap(
            plain(value), width, initial_indent=f"{key:<{label}}", subsequent_indent=" " * label, break_on_hyphens=False
        )
    return "\n".join(lines)


def add(sub: Any) -> None:
    """``list`` and ``info``."""
    command(sub, "list", "list the installed environments", _list)
    info = command(sub, "info", "describe an environment: flags, spaces, episode end, presets, baselines, data", _info)
    info.add_argument("env_id", help=ENV_ID_HELP)
    info.add_argument("--json", action="store_true", help="print the record as JSON (for programs)")
