"""PPO and DQN through Stable-Baselines3 (the ``rl`` extra), on the CPU with one thread.

A run writes ``model.zip`` (the best model on the validation episodes), ``normalize.npz`` (observation
statistics when the preset normalises observations; numpy, not pickle) and the learning curve. At every
evaluation it also writes a checkpoint (``checkpoint/``: the model, the normalisation statistics, DQN's
replay buffer as numpy arrays, the evaluation state); a run started again in the same folder resumes from
it, with fresh episodes in its environments.
"""

from __future__ import annotations

import inspect
import json
import shutil
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import ConfigError, PolicyError
from gym4real.rl.progress import Progress
from gym4real.rl.schedules import Constant, KLAdaptive, KLAdaptiveRate, schedule
from gym4real.rl.storage import write_whole

#: PyTorch's index of CPU-only wheels.
TORCH_CPU_INDEX = "https://download.pytorch.org/whl/cpu"


def _sb3() -> Any:
    try:
        import stable_baselines3
        import torch
    except ImportError as exc:
        msg = (
            f"PPO/DQN need the `rl` extra ({exc.name} is missing): install the CPU build of torch first, "
            f'`pip install torch --index-url {TORCH_CPU_INDEX}`, then `pip install "gym4real-core[rl]"` '
            "(a plain `pip install torch` on Linux pulls the multi-GB CUDA build)"
        )
        raise PolicyError(msg) from exc
    torch.set_num_threads(1)
    return stable_baselines3


ALGOS = {"ppo": "PPO", "dqn": "DQN"}


def rescaled(space: gym.Space[Any]) -> bool:
    """Whether training acts in ``[-1, 1]`` instead of ``space``: a bounded Box that is not already so.

    SB3's Gaussian policies start around 0 with unit scale, so they learn on ``[-1, 1]`` actions (the
    reference's dam PPO wraps its env in ``RescaleAction(-1, 1)`` too); policies map back to the bounds.
    """
    return (
        isinstance(space, gym.spaces.Box)
        and bool(np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high)))
        and not (np.all(space.low == -1) and np.all(space.high == 1))
    )


#: Constructor arguments the trainer sets itself, not through ``hyperparams``.
_SET_BY_TRAINER = {"self", "policy", "env", "policy_kwargs", "seed", "device", "verbose", "_init_setup_model"}


def _check_hyperparams(algo_cls: Any, hyperparams: dict[str, Any]) -> None:
    accepted = set(inspect.signature(algo_cls.__init__).parameters) - _SET_BY_TRAINER
    unknown = sorted(set(hyperparams) - accepted)
    if unknown:
        raise ConfigError(
            f"unknown field `hyperparams.{unknown[0]}` for {algo_cls.__name__}; expected some of {sorted(accepted)}"
        )


def _rescale(env: gym.Env[Any, Any]) -> gym.Env[Any, Any]:
    return gym.wrappers.RescaleAction(env, np.float32(-1.0), np.float32(1.0)) if rescaled(env.action_space) else env


