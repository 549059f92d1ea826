"""PPO trained with JAX on a domain's native vector env: ``gym4real train --trainer jax`` (the ``jax`` extra).

The same PPO as the SB3 trainer's (:mod:`gym4real.rl.sb3`), from the same preset, at the speed of the
environments. An iteration is a rollout in the native vector env (``gymnasium.make_vec(...,
vectorization_mode="vector_entry_point")``) with one compiled call per vector step for the observation
statistics, both networks, the action draw and the buffer writes (:mod:`gym4real.rl.rollout_kernel`),
the advantages (SB3's GAE, compiled), then one jitted update (:mod:`gym4real.rl.jax_update`).

What follows SB3 (each tested against it): the preset's hyperparameters and SB3's defaults for those it
omits, SB3's initialisation and ``log_std_init`` (:mod:`gym4real.rl.actor_critic`), VecNormalize's running
observation statistics and clipping (``normalize_obs``, ``clip_obs``), Gaussian actions learnt on
``[-1, 1]`` and mapped onto a bounded Box (clipped first, the unclipped action trained on), truncated
episodes bootstrapped from their final observation, the learning-rate schedules (the rate of an iteration
is the schedule's at the progress after its rollout) and the dam preset's KL-adaptive rate and standardised
value targets (:mod:`gym4real.rl.value_scaler`). Where it differs, by design:

- the random numbers are jax's (``jax.random``, keys derived from the seed and the iteration), so runs of
  the two trainers with one seed differ as runs of two seeds do;
- the native env resets an ended copy at its next step; that step holds no transition and weighs 0 in the
  update (:mod:`gym4real.rl.rollout_kernel`), where SB3's vector env resets within the step;
- evaluations run after the update of the iteration that reaches the next ``eval_freq`` (SB3's callback
  evaluates within the rollout), with the deterministic mean action, on a snapshot of the policy: beside
  training in a second process where two cores are available (:mod:`gym4real.rl.checkpoint_evaluations`),
  their results taken at the next evaluation point; the curve and the selected model are the same in-line;
- each checkpoint (written at each evaluation, its own evaluation still running: a resumed run runs it
  again from the checkpoint's policy) restarts the envs' episodes, seeded ``seed + timesteps``, in the
  uninterrupted run as in a resumed one: a resumed run is the uninterrupted run, bit for bit.

A run writes ``model.npz`` (the best model on the validation episodes; a :mod:`gym4real.rl.actor_critic`
model file, loaded as ``ppo-jax:PATH``), the learning curve and, while unfinished, ``checkpoint/``.
XLA runs on one thread (set before jax starts), as SB3's torch does: the same seed gives the same model.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import ConfigError, PolicyError
from gym4real.core.vector import step_arrays
from gym4real.rl.actor_critic import Model, Normalization, architecture, initial_parameters, network
from gym4real.rl.progress import Progress
from gym4real.rl.schedules import KLAdaptive, schedule
from gym4real.rl.storage import write_whole
from gym4real.rl.value_scaler import RunningStandardScaler

#: SB3 PPO's defaults of the hyperparameters this trainer implements (checked against SB3 in the tests).
PPO_DEFAULTS: dict[str, Any] = {
    "n_steps": 2048,
    "batch_size": 64,
    "n_epochs": 10,
    "gamma": 0.99,
    "gae_lambda": 0.95,
    "clip_range": 0.2,
    "clip_range_vf": None,
    "normalize_advantage": True,
    "ent_coef": 0.0,
    "vf_coef": 0.5,
    "max_grad_norm": 0.5,
}

#: XLA on one thread: the numbers do not depend on the machine's cores, and the rollout's calls stay cheap.
XLA_ONE_THREAD = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"

#: The install command of the extra, for the error without it.
INSTALL = 'pip install "gym4real-core[jax]"'


def jax_modules() -> tuple[Any, Any]:
    """``jax`` and ``optax``, XLA set to one thread first (it reads its flags when it starts).

    numba is checked too: the rollout is compiled with it.

    Raises:
        PolicyError: The ``jax`` extra is not installed (naming the install command).
    """
    flags = os.environ.get("XLA_FLAGS", "")
    if "intra_op_parallelism_threads" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} {XLA_ONE_THREAD}".strip()
    try:
        import jax
        import numba  # noqa: F401  # the compiled rollout (gym4real.rl.rollout_kernel)
        import optax
    except ImportError as exc:
        raise PolicyError(f"`--trainer jax` needs the `jax` extra ({exc.name} is missing): `{INSTALL}`") from exc
    return jax, optax


def ppo_settings(env_id: str, hp: dict[str, Any]) -> dict[str, Any]:
    """The preset's PPO hyperparameters with SB3's defaults for the others.

    Raises:
        ConfigError: A setting this trainer does not implement (named), or an env without a native vector env.
    """
    if hp["algo"] != "ppo":
        raise ConfigError(f"the JAX trainer trains PPO, not `{hp['algo']}`: use `--trainer sb3`")
    if gym.spec(env_id).vector_entry_point is None:
        raise ConfigError(f"the JAX trainer steps a native vector env, and `{env_id}` has none: use `--trainer sb3`")
    if hp.get("normalize_reward"):
        raise ConfigError("the JAX trainer does not normalise rewards (`normalize_reward: true`): use `--trainer sb3`")
    given = dict(hp["hyperparams"])
    rate = given.pop("learning_rate")
    unknown = sorted(set(given) - set(PPO_DEFAULTS))
    if unknown:
        raise ConfigError(
            f"the JAX trainer implements `hyperparams` {sorted(PPO_DEFAULTS)} and learning_rate, not "
            f"`{unknown[0]}`: remove it or use `--trainer sb3`"
        )
    return {**PPO_DEFAULTS, **given, "learning_rate": rate}


class _Rollout:
    """The buffers of one rollout and the compiled per-step work (:func:`gym4real.rl.rollout_kernel.step`)."""

    def __init__(self, steps: int, n: int, obs_dim: int, actions: int, discrete: bool) -> None:
        self.steps, self.n = steps, n
        width = 1 if discrete else actions
        self.obs = np.zeros((steps + 1, n, obs_dim), dtype=np.float32)
        self.actions = np.zeros((steps, n, width), dtype=np.float32)
        self.values = np.zeros((steps + 1, n), dtype=np.float32)
        self.log_probs = np.zeros((steps, n), dtype=np.float32)
        self.rewards = np.zeros((steps, n), dtype=np.float32)
        self.terminated = np.zeros((steps, n), dtype=bool)
        self.truncated = np.zeros((steps, n), dtype=bool)
        self.valid = np.ones((steps + 1, n), dtype=bool)
        self.env_actions = np.zeros((n, width), dtype=np.float32)

    @property
    def buffers(self) -> tuple[np.ndarray, ...]:
        return (
            self.obs,
            self.actions,
            self.values,
            self.log_probs,
            self.rewards,
            self.terminated,
            self.truncated,
            self.valid,
        )

    def rows(self, name: str) -> np.ndarray:
        """A copy of a buffer's rollout rows (the last observation row left out) as ``(steps * copies, ...)``."""
        data = getattr(self, name)[: self.steps]
        return data.reshape(self.steps * self.n, *data.shape[2:]).copy()


