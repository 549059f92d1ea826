"""``gym4real train``: one entry point for every algorithm and registered preset.

A run folder holds ``settings.json`` (what is trained: env, algo, preset, seed, every setting and, for the
JAX trainer, ``trainer: jax``), the
model, the learning curve, a checkpoint while the run is unfinished, and ``run.json`` once it is finished
(wall time, environment steps, versions, the distributions it imported, the CPU model of the machine that
finished it, the code version and CPU model that started it and its resumes). Training in a folder that holds
an unfinished run of the same settings resumes it; a folder of other settings is refused.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from gym4real.bench.progress import ProgressDisplay
from gym4real.bench.seeds import is_preset_file
from gym4real.bench.versions import NOT_RECORDED, cpu_model, git_version
from gym4real.core.errors import ConfigError
from gym4real.core.registry import slug
from gym4real.rl.curves import LearningCurve
from gym4real.rl.imported import imported_distributions
from gym4real.rl.presets import load_preset
from gym4real.rl.progress import Progress

_VERSIONS = ("gym4real-core", "gymnasium", "numpy", "stable-baselines3", "torch", "numba", "jax", "jaxlib", "optax")

#: The trainers of PPO: Stable-Baselines3 (the reference, extra ``rl``) and JAX (extra ``jax``).
TRAINERS = ("sb3", "jax")

#: The policy kind of a model trained by each trainer other than SB3 (``ppo-jax:PATH``).
TRAINER_KINDS = {"jax": "ppo-jax"}


def label(algo: str, trainer: str = "sb3") -> str:
    """An agent's name in run folders, records and reports: the algorithm, with a trainer other than SB3's.

    ``ppo`` (SB3), ``ppo-jax`` (the JAX trainer), ``qlearning``, ...
    """
    return TRAINER_KINDS.get(trainer, algo)


@dataclass(frozen=True)
class TrainingRun:
    """Where a finished training run wrote its results, and what it cost."""

    env_id: str
    algo: str
    preset: str
    seed: int
    model_path: Path
    curve_csv: Path
    wall_time_s: float
    env_steps: int
    eval_steps: int
    trainer: str = "sb3"

    @property
    def agent(self) -> str:
        """The agent's name in reports (:func:`label`: ``ppo``, ``ppo-jax``)."""
        return label(self.algo, self.trainer)

    @property
    def policy(self) -> str:
        """The bench policy string of the trained model (``ppo:DIR/model.zip``, ``ppo-jax:DIR/model.npz``)."""
        return f"{self.agent}:{self.model_path}"

    @property
    def steps_per_s(self) -> float:
        """Environment steps (training and validation) per second of wall time."""
        return (self.env_steps + self.eval_steps) / self.wall_time_s if self.wall_time_s > 0 else float("nan")


def default_out(env_id: str, algo: str, preset: str, seed: int, trainer: str = "sb3") -> Path:
    """``runs/<env>/<agent>-<preset>-seed<S>``, ``<env>`` the id's name (``dam-v0``), as ``{env}`` of ``evaluate``.

    ``<agent>`` is :func:`label`: ``ppo``, or ``ppo-jax`` for the JAX trainer.
    """
    name = Path(preset).stem if is_preset_file(preset) else preset
    return Path("runs") / slug(env_id) / f"{label(algo, trainer)}-{name}-seed{seed}"