class NormalizedPolicy:
    """A trained SB3 model as a deterministic ``obs -> action`` policy.

    Observations are normalised as in training; actions learnt on ``[-1, 1]`` are mapped onto the
    environment's bounds. With ``portable``, the network runs :mod:`gym4real.rl.portable_forward` (the same
    bits on every CPU) instead of torch.
    """

    def __init__(
        self, model: Any, stats: dict[str, Any] | None, action_space: gym.Space[Any], portable: bool = False
    ) -> None:
        self.model = model
        self.stats = stats
        self.portable = portable
        self.bounds = None
        if isinstance(action_space, gym.spaces.Box) and rescaled(action_space):
            self.bounds = (action_space.low, action_space.high)

    def _normalize(self, obs: Any) -> Any:
        if self.stats is None:
            return obs
        s, clip = self.stats, float(self.stats["clip_obs"])
        if isinstance(obs, dict):
            return {
                k: np.clip((obs[k] - s[f"mean/{k}"]) / np.sqrt(s[f"var/{k}"] + s["epsilon"]), -clip, clip) for k in obs
            }
        return np.clip((obs - s["mean"]) / np.sqrt(s["var"] + s["epsilon"]), -clip, clip)

    def _to_bounds(self, action: Any) -> Any:
        if self.bounds is None:
            return action
        low, high = self.bounds
        return (low + (np.clip(action, -1.0, 1.0) + 1.0) * 0.5 * (high - low)).astype(low.dtype)

    def __call__(self, obs: Any) -> Any:
        """Return the model's deterministic action."""
        if self.portable:  # a batch of one row
            row = {k: np.asarray(v)[None] for k, v in obs.items()} if isinstance(obs, dict) else np.asarray(obs)[None]
            return self.actions(row)[0]
        action, _ = self.model.predict(self._normalize(obs), deterministic=True)
        return self._to_bounds(action)

    def actions(self, obs: Any) -> np.ndarray:
        """The deterministic actions of a batch of observations (first axis), in one forward pass.

        Each row is what ``__call__`` gives for that observation alone, up to the floating-point rounding
        of a matrix product over a batch instead of one row.
        """
        import torch

        policy = self.model.policy
        if policy.training:  # switching every module costs more than the forward pass: once
            policy.set_training_mode(False)
        if self.portable:
            from gym4real.rl.portable_forward import deterministic_actions

            actions = deterministic_actions(policy, self._normalize(obs))
        else:
            tensor, _ = policy.obs_to_tensor(self._normalize(obs))
            with torch.inference_mode():
                actions = policy._predict(tensor, deterministic=True).cpu().numpy()
        space = policy.action_space
        actions = actions.reshape((-1, *space.shape))
        if isinstance(space, gym.spaces.Box) and policy.squash_output:  # as SB3's predict
            actions = policy.unscale_action(actions)
        elif isinstance(space, gym.spaces.Box):
            actions = np.clip(actions, space.low, space.high)
        return np.asarray(self._to_bounds(actions))


def load_model(env: gym.Env[Any, Any], path: str | Path, algo: str) -> NormalizedPolicy:
    """Load ``model.zip`` (and ``normalize.npz`` beside it) of ``algo`` as a policy for ``env``.

    ``algo`` is any algorithm Stable-Baselines3 ships (``a2c``, ``ddpg``, ``dqn``, ``ppo``, ``sac``, ``td3``)
    or sb3-contrib's ``crossq``, ``qrdqn``, ``tqc``, ``trpo``.

    The file is read as data (:mod:`gym4real.rl.model_file`): no entry of it is unpickled.

    Raises:
        PolicyError: An algorithm SB3 does not ship, not an SB3 model of ``algo``, a pickled entry SB3 does not
            write (named), or a model trained on other observation/action spaces.
    """
    from gym4real.core.registry import load_object
    from gym4real.rl.model_file import SB3_ALGOS, algo_name, custom_objects

    if algo not in SB3_ALGOS:
        raise PolicyError(f"unknown Stable-Baselines3 algorithm `{algo}`; expected one of {sorted(SB3_ALGOS)}")
    _sb3()
    path = Path(path)
    try:
        algo_cls = load_object(SB3_ALGOS[algo])
    except ImportError as exc:
        raise PolicyError(f"{algo_name(algo)} models need sb3-contrib: `pip install sb3-contrib`") from exc
    expected_actions = env.action_space
    if rescaled(env.action_space):
        expected_actions = gym.spaces.Box(-1.0, 1.0, env.action_space.shape, env.action_space.dtype)  # type: ignore[arg-type]
    objects = custom_objects(path, algo, algo_cls, env.observation_space, expected_actions)
    try:
        model = algo_cls.load(path, device="cpu", custom_objects=objects)
    except Exception as exc:  # a zip that passed the data check but whose weights do not fit
        raise PolicyError(f"`{path}` is not a loadable {algo_name(algo)} model for this environment: {exc}") from exc
    stats_path = path.with_name("normalize.npz")
    stats = dict(np.load(stats_path, allow_pickle=False)) if stats_path.exists() else None
    return NormalizedPolicy(model, stats, env.action_space, portable=portable_forward(env))