class JaxPPO:
    """The state of a training run: parameters, optimizer, statistics, rate, and how to step it.

    Args:
        env_id: A registered id with a native vector env.
        hp: A resolved PPO preset.
        seed: Seed of the run.
    """

    def __init__(self, env_id: str, hp: dict[str, Any], seed: int) -> None:
        jax, _ = jax_modules()
        from gym4real.rl import rollout_kernel
        from gym4real.rl.jax_update import UpdateSettings, epoch_orders, make_update, optimizer
        from gym4real.rl.sb3 import rescaled

        self.jax = jax
        self.kernel: Any = rollout_kernel  # its compiled functions, called with tuples of arrays
        self.ppo = p = ppo_settings(env_id, hp)
        self.seed = seed
        self.n_envs = int(hp.get("n_envs", 1))
        self.total = int(hp["total_timesteps"])
        env_kwargs = dict(hp.get("env_kwargs", {}))
        self.venv = gym.make_vec(env_id, self.n_envs, vectorization_mode="vector_entry_point", **env_kwargs)
        obs_space, act_space = self.venv.single_observation_space, self.venv.single_action_space
        self.arch = architecture(obs_space, act_space, hp.get("policy_kwargs"))
        self.rescaled = rescaled(act_space)
        self.spaces = (obs_space, act_space)
        self.normalize = bool(hp.get("normalize_obs", False))
        self.clip_obs = float(hp["clip_obs"])
        rate = schedule(p["learning_rate"])
        self.schedule = rate
        kl = rate if isinstance(rate, KLAdaptive) else None
        self.settings = UpdateSettings(
            arch=self.arch,
            rows=int(p["n_steps"]) * self.n_envs,
            n_epochs=int(p["n_epochs"]),
            batch_size=int(p["batch_size"]),
            clip_range=float(p["clip_range"]),
            clip_range_vf=None if p["clip_range_vf"] is None else float(p["clip_range_vf"]),
            ent_coef=float(p["ent_coef"]),
            vf_coef=float(p["vf_coef"]),
            max_grad_norm=float(p["max_grad_norm"]),
            normalize_advantage=bool(p["normalize_advantage"]),
            kl_adaptive=kl,
        )
        self.update = make_update(self.settings)
        self.epoch_orders = epoch_orders  # each epoch's permutation, drawn before the update
        self.adam = optimizer()
        log_std_init = float((hp.get("policy_kwargs") or {}).get("log_std_init", 0.0))
        self.params = {k: jax.numpy.asarray(v) for k, v in initial_parameters(self.arch, log_std_init, seed).items()}
        self.opt_state = self.adam.init(self.params)
        self.rate = float(rate.initial)
        self.scaler = RunningStandardScaler() if hp.get("value_scaler") else None
        d = self.arch.obs_dim
        self.stats = (np.zeros(d), np.ones(d), np.array([1e-4]))  # RunningMeanStd's start (count epsilon)
        self.timesteps = 0
        self.rollout = _Rollout(int(p["n_steps"]), self.n_envs, d, self.arch.actions, self.arch.discrete)
        if self.arch.discrete:
            start = float(act_space.start)  # type: ignore[attr-defined]
            self.bounds = (np.array([start], np.float32), np.array([start + self.arch.actions - 1], np.float32), 2)
        else:
            self.bounds = (act_space.low, act_space.high, 0 if self.rescaled else 1)  # type: ignore[attr-defined]
        noise = jax.random.gumbel if self.arch.discrete else jax.random.normal
        shape = (self.rollout.steps, self.n_envs, self.arch.actions)
        self._noise = jax.jit(lambda key: noise(key, shape, jax.numpy.float32))
        self._raw: tuple[np.ndarray, ...] = ()
        self._update_key: Any = None

    # -- state ---------------------------------------------------------------------------------------

    def model(self) -> Model:
        """The current policy as a model (a copy: training goes on)."""
        norm = None
        if self.normalize:
            mean, var, count = self.stats
            norm = Normalization(mean.copy(), var.copy(), float(count[0]), self.clip_obs)
        params = {k: np.array(v) for k, v in self.params.items()}
        return Model(self.arch, params, norm, *self.spaces, self.rescaled)

    def state(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """The arrays and the numbers a checkpoint holds: parameters, Adam's moments, statistics; rate, counters."""
        leaves = self.jax.tree_util.tree_leaves(self.opt_state)
        arrays: dict[str, Any] = {f"param/{k}": np.asarray(v) for k, v in self.params.items()}
        arrays |= {f"adam/{i}": np.asarray(v) for i, v in enumerate(leaves)}
        arrays |= {"obs_mean": self.stats[0], "obs_var": self.stats[1], "obs_count": self.stats[2]}
        numbers = {
            "timesteps": self.timesteps,
            "learning_rate": self.rate,
            "value_scaler": self.scaler.state() if self.scaler is not None else None,
        }
        return arrays, numbers

    def restore(self, arrays: dict[str, np.ndarray], numbers: dict[str, Any]) -> None:
        """Go on from a checkpoint's :meth:`state`."""
        jnp = self.jax.numpy
        self.params = {k: jnp.asarray(arrays[f"param/{k}"]) for k in self.params}
        treedef = self.jax.tree_util.tree_structure(self.adam.init(self.params))
        leaves = [jnp.asarray(arrays[f"adam/{i}"]) for i in range(treedef.num_leaves)]
        self.opt_state = self.jax.tree_util.tree_unflatten(treedef, leaves)
        self.stats = (arrays["obs_mean"].copy(), arrays["obs_var"].copy(), arrays["obs_count"].copy())
        self.timesteps = int(numbers["timesteps"])
        self.rate = float(numbers["learning_rate"])
        if self.scaler is not None:
            self.scaler = RunningStandardScaler(*numbers["value_scaler"])

    # -- training ------------------------------------------------------------------------------------

    def _arguments(self) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """What :func:`gym4real.rl.rollout_kernel.step` takes besides a step's own values, fixed for a rollout.

        The arguments between ``observe`` and ``noise``, then those between ``noise`` and ``act``.
        """
        params = {k: np.asarray(v) for k, v in self.params.items()}
        net = (*network(params, self.arch, "pi"), *network(params, self.arch, "vf"))
        log_std = params.get("log_std", np.zeros(1, np.float32))
        scale = (self.scaler.mean, self.scaler.std, self.scaler.clip) if self.scaler is not None else (0.0, 1.0, 0.0)
        head = ((*self.stats, self.clip_obs, 1e-8), self.normalize, net, log_std)
        return head, (scale, self.bounds, self.rollout.buffers, self.rollout.env_actions)

    def start_episodes(self) -> None:
        """Reset every copy, seeded ``seed + timesteps``, into the rollout's first row."""
        obs, _ = self.venv.reset(seed=self.seed + self.timesteps)
        n = self.n_envs
        zeros = np.zeros(n, dtype=bool)
        self._raw = (np.asarray(obs, dtype=np.float32), np.zeros(n, np.float32), zeros, zeros)
        self.rollout.valid[0] = True
        head, tail = self._arguments()
        self.kernel.step(0, *self._raw, True, *head, np.zeros((n, self.arch.actions), np.float32), *tail, False)

    def iteration(self) -> np.ndarray:
        """Collect a rollout and update on it; return each epoch's mean KL estimate."""
        return self.learn(self.collect())

    def collect(self) -> dict[str, np.ndarray]:
        """Collect a rollout; return its rows as the update takes them (:func:`gym4real.rl.jax_update.losses`)."""
        jax = self.jax
        r, steps = self.rollout, self.rollout.steps
        iteration = self.timesteps // (steps * self.n_envs)  # its keys: from the seed and the iteration alone
        noise_key, self._update_key = jax.random.split(jax.random.fold_in(jax.random.PRNGKey(self.seed), iteration))
        noise = np.asarray(self._noise(noise_key))
        head, tail = self._arguments()
        step, venv, discrete = self.kernel.step, self.venv, self.arch.discrete
        env_actions = r.env_actions[:, 0].astype(np.int64) if discrete else r.env_actions
        raw = self._raw
        for t in range(steps):  # the hot loop: the env's step and one compiled call
            step(t, *raw, t > 0, *head, noise[t], *tail, True)
            if discrete:
                env_actions[:] = r.env_actions[:, 0]
            raw = step_arrays(venv, env_actions)  # the info no update reads is not built
        step(steps, *raw, True, *head, noise[-1], *tail, False)
        self._raw = raw
        self.timesteps += steps * self.n_envs
        gamma, lam = float(self.ppo["gamma"]), float(self.ppo["gae_lambda"])
        advantages, returns = self.kernel.advantages(r.rewards, r.values, r.terminated, r.truncated, gamma, lam)
        valid = r.rows("valid")
        old_values = r.rows("values")
        returns = returns.reshape(-1)
        if self.scaler is not None:  # skrl: the statistics take the values, then the returns
            self.scaler.update(old_values[valid])
            old_values = self.scaler.standardize(old_values)
            self.scaler.update(returns[valid])
            returns = self.scaler.standardize(returns)
        data = {
            "obs": r.rows("obs"),
            "actions": r.rows("actions"),
            "old_log_prob": r.rows("log_probs"),
            "old_values": old_values,
            "advantages": advantages.reshape(-1),
            "returns": returns,
            "valid": valid.astype(np.float32),
        }
        r.obs[0], r.values[0], r.valid[0] = r.obs[steps], r.values[steps], r.valid[steps]
        return data

    def learn(self, data: dict[str, np.ndarray]) -> np.ndarray:
        """Update on a rollout's rows (from :meth:`collect`); return each epoch's mean KL estimate."""
        jax = self.jax
        if not isinstance(self.schedule, KLAdaptive):
            self.rate = self.schedule(1.0 - self.timesteps / self.total)
        rate = jax.numpy.float32(self.rate)
        orders = self.epoch_orders(self._update_key, self.settings.rows, self.settings.n_epochs)
        self.params, self.opt_state, rate, kls = self.update(self.params, self.opt_state, rate, orders, data)
        self.rate = float(rate)
        return np.asarray(kls)

    def close(self) -> None:
        """Close the vector env."""
        self.venv.close()


def _checkpoint(folder: Path, slot: str, trainer: JaxPPO, record: dict[str, Any]) -> str:
    """Write the checkpoint into the slot the last one is not in, then name it in ``state.json`` (last, at once)."""
    slot = "b" if slot == "a" else "a"
    shutil.rmtree(folder / slot, ignore_errors=True)
    (folder / slot).mkdir(parents=True)
    arrays, numbers = trainer.state()
    np.savez(folder / slot / "state.npz", **arrays)
    state = {"slot": slot, **record, **numbers}
    write_whole(folder / "state.json", lambda tmp: tmp.write_text(json.dumps(state)))
    return slot


def train_jax(
    env_id: str,
    hp: dict[str, Any],
    seed: int,
    out: Path,
    progress: Progress | None = None,
    eval_beside: bool | None = None,
) -> tuple[Path, dict[str, int]]:
    """Train PPO with a preset; keep the best model on the validation episodes (see the module docstring).

    Args:
        env_id: A registered id with a native vector env.
        hp: A resolved PPO preset.
        seed: Seed of the run.
        out: The run's folder (a checkpoint there is resumed).
        progress: Called with (steps done, total) after each iteration.
        eval_beside: Run the checkpoint evaluations in a second process beside training (True), in-line
            (False), or beside when this process may use two cores (None,
            :func:`~gym4real.rl.checkpoint_evaluations.beside_by_default`). The results are the same.

    Returns ``model.npz`` and the counts of environment steps (``train``, ``eval``).
    """
    from gym4real.rl.checkpoint_evaluations import CheckpointEvaluations, beside_by_default
    from gym4real.rl.curves import LearningCurve

    trainer = JaxPPO(env_id, hp, seed)
    checkpoint = out / "checkpoint"
    state = json.loads((checkpoint / "state.json").read_text()) if (checkpoint / "state.json").exists() else None
    if state is not None:
        with np.load(checkpoint / state["slot"] / "state.npz", allow_pickle=False) as data:
            trainer.restore({k: data[k] for k in data.files}, state)
    eval_freq, total = int(hp["eval_freq"]), trainer.total
    evaluations = CheckpointEvaluations(
        env_id,
        hp.get("eval_env_kwargs") or hp.get("env_kwargs", {}),
        int(hp["eval_episodes"]),
        int(hp["eval_seed"]),
        beside_by_default() if eval_beside is None else eval_beside,
    )
    # a checkpoint's own evaluation was still running when it was written: it runs again, from its snapshot
    pending = bool(state and state.get("pending"))
    curve = LearningCurve.load(out, "timesteps", upto=trainer.timesteps - 1 if pending else trainer.timesteps)
    best = float(state["best"]) if state else -np.inf
    next_eval = int(state["next_eval"]) if state else min(eval_freq, total)
    eval_steps = int(state["eval_steps"]) if state else 0
    slot = state["slot"] if state else ""
    model_path = out / "model.npz"
    out.mkdir(parents=True, exist_ok=True)

    def settle() -> None:
        """Take the results of the evaluations submitted so far: the curve, and the best model."""
        nonlocal best, eval_steps
        for timesteps, model, rewards in evaluations.results():
            eval_steps += sum(len(r) for r in rewards)
            mean = curve.add(timesteps, [float(r.sum()) for r in rewards])
            if mean > best:
                best = mean
                write_whole(model_path, model.save)

    try:
        if pending:
            evaluations.submit(trainer.timesteps, trainer.model())
        trainer.start_episodes()
        while trainer.timesteps < total:
            trainer.iteration()
            if progress is not None:
                progress(trainer.timesteps, total)
            if trainer.timesteps >= next_eval and trainer.timesteps < total:
                next_eval += eval_freq
                settle()
                evaluations.submit(trainer.timesteps, trainer.model())
                record = {"best": best, "next_eval": next_eval, "eval_steps": eval_steps, "pending": True}
                slot = _checkpoint(checkpoint, slot, trainer, record)
                trainer.start_episodes()
        settle()
        if not curve.rows or curve.rows[-1]["timesteps"] < trainer.timesteps:
            evaluations.submit(trainer.timesteps, trainer.model())
            settle()
    finally:
        evaluations.close()
        trainer.close()
    shutil.rmtree(checkpoint, ignore_errors=True)
    return model_path, {"train": trainer.timesteps, "eval": eval_steps}
