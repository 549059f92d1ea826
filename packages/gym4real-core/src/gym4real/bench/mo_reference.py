"""The fixed reference point and the reference fronts of a vector-reward id, shipped with its domain.

A domain ships, for each vector-reward id ``gym4real/<name>`` it declares (:mod:`gym4real.core.mo_spec`),
the package-data file ``gym4real/<domain>/reference/<name>.mo.json``, written once by
``scripts/export_mo_references.py`` (:func:`export`) and never recomputed from an agent under test:

- **reference point**, by a fixed rule: run ``random`` on the test protocol; per objective, take its worst
  test episode and push it out by ``margin`` (the spec's, 0.1) times the range of its test episodes:
  ``r = worst - margin (best - worst)``. ``random``'s best episode is ``top``, 1 on the normalised scale
  (:mod:`gym4real.bench.mo_metrics`); its per-episode values are kept in the file, so that the rule can be
  checked against them;
- **reference fronts**, each a set of policies with their per-test-episode objective vectors: each
  rule-based sweep of the spec, and ``rule_based``, all the sweeps' policies together; :func:`add_front`
  adds another: the shipped files hold ``hindsight``, the weighted front of the domain's hindsight planner
  (``factory(env, weights=w)`` run at some EUM weights, handed raw weights that rank as ``w`` on the
  normalised scale; ``scripts/export_mo_references.py --hindsight``). A front's value is the hypervolume
  and the EUM of its policies' mean vectors;
- the **fingerprint** of the protocol (:func:`gym4real.bench.reference.fingerprint`) with the objectives
  and margin: :func:`load` refuses a file measured on another protocol or for other objectives, naming each
  difference.
"""

from __future__ import annotations

import functools
import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.bench import mo_metrics, versions
from gym4real.bench.agent_errors import AgentError, blame
from gym4real.bench.benchmark import protocol, run_episode
from gym4real.bench.policies import make_policy
from gym4real.bench.reference import FINGERPRINT_FIELDS, FOLDER, domain_package, fingerprint
from gym4real.core.errors import ConfigError, ReferenceMismatchError
from gym4real.core.mo_spec import MultiObjectiveSpec, SweepPolicy, mo_spec
from gym4real.core.registry import base_env, load_object, slug

#: The suffix of the file beside the reference runs (``reference/<name>.mo.json``).
SUFFIX = ".mo.json"
#: The front of all the rule-based sweeps together.
RULE_BASED = "rule_based"
#: The rule of the reference point, as the file and the docs state it.
RULE = (
    "per objective, random's worst test episode pushed out by margin x (best - worst) of random's test episodes; "
    "random's best test episode is 1 on the normalised scale"
)

Build = Callable[[gym.Env[Any, Any]], Callable[[Any], Any]]


@dataclass(frozen=True)
class Scale:
    """The normalised scale of an id: the reference point is 0, ``top`` (random's best episodes) is 1."""

    reference_point: np.ndarray
    top: np.ndarray

    def normalise(self, values: np.ndarray) -> np.ndarray:
        """``(values - reference_point) / (top - reference_point)``, over the last axis."""
        return (np.asarray(values, dtype=float) - self.reference_point) / (self.top - self.reference_point)

    def raw_weights(self, weights: Sequence[float]) -> np.ndarray:
        """Weights over the raw objectives that rank objective vectors as ``weights`` does on this scale.

        ``w . normalise(v)`` is ``sum_i w_i v_i / (top_i - reference_point_i)`` plus a constant, so maximising
        it maximises ``v`` weighted by ``w_i / (top_i - reference_point_i)``; returned rescaled to sum to 1.

        Raises:
            ConfigError: Not one finite, non-negative weight per objective, or all of them 0.
        """
        w = np.asarray(weights, dtype=float)
        if w.shape != self.top.shape or not np.isfinite(w).all() or (w < 0).any() or not w.sum() > 0:
            raise ConfigError(
                f"weights must be {self.top.size} finite non-negative numbers, not all 0; got {w.tolist()}"
            )
        raw = w / (self.top - self.reference_point)
        return np.asarray(raw / raw.sum())