def versions() -> dict[str, str]:
    """Installed versions of the packages a training result depends on, and the commit of the code.

    The commit is ``git describe --always --dirty`` of the checkout holding this code, else the value of
    ``GYM4REAL_CODE_VERSION`` (suffixed ``(stated)``), else absent.
    """
    found = {}
    for dist in _VERSIONS:
        try:
            found[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            continue
    commit = git_version()
    if commit is not None:
        found["gym4real (git)"] = commit
    return found


def _settings(env_id: str, algo: str, preset: str, seed: int, hp: dict[str, Any], trainer: str) -> dict[str, Any]:
    """What a run trains; ``trainer`` only where it is not SB3 (the settings of SB3 runs stay as they were)."""
    settings = {"env_id": env_id, "algo": algo, "preset": preset, "seed": seed, "hyperparameters": hp}
    if trainer != "sb3":
        settings["trainer"] = trainer
    return json.loads(json.dumps(settings))


def finished_run(
    folder: Path, env_id: str, algo: str, preset: str, seed: int, trainer: str = "sb3"
) -> TrainingRun | None:
    """The finished run in ``folder`` if it trained exactly these settings (by this trainer), else None."""
    record = folder / "run.json"
    if not record.exists():
        return None
    data = json.loads(record.read_text())
    expected = _settings(env_id, algo, preset, seed, load_preset(env_id, algo, preset), trainer)
    if data.get("trainer", "sb3") != trainer:
        return None
    if {k: data.get(k) for k in expected} != expected:
        return None
    model = folder / data["model"]
    if not model.exists():
        return None
    return TrainingRun(
        env_id,
        algo,
        preset,
        seed,
        model,
        folder / "curve.csv",
        data["wall_time_s"],
        data["env_steps"],
        data["eval_steps"],
        trainer,
    )


def train(
    env_id: str,
    algo: str,
    preset: str = "paper",
    seed: int = 0,
    out: str | Path | None = None,
    progress: bool | Progress = False,
    trainer: str = "sb3",
    eval_beside: bool | None = None,
) -> TrainingRun:
    """Train an agent with a registered preset and write the model and the learning curve.

    Args:
        env_id: A registered id.
        algo: ``ppo``, ``dqn`` (Stable-Baselines3), ``qlearning`` or ``sarsa`` (tabular).
        preset: Training preset name (``paper``, ``smoke``) or the path of a YAML preset file.
        seed: Seed of the run.
        out: Output folder (default ``runs/<env>/<algo>-<preset>-seed<S>``); an unfinished run of the same
            settings there is resumed from its last checkpoint.
        progress: Show a progress bar (True), or a function called with (done, total).
        trainer: ``sb3`` (Stable-Baselines3, every algorithm but the tabular ones) or ``jax`` (PPO on an env
            with a native vector env, :mod:`gym4real.rl.jax_ppo`; the ``jax`` extra).
        eval_beside: The JAX trainer's checkpoint evaluations in a second process beside training (True),
            in-line (False), or beside when this process may use two cores (None); the run's results are
            the same either way (:mod:`gym4real.rl.checkpoint_evaluations`). Not a setting of the run: a
            run resumes with either.

    Raises:
        ConfigError: ``out`` holds a run of other settings, or an unknown trainer or one that does not
            train ``algo``, or ``eval_beside=True`` with a trainer other than JAX.
    """
    if trainer not in TRAINERS:
        raise ConfigError(f"unknown trainer `{trainer}`; expected one of {list(TRAINERS)}")
    if eval_beside and trainer != "jax":
        raise ConfigError("checkpoint evaluations beside training are the JAX trainer's (`--trainer jax`)")
    if trainer == "jax" and algo != "ppo":
        raise ConfigError(f"the JAX trainer trains PPO, not `{algo}`: use `--trainer sb3`")
    hp = load_preset(env_id, algo, preset)
    check_no_test_overlap(env_id, algo, preset)
    folder = Path(out) if out else default_out(env_id, algo, preset, seed, trainer)
    folder.mkdir(parents=True, exist_ok=True)
    settings = _settings(env_id, algo, preset, seed, hp, trainer)
    settings_path = folder / "settings.json"
    if settings_path.exists() and json.loads(settings_path.read_text()) != settings:
        raise ConfigError(
            f"`{folder}` holds a run of other settings (see its settings.json); choose another output folder "
            "or delete that one"
        )
    settings_path.write_text(json.dumps(settings, indent=1))
    (folder / "run.json").unlink(missing_ok=True)
    started = record_start(folder)
    resumes = record_resume(folder)
    timing = folder / "timing.json"
    previous = json.loads(timing.read_text())["wall_time_s"] if timing.exists() else 0.0
    start = time.perf_counter()
    last_write = start
    bar = None
    if progress is True:
        bar = ProgressDisplay(
            f"{label(algo, trainer)} {env_id}", unit="episodes" if algo in ("qlearning", "sarsa") else "steps"
        )

    def report(done: int, total: int) -> None:
        nonlocal last_write
        now = time.perf_counter()
        if now - last_write > 30:
            timing.write_text(json.dumps({"wall_time_s": previous + now - start}))
            last_write = now
        if bar is not None:
            bar.update(done, total)
        elif callable(progress):
            progress(done, total)

    if algo in ("qlearning", "sarsa"):
        from gym4real.rl.tabular import train_tabular

        model, steps = train_tabular(env_id, hp, seed, folder, report)
    elif trainer == "jax":
        from gym4real.rl.jax_ppo import train_jax

        model, steps = train_jax(env_id, hp, seed, folder, report, eval_beside)
    else:
        from gym4real.rl.sb3 import train_sb3

        model, steps = train_sb3(env_id, hp, seed, folder, report)
    if bar is not None:
        bar.close()
    LearningCurve.load(folder, "episodes" if algo in ("qlearning", "sarsa") else "timesteps").draw()
    wall = previous + time.perf_counter() - start
    timing.unlink(missing_ok=True)
    run = TrainingRun(
        env_id, algo, preset, seed, model, folder / "curve.csv", wall, steps["train"], steps["eval"], trainer
    )
    record = {
        **settings,
        **({} if algo in ("qlearning", "sarsa") else {"trainer": trainer}),
        "model": model.name,
        "wall_time_s": wall,
        "env_steps": steps["train"],
        "eval_steps": steps["eval"],
        "steps_per_s": run.steps_per_s,
        "versions": versions(),
        "cpu": cpu_model(),
        **({} if started is None else {"started": started}),
        "resumes": resumes,
        "imported": imported_distributions(),
    }
    (folder / "run.json").write_text(json.dumps(record, indent=1))
    (folder / RESUMES).unlink(missing_ok=True)
    (folder / STARTED).unlink(missing_ok=True)
    return run


#: The record of an unfinished run's resumes, kept beside its checkpoint until ``run.json`` takes it over.
RESUMES = "resumes.json"

#: The record of an unfinished run's start from scratch, kept beside its checkpoint until ``run.json`` takes it over.
STARTED = "started.json"


def checkpoint_progress(folder: Path) -> dict[str, Any] | None:
    """Where the checkpoint in ``folder`` stands (``{"unit": ..., "at": N}``), None without a checkpoint."""
    state = folder / "checkpoint" / "state.json"
    if state.exists():
        return {"unit": "timesteps", "at": int(json.loads(state.read_text())["timesteps"])}
    tabular = folder / "checkpoint.npz"
    if tabular.exists():
        import numpy as np

        with np.load(tabular, allow_pickle=False) as data:
            return {"unit": "episodes", "at": int(data["episode"])}
    return None


#: The code version of a start or resume whose code had none (not a git checkout, no ``GYM4REAL_CODE_VERSION``).
UNKNOWN = "unknown"


def _segment() -> dict[str, str]:
    """Who trains this stretch of a run: the code version (:data:`UNKNOWN` where none) and the CPU model."""
    return {"code_version": versions().get("gym4real (git)", UNKNOWN), "cpu": cpu_model()}


def record_start(folder: Path) -> dict[str, str] | None:
    """The code version and CPU model that started the run from scratch (``started.json``), recorded now if this does.

    None for an unfinished run that started before starts were recorded: its start is not known.
    """
    path = folder / STARTED
    if checkpoint_progress(folder) is None:
        path.write_text(json.dumps(_segment(), indent=1))
    return json.loads(path.read_text()) if path.exists() else None


def started_by(record: dict[str, Any]) -> str:
    """The code version that started a finished run (its ``run.json`` ``record``).

    A run recorded before starts were names the code version that finished it; a run whose code version is
    not known (recorded before versions were, or started by code without one) says
    :data:`~gym4real.bench.versions.NOT_RECORDED`.
    """
    if "started" in record:
        version = str(record["started"]["code_version"])
        return NOT_RECORDED if version == UNKNOWN else version
    return str(record.get("versions", {}).get("gym4real (git)", NOT_RECORDED))


def record_resume(folder: Path) -> list[dict[str, Any]]:
    """The run's resumes so far, this start appended when it resumes from a checkpoint (``resumes.json``).

    Each entry says from where the run went on (unit and count), the code version that went on with it and
    the CPU model of the machine it went on on.
    """
    path = folder / RESUMES
    resumes: list[dict[str, Any]] = json.loads(path.read_text()) if path.exists() else []
    at = checkpoint_progress(folder)
    if at is not None:
        resumes.append({**at, **_segment()})
        path.write_text(json.dumps(resumes, indent=1))
    return resumes


def check_no_test_overlap(env_id: str, algo: str, preset: str) -> None:
    """Refuse a preset whose validation seeds are seeds of the env's test protocol.

    Model selection must never see the test split: the validation episodes ``eval_seed, eval_seed + 1,
    ...`` may not share a seed with the registered test protocol (a seed fixes an episode's draws, whatever
    the preset). Held-out data splits of the validation env are the domain's to declare and test.

    Raises:
        ConfigError: The two blocks of seeds overlap.
    """
    from gym4real.core.registry import load_object, registry

    spec = registry().benchmarks.get(env_id)
    if spec is None:
        return
    hp = load_preset(env_id, algo, preset)
    test_seeds = {ep.get("seed") for ep in load_object(spec.protocol)(dict(spec.env_kwargs))}
    start, n = int(hp["eval_seed"]), int(hp["eval_episodes"])
    overlap = sorted(s for s in test_seeds if s is not None and start <= s < start + n)
    if overlap:
        raise ConfigError(
            f"training preset `{algo}/{preset}` of `{env_id}` selects its model on test episodes (seeds "
            f"{overlap[0]}..{overlap[-1]}); set `eval_seed` to a block disjoint from the test protocol's seeds"
        )