def portable_forward(env: gym.Env[Any, Any]) -> bool:
    """Whether ``env``'s evaluation protocol scores policies with the portable forward.

    As its :attr:`~gym4real.core.specs.BenchmarkSpec.portable_forward` says (False for an env without a protocol).
    """
    from gym4real.core.registry import base_env, registry

    spec = env.spec
    benchmark = registry().benchmarks.get(base_env(spec.id)) if spec is not None else None
    return benchmark is not None and benchmark.portable_forward


def load_ppo(env: gym.Env[Any, Any], path: str | Path) -> NormalizedPolicy:
    """Policy loader of ``ppo:PATH``."""
    return load_model(env, path, "ppo")


def load_dqn(env: gym.Env[Any, Any], path: str | Path) -> NormalizedPolicy:
    """Policy loader of ``dqn:PATH``."""
    return load_model(env, path, "dqn")


def _rms_arrays(vec: Any) -> dict[str, Any]:
    rms = vec.obs_rms
    data: dict[str, Any] = {"clip_obs": np.array(vec.clip_obs), "epsilon": np.array(vec.epsilon)}
    if isinstance(rms, dict):
        for k, r in rms.items():
            data[f"mean/{k}"], data[f"var/{k}"], data[f"count/{k}"] = r.mean, r.var, np.array(r.count)
    else:
        data["mean"], data["var"], data["count"] = rms.mean, rms.var, np.array(rms.count)
    ret = vec.ret_rms
    data["ret_mean"], data["ret_var"], data["ret_count"] = np.array(ret.mean), np.array(ret.var), np.array(ret.count)
    return data


def _save_normalization(vec: Any, path: Path) -> None:
    np.savez(path, **_rms_arrays(vec))


def _load_normalization(vec: Any, path: Path) -> None:
    with np.load(path, allow_pickle=False) as data:
        rms = vec.obs_rms
        for key, r in rms.items() if isinstance(rms, dict) else [("", rms)]:
            suffix = f"/{key}" if key else ""
            r.mean, r.var, r.count = data[f"mean{suffix}"], data[f"var{suffix}"], float(data[f"count{suffix}"])
        vec.ret_rms.mean, vec.ret_rms.var = data["ret_mean"], data["ret_var"]
        vec.ret_rms.count = float(data["ret_count"])


_BUFFER_FIELDS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def _save_buffer(buffer: Any, path: Path) -> None:
    """The filled part of a replay buffer as numpy arrays (SB3 saves it with pickle)."""
    end = buffer.buffer_size if buffer.full else buffer.pos
    arrays = {}
    for name in _BUFFER_FIELDS:
        value = getattr(buffer, name, None)
        if isinstance(value, dict):
            arrays.update({f"{name}/{k}": v[:end] for k, v in value.items()})
        elif value is not None:
            arrays[name] = value[:end]
    np.savez(path, pos=np.array(buffer.pos), full=np.array(buffer.full), **arrays)


def _load_buffer(buffer: Any, path: Path) -> None:
    with np.load(path, allow_pickle=False) as data:
        for key in data.files:
            if key in ("pos", "full"):
                continue
            name, _, sub = key.partition("/")
            target = getattr(buffer, name)
            target = target[sub] if sub else target
            target[: len(data[key])] = data[key]
        buffer.pos, buffer.full = int(data["pos"]), bool(data["full"])