def reference_scale(random_episodes: np.ndarray, margin: float) -> Scale:
    """The reference point rule (:data:`RULE`) applied to ``random``'s per-episode objectives ``(episodes, m)``.

    Raises:
        ConfigError: An objective on which every episode of ``random`` scores the same (no range to scale by).
    """
    values = np.asarray(random_episodes, dtype=float)
    worst, best = values.min(axis=0), values.max(axis=0)
    flat = np.flatnonzero(best <= worst)
    if flat.size:
        raise ConfigError(
            f"random scores the same on every test episode for objective(s) {flat.tolist()}: the reference point "
            "rule needs a range; define the objective otherwise"
        )
    return Scale(worst - margin * (best - worst), best)


@dataclass
class Front:
    """A reference front: policies and their per-test-episode objective vectors.

    Attributes:
        name: The front's name (a sweep's, ``rule_based``, ``hindsight``...).
        kind: ``rule_based`` or what else it is (``hindsight``).
        description: What the policies are.
        labels: One label per policy (its parameters, or its weights).
        episodes: ``(policies, episodes, objectives)`` raw objective values.
    """

    name: str
    kind: str
    description: str
    labels: list[str]
    episodes: np.ndarray

    @property
    def means(self) -> np.ndarray:
        """Each policy's mean objective vector over the test episodes, ``(policies, objectives)``."""
        return np.asarray(self.episodes.mean(axis=1))

    def values(self, scale: Scale, weights: np.ndarray) -> dict[str, Any]:
        """The front's record: its non-dominated policies, hypervolume and EUM on ``scale``."""
        mask = mo_metrics.nondominated(self.means)
        points = scale.normalise(self.means)
        return {
            "kind": self.kind,
            "description": self.description,
            "policies": [
                {"label": label, "mean": mean.tolist(), "nondominated": bool(keep), "episodes": eps.tolist()}
                for label, mean, keep, eps in zip(self.labels, self.means, mask, self.episodes, strict=True)
            ],
            "hypervolume": mo_metrics.hypervolume(points),
            "eum": mo_metrics.expected_utility(points, weights),
        }


@dataclass
class MOReference:
    """What a vector-reward id ships: the reference point, the fronts, and the protocol they were measured on."""

    env_id: str
    spec: MultiObjectiveSpec
    scale: Scale
    random_episodes: np.ndarray
    fronts: dict[str, Front]
    fingerprint: dict[str, Any]
    record: dict[str, Any] = field(default_factory=dict)
    source: str = ""

    @property
    def weights(self) -> np.ndarray:
        """The EUM weights (:func:`gym4real.bench.mo_metrics.simplex_weights`)."""
        return mo_metrics.simplex_weights(len(self.spec.objectives))


def _policy_env(env: gym.Env[Any, Any]) -> gym.Env[Any, Any]:
    """The env a rule reads: the one a vector-reward variant owns (the same spaces, its simulator's attributes)."""
    return getattr(env.unwrapped, "env", env)


def run_objectives(
    env_id: str,
    build: Build,
    plan: Sequence[Mapping[str, Any]],
    kwargs: Mapping[str, Any],
    label: str,
    timeout: float | None = None,
) -> np.ndarray:
    """Run the policy ``build(env)`` on the test episodes of a vector-reward id; ``(episodes, objectives)``.

    Args:
        env_id: The vector-reward id.
        build: ``build(env)`` returns the policy.
        plan: The test episodes.
        kwargs: Their ``make()`` arguments.
        label: The policy in the errors (``agent `mo=m:f` (seed 0, policy w=0.5,0.5)``, ``random``).
        timeout: Seconds an episode may take (:func:`~gym4real.bench.agent_errors.time_limit`), or None.

    Raises:
        AgentError: The policy or its factory failed, ran past ``timeout``, or scored a non-finite objective,
            naming ``label``, the id, the test episode and step (:func:`~gym4real.bench.agent_errors.blame`).
    """
    spec = mo_spec(env_id)
    where = f"{label} on `{env_id}`"
    env = gym.make(env_id, **kwargs)
    try:
        with blame(where):
            policy = build(env)
        rows = []
        for i, episode in enumerate(plan):
            at = f"{where}, test episode {i} (reset seed {episode.get('seed')})"
            with blame(at, timeout):
                run = run_episode(env, policy, episode.get("seed"), episode.get("options"))
            values = spec.values(run["components"])
            if not np.isfinite(values).all():
                raise AgentError(
                    f"{at}: non-finite objectives {values.tolist()}; fix the actions that drive the env there"
                )
            rows.append(values)
    finally:
        env.close()
    return np.array(rows)


def sweep_builder(policy: SweepPolicy) -> Build:
    """Build a sweep's policy in the env the vector-reward variant owns."""
    return lambda env: policy(_policy_env(env))


def test_plan(env_id: str) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The test episodes and ``make()`` arguments of an id's protocol."""
    spec = protocol(env_id)
    kwargs = dict(spec.env_kwargs)
    return load_object(spec.protocol)(dict(kwargs)), kwargs


def installed_fingerprint(env_id: str) -> dict[str, Any]:
    """The fingerprint of the installed protocol of a vector-reward id (made on the env it wraps)."""
    _, kwargs = test_plan(env_id)
    env = gym.make(base_env(env_id), **kwargs)
    try:
        return fingerprint(env_id, env)
    finally:
        env.close()


def path_of(env_id: str, folder: str | Path | None = None) -> Path:
    """Where an id's file is: ``folder/<name>.mo.json`` or the domain package's ``reference/`` folder."""
    base = Path(folder) if folder is not None else Path(str(resources.files(domain_package(base_env(env_id))))) / FOLDER
    return base / f"{slug(env_id)}{SUFFIX}"


def _check(
    env_id: str, record: dict[str, Any], spec: MultiObjectiveSpec, installed: dict[str, Any], where: str
) -> None:
    def measured(objectives: list[dict[str, Any]]) -> list[tuple[str, list[str]]]:  # descriptions are prose
        return [(o["name"], list(o["components"])) for o in objectives]

    declared = spec.record()
    differences = [
        f"{key}: {record['fingerprint'].get(key)!r} in the file, {installed.get(key)!r} installed"
        for key in FINGERPRINT_FIELDS
        if record["fingerprint"].get(key) != installed.get(key)
    ]
    if measured(record["objectives"]) != measured(declared["objectives"]):
        differences.append(
            f"objectives: {measured(record['objectives'])} in the file, {measured(declared['objectives'])} declared"
        )
    if record["margin"] != declared["margin"]:
        differences.append(f"margin: {record['margin']} in the file, {declared['margin']} declared")
    if differences:
        raise ReferenceMismatchError(
            f"the multi-objective reference of `{env_id}` ({where}) was measured on another protocol or for other "
            f"objectives than the installed ones ({'; '.join(differences)}): install the version it was measured on, "
            "or regenerate it with `python scripts/export_mo_references.py`"
        )


def _front(name: str, entry: Mapping[str, Any]) -> Front:
    return Front(
        name,
        entry["kind"],
        entry["description"],
        [p["label"] for p in entry["policies"]],
        np.array([p["episodes"] for p in entry["policies"]], dtype=float),
    )