def _algorithm(algo_cls: Any, hp: dict[str, Any], venv: Any, seed: int, state: dict[str, Any] | None) -> Any:
    """The SB3 algorithm of a preset, with its learning-rate schedule and value scaler.

    A constant rate goes to SB3 as a number (the model file then holds no pickled schedule); ``kl_adaptive``
    or ``value_scaler`` make it :class:`~gym4real.rl.skrl_ppo.SkrlPPO`, a resumed run's adaptive rate
    and value statistics restored from the checkpoint's ``state``.
    """
    hyperparams = dict(hp["hyperparams"])
    lr_schedule = schedule(hyperparams.pop("learning_rate"))
    rate = lr_schedule.initial if isinstance(lr_schedule, Constant) else lr_schedule
    policy = hp.get("policy", "MlpPolicy")
    common: dict[str, Any] = {"policy_kwargs": hp.get("policy_kwargs"), "seed": seed, "device": "cpu", "verbose": 0}
    if not isinstance(lr_schedule, KLAdaptive) and not hp.get("value_scaler"):
        return algo_cls(policy, venv, learning_rate=rate, **common, **hyperparams)
    from gym4real.rl.skrl_ppo import RunningStandardScaler, SkrlPPO

    skrl: dict[str, Any] = {"learning_rate": rate}
    if isinstance(lr_schedule, KLAdaptive):
        skrl = {"rate": KLAdaptiveRate(lr_schedule, state["learning_rate"] if state else None)}
    if hp.get("value_scaler"):
        skrl["value_scaler"] = RunningStandardScaler(*(state["value_scaler"] if state else ()))
    return SkrlPPO(policy, venv, **skrl, **common, **hyperparams)


def algorithm_state(model: Any) -> dict[str, Any]:
    """What a checkpoint saves beyond the weights for the run to go on as it would have.

    The learning rate its next update starts from (a ``kl_adaptive`` one is history, not progress) and the
    value scaler's statistics.
    """
    state: dict[str, Any] = {"learning_rate": float(model.lr_schedule(model._current_progress_remaining))}
    if getattr(model, "value_scaler", None) is not None:
        state["value_scaler"] = model.value_scaler.state()
    return state