def load(env_id: str, folder: str | Path | None = None, check: bool = True) -> MOReference | None:
    """The shipped reference of a vector-reward id (or the one in ``folder``); None when there is none.

    Args:
        env_id: A vector-reward id with a declared evaluation.
        folder: A folder holding ``<name>.mo.json`` instead of the domain package's ``reference/``.
        check: Refuse a file measured on another protocol or for other objectives than the installed ones.

    Raises:
        ReferenceMismatchError: With ``check``, the differences.
    """
    spec = mo_spec(env_id)
    path = path_of(env_id, folder)
    if not path.is_file():
        return None
    record = json.loads(path.read_text())
    if check:
        _check(env_id, record, spec, installed_fingerprint(env_id), str(path))
    point = record["reference_point"]
    return MOReference(
        env_id,
        spec,
        Scale(np.array(point["value"], dtype=float), np.array(point["top"], dtype=float)),
        np.array(point["random_episodes"], dtype=float),
        {name: _front(name, entry) for name, entry in record["fronts"].items()},
        record["fingerprint"],
        record,
        # shipped files by their package and name, never a path of this machine (as the reference runs do)
        str(path) if folder is not None else f"{domain_package(base_env(env_id))}: {FOLDER}/{path.name}",
    )


def _write(reference: MOReference, path: Path, manifest: Mapping[str, Any]) -> Path:
    weights = reference.weights
    random = reference.random_episodes
    record = {
        "env_id": reference.env_id,
        "fingerprint": reference.fingerprint,
        **{k: v for k, v in reference.spec.record().items() if k in ("objectives", "margin")},
        "reference_point": {
            "rule": RULE,
            "value": reference.scale.reference_point.tolist(),
            "top": reference.scale.top.tolist(),
            "random_worst": random.min(axis=0).tolist(),
            "random_best": random.max(axis=0).tolist(),
            "random_episodes": random.tolist(),
        },
        "weights": {
            "rule": f"Das-Dennis simplex lattice, the first with at least {mo_metrics.WEIGHTS} weights",
            "count": len(weights),
        },
        "fronts": {name: front.values(reference.scale, weights) for name, front in reference.fronts.items()},
        "manifest": dict(manifest),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1) + "\n")
    return path


def _manifest(command: str) -> dict[str, Any]:
    return {"command": command, "code_version": versions.code_version(), "versions": versions.versions()}


def measure_sweeps(env_id: str, progress: Callable[[str], None] | None = None) -> dict[str, np.ndarray]:
    """Run every sweep of an id's spec on its test protocol: ``"<sweep>:<label>"`` -> ``(episodes, objectives)``."""
    plan, kwargs = test_plan(env_id)
    measured = {}
    for sweep in mo_spec(env_id).sweeps:
        for policy in sweep.policies:
            key = f"{sweep.name}:{policy.label}"
            measured[key] = run_objectives(env_id, sweep_builder(policy), plan, kwargs, key)
            if progress is not None:
                progress(key)
    return measured


def measure_random(env_id: str) -> np.ndarray:
    """``random``'s objectives on each test episode, ``(episodes, objectives)``: the reference point's data."""
    plan, kwargs = test_plan(env_id)
    return run_objectives(env_id, lambda env: make_policy(env_id, "random", env), plan, kwargs, "random")


def reference_run_objectives(env_id: str, policy: str) -> np.ndarray | None:
    """A baseline's objectives on each test episode, from the reference runs its env ships; None if absent.

    The reference runs (:mod:`gym4real.bench.reference`) of the env a vector-reward id wraps keep every reward
    component of every test episode, measured on the same protocol (their fingerprint is checked).

    Raises:
        ReferenceMismatchError: The reference runs were measured on another protocol.
    """
    import pandas as pd

    from gym4real.bench.reference import check_fingerprint, load_reference, reference_table

    base = base_env(env_id)
    reference = load_reference(base)
    if reference is None or policy not in reference.scores:
        return None
    _, kwargs = test_plan(env_id)
    env = gym.make(base, **kwargs)
    try:
        check_fingerprint(reference, fingerprint(base, env))
    finally:
        env.close()
    with reference_table(base).open() as handle:
        frame = pd.read_csv(handle)
    rows = frame[(frame["policy"] == policy) & frame["seed"].isna()].sort_values("episode")
    spec = mo_spec(env_id)
    return np.array([spec.values(row) for row in rows.to_dict("records")])


def export(
    env_id: str,
    into: str | Path | None = None,
    measured: Mapping[str, np.ndarray] | None = None,
    command: str = "python scripts/export_mo_references.py",
) -> Path:
    """Measure and write an id's reference point and rule-based fronts (``reference/<name>.mo.json``).

    Args:
        env_id: A vector-reward id with a declared evaluation.
        into: Write into this folder instead of the domain package's ``reference/`` (the source tree in an
            editable checkout).
        measured: Per-episode objectives already measured on this protocol, ``"random"`` and
            ``"<sweep>:<label>"`` -> ``(episodes, objectives)``; what is missing is run here, except ``random``,
            taken from the reference runs the env ships when they hold it (:func:`reference_run_objectives`).
        command: The command that measured them, kept in the manifest.
    """
    spec = mo_spec(env_id)
    plan, kwargs = test_plan(env_id)
    found = dict(measured or {})
    if "random" not in found:
        shipped = reference_run_objectives(env_id, "random")
        found["random"] = shipped if shipped is not None else measure_random(env_id)
    random = found["random"]
    fronts: dict[str, Front] = {}
    for sweep in spec.sweeps:
        labels, rows = [], []
        for policy in sweep.policies:
            key = f"{sweep.name}:{policy.label}"
            if key not in found:
                found[key] = run_objectives(env_id, sweep_builder(policy), plan, kwargs, key)
            labels.append(policy.label)
            rows.append(found[key])
        fronts[sweep.name] = Front(sweep.name, RULE_BASED, sweep.description, labels, np.array(rows))
    for name, episodes in [("random", random), *((k, v) for k, v in found.items() if k != "random")]:
        if np.asarray(episodes).shape != (len(plan), len(spec.objectives)):
            raise ConfigError(
                f"`{name}` has objectives of shape {np.asarray(episodes).shape}; the protocol of `{env_id}` needs "
                f"({len(plan)}, {len(spec.objectives)})"
            )
    if spec.sweeps:
        fronts[RULE_BASED] = Front(
            RULE_BASED,
            RULE_BASED,
            "every rule-based sweep's policies together: " + ", ".join(s.name for s in spec.sweeps),
            [f"{f.name}:{label}" for f in fronts.values() for label in f.labels],
            np.concatenate([f.episodes for f in fronts.values()]),
        )
    reference = MOReference(
        env_id, spec, reference_scale(random, spec.margin), np.asarray(random), fronts, installed_fingerprint(env_id)
    )
    return _write(reference, path_of(env_id, into), _manifest(command))