def train_sb3(
    env_id: str, hp: dict[str, Any], seed: int, out: Path, progress: Progress | None = None
) -> tuple[Path, dict[str, int]]:
    """Train PPO or DQN with a preset; keep the best model on the validation episodes.

    Returns ``model.zip`` and the counts of environment steps (``train``, ``eval``).
    """
    sb3 = _sb3()
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecNormalize

    from gym4real.rl.curves import LearningCurve
    from gym4real.rl.evaluation import BatchEvaluation
    from gym4real.rl.vec_env import TrainingVecEnv

    algo = hp["algo"]
    if algo not in ALGOS:
        raise ConfigError(f"algo `{algo}` is not one of {sorted(ALGOS)}")
    n_envs = int(hp.get("n_envs", 1))
    vec_cls = SubprocVecEnv if hp.get("vec_env") == "subproc" and n_envs > 1 else TrainingVecEnv
    # render_mode=None: SB3 otherwise asks every env for "rgb_array"
    env_kwargs = {"render_mode": None, **hp.get("env_kwargs", {})}
    venv = make_vec_env(
        env_id, n_envs=n_envs, seed=seed, env_kwargs=env_kwargs, vec_env_cls=vec_cls, wrapper_class=_rescale
    )
    norm_obs, norm_rew = bool(hp.get("normalize_obs", False)), bool(hp.get("normalize_reward", False))
    if norm_obs or norm_rew:
        gamma = hp["hyperparams"].get("gamma", 0.99)
        venv = VecNormalize(venv, norm_obs=norm_obs, norm_reward=norm_rew, clip_obs=hp["clip_obs"], gamma=gamma)
    algo_cls = getattr(sb3, ALGOS[algo])
    _check_hyperparams(algo_cls, hp["hyperparams"])
    checkpoint = out / "checkpoint"
    state = json.loads((checkpoint / "state.json").read_text()) if (checkpoint / "state.json").exists() else None
    model = _algorithm(algo_cls, hp, venv, seed if state is None else seed + int(state["timesteps"]), state)
    if state is not None:
        saved = checkpoint / state.get("slot", "")  # (gym4real 0.2.0 wrote its files beside state.json)
        # the weights and optimizer states only (torch tensors, no pickle); the counters from state.json
        model.set_parameters(str(saved / "model.zip"), exact_match=True, device="cpu")
        model.num_timesteps = int(state["timesteps"])
        if hasattr(model, "_n_calls"):
            model._n_calls = int(state["n_calls"])
        if isinstance(venv, VecNormalize):
            _load_normalization(venv, saved / "normalize.npz")
        buffer = getattr(model, "replay_buffer", None)
        if buffer is not None and (saved / "buffer.npz").exists():
            _load_buffer(buffer, saved / "buffer.npz")
    model_path = out / "model.zip"
    eval_freq, eval_episodes, eval_seed = int(hp["eval_freq"]), int(hp["eval_episodes"]), int(hp["eval_seed"])
    evaluation = BatchEvaluation(
        env_id, hp.get("eval_env_kwargs") or hp.get("env_kwargs", {}), eval_episodes, eval_seed
    )
    total = int(hp["total_timesteps"])
    done_before = int(state["timesteps"]) if state else 0
    curve = LearningCurve.load(out, "timesteps", upto=done_before)

    class Evaluate(BaseCallback):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.best = float(state["best"]) if state else -np.inf
            self.next_eval = int(state["next_eval"]) if state else min(eval_freq, total)
            self.eval_steps = int(state["eval_steps"]) if state else 0
            self.slot = state.get("slot", "") if state else ""

        def _evaluate(self, save_checkpoint: bool = True) -> None:
            stats: dict[str, Any] | None = None
            if isinstance(venv, VecNormalize) and norm_obs:  # a copy: training goes on updating the statistics
                stats = {k: np.array(v) for k, v in _rms_arrays(venv).items()}
            rewards = evaluation.run(NormalizedPolicy(self.model, stats, evaluation.single_action_space))
            self.eval_steps += sum(len(r) for r in rewards)
            mean = curve.add(self.num_timesteps, [float(r.sum()) for r in rewards])
            if mean > self.best:
                self.best = mean
                if stats is not None:
                    write_whole(out / "normalize.npz", lambda tmp: np.savez(tmp, **stats))
                write_whole(model_path, self.model.save)
            if save_checkpoint:
                self._checkpoint()

        def _checkpoint(self) -> None:
            """Write the checkpoint into the slot the last one is not in, then name it in ``state.json``.

            ``state.json`` is replaced last and at once, so a run killed at any moment (a session's end,
            a lost node) still has the previous checkpoint whole and resumes from it.
            """
            slot = "b" if self.slot == "a" else "a"
            folder = checkpoint / slot
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir(parents=True)
            self.model.save(folder / "model.zip")
            if isinstance(venv, VecNormalize):
                _save_normalization(venv, folder / "normalize.npz")
            buffer = getattr(self.model, "replay_buffer", None)
            if buffer is not None:
                _save_buffer(buffer, folder / "buffer.npz")
            record = {
                "slot": slot,
                "timesteps": self.num_timesteps,
                "n_calls": getattr(self.model, "_n_calls", 0),
                "best": self.best,
                "next_eval": self.next_eval,
                "eval_steps": self.eval_steps,
                **algorithm_state(self.model),
            }
            write_whole(checkpoint / "state.json", lambda tmp: tmp.write_text(json.dumps(record)))
            self.slot = slot

        def _on_step(self) -> bool:
            if progress is not None:
                progress(self.num_timesteps, total)
            if self.num_timesteps >= self.next_eval:
                self.next_eval += eval_freq
                self._evaluate()
            return True

        def _on_training_end(self) -> None:
            if not curve.rows or curve.rows[-1]["timesteps"] < self.num_timesteps:
                self._evaluate(save_checkpoint=False)  # the run is over: its checkpoint is removed

    out.mkdir(parents=True, exist_ok=True)
    callback = Evaluate()
    model.learn(total_timesteps=max(total - done_before, 0), callback=callback, reset_num_timesteps=state is None)
    venv.close()
    evaluation.close()
    shutil.rmtree(checkpoint, ignore_errors=True)
    return model_path, {"train": int(model.num_timesteps), "eval": callback.eval_steps}