def add_front(
    env_id: str,
    name: str,
    kind: str,
    description: str,
    factory: Callable[..., Any],
    seed: int | None = None,
    folder: str | Path | None = None,
    command: str = "",
    weights: np.ndarray | None = None,
    normalised: bool = False,
    replace: bool = False,
) -> Path:
    """Add a weighted front to an id's shipped file: ``factory(env, weights=w[, seed=seed])`` at each EUM weight.

    This is how the hindsight planners' upper reference front is added: one call, for example
    ``add_front("gym4real/dam-mo-v0", "hindsight", "hindsight", "the hindsight planner of ...",
    planner_factory, normalised=True)``. The reference point and the other fronts stay as they are. The
    CPU time of the runs (this process's) and the code version are kept in the manifest as ``cpu_s (<name>)``
    and ``code_version (<name>)``.

    Args:
        env_id: A vector-reward id whose file exists (:func:`export`).
        name: The front's name in the file (``hindsight``).
        kind: What the front is (``hindsight``).
        description: What its policies are, and at which weights they ran.
        factory: ``factory(env, weights=w[, seed=seed])`` returns a policy for the vector-reward env.
        seed: Passed to the factory when given.
        folder: The folder of the file, as in :func:`load`.
        command: The command that measured the front, kept in the manifest.
        weights: Run at these weights (over the objectives, ``(count, objectives)``) instead of the EUM's
            lattice, for a factory too slow to run at all of them; the front's EUM is still the mean over
            the EUM's weights (of the best of its policies at each). Say so in ``description``.
        normalised: Hand the factory, at weight ``w``, the weights over the raw objectives that rank
            objective vectors as ``w`` does on the normalised scale (:meth:`Scale.raw_weights`): a planner
            maximising its weighted objective then maximises ``w . z``, the utility the EUM takes at ``w``.
            The policies are still labelled by ``w``.
        replace: Measure the front again when the file already has one of that name (it is dropped first).

    Raises:
        ConfigError: The id ships no reference file yet (run :func:`export` first), ``name`` is taken, or
            ``weights`` is not one row of non-negative weights per policy, each summing to 1.
    """
    reference = load(env_id, folder)
    if reference is None:
        raise ConfigError(f"`{env_id}` ships no `{path_of(env_id, folder).name}`: run `export` first")
    if name in reference.fronts and not replace:
        raise ConfigError(f"`{env_id}` already has a front `{name}`; remove it from the file or pick another name")
    reference.fronts.pop(name, None)
    grid = reference.weights if weights is None else np.atleast_2d(np.asarray(weights, dtype=float))
    objectives = len(reference.spec.objectives)
    if grid.shape[1] != objectives or (grid < 0).any() or not np.allclose(grid.sum(axis=1), 1.0):
        raise ConfigError(f"`weights` must be rows of {objectives} non-negative weights summing to 1; got {grid}")
    plan, kwargs = test_plan(env_id)
    labels, rows = [], []
    extra = {} if seed is None else {"seed": seed}
    started = time.process_time()
    for w in grid:
        label = "w=" + ",".join(f"{x:.4g}" for x in w)
        given = reference.scale.raw_weights(w) if normalised else w
        rows.append(
            run_objectives(
                env_id, functools.partial(factory, weights=given, **extra), plan, kwargs, f"front `{name}` at {label}"
            )
        )
        labels.append(label)
    reference.fronts[name] = Front(name, kind, description, labels, np.array(rows))
    manifest = dict(reference.record.get("manifest", {}))
    if command:
        manifest[f"command ({name})"] = command
    manifest[f"cpu_s ({name})"] = round(time.process_time() - started, 1)
    manifest[f"code_version ({name})"] = versions.code_version()
    return _write(reference, path_of(env_id, folder), manifest)


def summary(env_id: str) -> dict[str, Any] | None:
    """What ``gym4real info`` shows of a vector-reward id's evaluation; None when its domain declares none.

    The objectives, the components left out, the reference point with its rule, and each shipped front's
    kind, hypervolume, EUM and description (or why there are none).
    """
    from gym4real.core.mo_spec import mo_ids

    if env_id not in mo_ids():
        return None
    spec = mo_spec(env_id)
    out: dict[str, Any] = {k: v for k, v in spec.record().items() if k in ("objectives", "left_out", "margin")}
    path = path_of(env_id)
    if not path.is_file():
        out["reference"] = f"none shipped (`{path.name}`): run `python scripts/export_mo_references.py {env_id}`"
        return out
    record = json.loads(path.read_text())
    point = record["reference_point"]
    out["reference_point"] = point["value"]
    out["reference_point_rule"] = f"{point['rule']} (margin {record['margin']})"
    out["top"] = point["top"]
    out["weights"] = record["weights"]
    out["reference_fronts"] = {
        name: {"kind": f["kind"], "hypervolume": f["hypervolume"], "eum": f["eum"], "description": f["description"]}
        for name, f in record["fronts"].items()
    }
    return out
