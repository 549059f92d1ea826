"""The JAX PPO trainer (issue 43): each of SB3's semantics on the same batch, resume, determinism, model files."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("jax")
torch = pytest.importorskip("torch")
sb3 = pytest.importorskip("stable_baselines3")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from stable_baselines3.common.logger import configure  # noqa: E402

import gym4real  # noqa: E402
from gym4real.core.errors import ConfigError, PolicyError  # noqa: E402
from gym4real.rl import rollout_kernel  # noqa: E402
from gym4real.rl.actor_critic import (  # noqa: E402
    ACTION_GAIN,
    HIDDEN_GAIN,
    VALUE_GAIN,
    Model,
    architecture,
    initial_parameters,
    load,
    mlp,
    network,
)
from gym4real.rl.jax_ppo import PPO_DEFAULTS, JaxPPO, jax_modules  # noqa: E402
from gym4real.rl.jax_update import UpdateSettings, epoch_orders, make_update, optimizer  # noqa: E402
from gym4real.rl.presets import load_preset  # noqa: E402
from gym4real.rl.schedules import KLAdaptive, KLAdaptiveRate  # noqa: E402
from gym4real.rl.train import train  # noqa: E402

DAM = "gym4real/dam-v0"

#: A tiny dam run: two copies of 20-day episodes (autoresets inside every rollout), four iterations.
TINY_DAM = """
algo: ppo
total_timesteps: 256
n_envs: 2
normalize_obs: true
clip_obs: 5.0
value_scaler: true
policy_kwargs: {net_arch: [8, 8], log_std_init: -0.5}
hyperparams:
  learning_rate: {schedule: kl_adaptive, initial: 1.0e-3, kl_threshold: 0.008}
  n_steps: 32
  batch_size: 24
  n_epochs: 2
  gamma: 0.995
env_kwargs: {preset: train, sim_horizon: 20}
eval_env_kwargs: {preset: validation, sim_horizon: 10}
eval_freq: 128
eval_episodes: 2
"""


def _tiny(tmp_path: Path, text: str = TINY_DAM) -> str:
    path = tmp_path / "tiny.yaml"
    path.write_text(text)
    return str(path)


# -- SB3's settings and initialisation --------------------------------------------------------------


def test_ppo_defaults_are_sb3s() -> None:
    defaults = {k: p.default for k, p in inspect.signature(sb3.PPO.__init__).parameters.items()}
    assert {k: defaults[k] for k in PPO_DEFAULTS} == PPO_DEFAULTS


def _sb3_ppo(env_id: str, **kwargs: Any) -> Any:
    model = sb3.PPO("MlpPolicy", gym.make(env_id), device="cpu", seed=0, **kwargs)
    model.set_logger(configure(None, []))
    return model


def _params_of(model: Any) -> dict[str, np.ndarray]:
    """The SB3 policy's parameters under the trainer's names (weights transposed to inputs x outputs)."""
    state = {k: v.detach().numpy() for k, v in model.policy.state_dict().items()}
    params: dict[str, np.ndarray] = {}
    for net, torch_net, head in (("pi", "policy_net", "action_net"), ("vf", "value_net", "value_net")):
        layers = sorted({int(k.split(".")[2]) for k in state if k.startswith(f"mlp_extractor.{torch_net}.")})
        for i, layer in enumerate(layers):
            params[f"{net}/{i}/w"] = state[f"mlp_extractor.{torch_net}.{layer}.weight"].T.copy()
            params[f"{net}/{i}/b"] = state[f"mlp_extractor.{torch_net}.{layer}.bias"].copy()
        params[f"{net}/out/w"] = state[f"{head}.weight"].T.copy()
        params[f"{net}/out/b"] = state[f"{head}.bias"].copy()
    if "log_std" in state:
        params["log_std"] = state["log_std"].copy()
    return params


@pytest.mark.parametrize("env_id", ["Pendulum-v1", "CartPole-v1"])
def test_initial_parameters_are_sb3s_orthogonal_initialisation(env_id: str) -> None:
    kwargs = {"net_arch": [16, 8], "log_std_init": -1.0}
    model = _sb3_ppo(env_id, policy_kwargs=kwargs if env_id == "Pendulum-v1" else {"net_arch": [16, 8]})
    env = gym.make(env_id)
    arch = architecture(env.observation_space, env.action_space, kwargs)
    ours, theirs = initial_parameters(arch, -1.0, seed=3), _params_of(model)
    assert {k: v.shape for k, v in ours.items()} == {k: v.shape for k, v in theirs.items()}
    for name, w in ours.items():
        if name.endswith("/b"):
            assert not w.any() and not theirs[name].any()
            continue
        if name == "log_std":
            np.testing.assert_array_equal(w, theirs[name])
            continue
        gain = ACTION_GAIN if name == "pi/out/w" else VALUE_GAIN if name == "vf/out/w" else HIDDEN_GAIN
        for matrix in (w, theirs[name]):  # orthogonal rows or columns (the fewer), times the gain
            gram = matrix.T @ matrix if matrix.shape[0] >= matrix.shape[1] else matrix @ matrix.T
            np.testing.assert_allclose(gram, gain**2 * np.eye(len(gram)), atol=1e-5)


def test_the_three_forward_passes_agree() -> None:
    env = gym.make("Pendulum-v1")
    arch = architecture(env.observation_space, env.action_space, {"net_arch": [16, 8]})
    params = initial_parameters(arch, 0.0, seed=1)
    params["pi/out/w"] = params["pi/out/w"] * 100  # heads of a trained size
    x = np.random.default_rng(0).standard_normal((5, 3)).astype(np.float32)
    weights, biases = network(params, arch, "pi")
    expected = mlp(weights, biases, x)
    np.testing.assert_allclose(rollout_kernel._mlp(weights, biases, x), expected, rtol=1e-5, atol=1e-6)
    from gym4real.rl.jax_update import _mlp

    jparams = {k: jnp.asarray(v) for k, v in params.items()}
    np.testing.assert_allclose(
        np.asarray(_mlp(jparams, arch.layers("pi"), jnp.asarray(x))), expected, rtol=1e-5, atol=1e-6
    )


# -- the update against SB3's train() on the same batch ----------------------------------------------


def _filled_buffer(model: Any, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Fill SB3's rollout buffer with a batch of the policy's own actions (old log-probs perturbed)."""
    buf = model.rollout_buffer
    buf.reset()
    n = buf.buffer_size
    space = model.observation_space
    obs = rng.uniform(-1, 1, (n, 1, *space.shape)).astype(np.float32)
    for t in range(n):
        with torch.no_grad():
            tensor = torch.as_tensor(obs[t])
            actions, values, log_prob = model.policy(tensor)
        noise = torch.as_tensor(rng.normal(0, 0.3, 1), dtype=torch.float32)
        buf.add(obs[t], actions.numpy(), rng.normal(0, 1, 1), np.array([t % 17 == 0]), values, log_prob + noise)
    buf.compute_returns_and_advantage(torch.as_tensor(rng.normal(0, 1, 1)), np.array([False]))
    return {
        "obs": buf.observations.reshape(n, -1),
        "actions": buf.actions.reshape(n, -1),
        "old_log_prob": buf.log_probs.reshape(n),
        "old_values": buf.values.reshape(n),
        "advantages": buf.advantages.reshape(n),
        "returns": buf.returns.reshape(n),
        "valid": np.ones(n, dtype=np.float32),
    }


def _settings(model: Any, arch: Any, kl: KLAdaptive | None = None) -> UpdateSettings:
    vf = model.clip_range_vf(1.0) if model.clip_range_vf is not None else None
    return UpdateSettings(
        arch=arch,
        rows=model.rollout_buffer.buffer_size,
        n_epochs=model.n_epochs,
        batch_size=model.batch_size,
        clip_range=model.clip_range(1.0),
        clip_range_vf=vf,
        ent_coef=model.ent_coef,
        vf_coef=model.vf_coef,
        max_grad_norm=model.max_grad_norm,
        normalize_advantage=model.normalize_advantage,
        kl_adaptive=kl,
    )


def _run_update(model: Any, data: dict[str, np.ndarray], rate: float, kl: KLAdaptive | None = None) -> Any:
    env = model.get_env()
    kwargs = {"net_arch": model.policy.net_arch}
    arch = architecture(env.observation_space, env.action_space, kwargs)
    params = {k: jnp.asarray(v) for k, v in _params_of(model).items()}
    settings = _settings(model, arch, kl)
    update = make_update(settings)
    orders = epoch_orders(jax.random.PRNGKey(0), settings.rows, settings.n_epochs)
    out = update(params, optimizer().init(params), jnp.float32(rate), orders, data)
    return out, update


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("Pendulum-v1", {"max_grad_norm": 0.05, "ent_coef": 0.01, "clip_range_vf": 0.3}),  # gradients clipped
        ("Pendulum-v1", {"max_grad_norm": 50.0, "clip_range": 0.1}),  # not clipped
        ("CartPole-v1", {"max_grad_norm": 0.5, "ent_coef": 0.02}),  # categorical
    ],
)
def test_an_update_equals_sb3s_train_on_the_same_batch(env_id: str, kwargs: dict[str, Any]) -> None:
    """Losses, advantage normalisation, gradients, clipping and Adam (eps 1e-5) over three epochs.

    One mini-batch per epoch holds every row: the permutation only reorders the rows of a mean.
    """
    policy_kwargs = {"net_arch": [16, 8], **({"log_std_init": -0.5} if env_id == "Pendulum-v1" else {})}
    model = _sb3_ppo(
        env_id, n_steps=64, batch_size=64, n_epochs=3, learning_rate=3e-3, policy_kwargs=policy_kwargs, **kwargs
    )
    data = _filled_buffer(model, np.random.default_rng(7))
    (params, _, _, _), _ = _run_update(model, data, 3e-3)
    model.train()
    after = _params_of(model)
    assert set(after) == set(params)
    for name, value in after.items():
        np.testing.assert_allclose(np.asarray(params[name]), value, rtol=2e-4, atol=2e-6, err_msg=name)


@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size")
def test_invalid_and_padding_rows_weigh_nothing() -> None:
    """A mini-batch with rows of weight 0 (autoreset steps, the padding of a short last mini-batch, as SB3's
    16-row last batch of 64 rows in batches of 48) has the loss and gradient of its valid rows alone."""
    from gym4real.rl.jax_update import losses

    model = _sb3_ppo("Pendulum-v1", n_steps=64, batch_size=48, n_epochs=1, learning_rate=1e-3)
    data = _filled_buffer(model, np.random.default_rng(2))
    env = model.get_env()
    arch = architecture(env.observation_space, env.action_space, {"net_arch": model.policy.net_arch})
    settings = _settings(model, arch)
    assert settings.minibatches == 2
    params = {k: jnp.asarray(v) for k, v in _params_of(model).items()}
    last = {k: jnp.asarray(v[48:]) for k, v in data.items()}
    padded = {
        k: jnp.asarray(np.concatenate([v[48:], np.zeros(32, np.float32) if k == "valid" else v[:32] * 0 + 1e6]))
        for k, v in data.items()
    }
    grad = jax.value_and_grad(losses, has_aux=True)
    (loss_a, kl_a), grads_a = grad(params, settings, last)
    (loss_b, kl_b), grads_b = grad(params, settings, padded)
    assert float(loss_a) == pytest.approx(float(loss_b), rel=1e-6) and float(kl_a) == pytest.approx(float(kl_b))
    for name in grads_a:
        np.testing.assert_allclose(np.asarray(grads_a[name]), np.asarray(grads_b[name]), rtol=1e-5, atol=1e-7)


def test_the_kl_adaptive_rate_follows_skrl_ppo_epoch_by_epoch() -> None:
    from gym4real.rl.skrl_ppo import SkrlPPO

    spec = KLAdaptive(schedule="kl_adaptive", initial=3e-3, kl_threshold=1e-4)
    model = SkrlPPO(
        "MlpPolicy",
        gym.make("Pendulum-v1"),
        rate=KLAdaptiveRate(spec),
        n_steps=64,
        batch_size=64,
        n_epochs=4,
        policy_kwargs={"net_arch": [16, 8]},
        device="cpu",
        seed=0,
    )
    model.set_logger(configure(None, []))
    data = _filled_buffer(model, np.random.default_rng(4))
    (params, _, rate, kls), _ = _run_update(model, data, spec.initial, spec)
    model.train()
    np.testing.assert_allclose(np.asarray(kls), model.epoch_kls, rtol=1e-3)
    assert model.rate is not None and float(rate) == pytest.approx(model.rate.rate, rel=1e-6)
    assert float(rate) != spec.initial  # the KLs crossed the band: the rate moved
    for name, value in _params_of(model).items():
        np.testing.assert_allclose(np.asarray(params[name]), value, rtol=2e-4, atol=2e-6, err_msg=name)


# -- the rollout kernel: statistics, actions, advantages ---------------------------------------------


def test_observation_statistics_are_vecnormalizes_without_the_final_observations() -> None:
    from stable_baselines3.common.running_mean_std import RunningMeanStd

    rng = np.random.default_rng(0)
    rms = RunningMeanStd(shape=(3,))
    mean, var, count = np.zeros(3), np.ones(3), np.array([1e-4])
    out = np.zeros((4, 3), np.float32)
    for _ in range(5):
        raw = rng.normal(5, 3, (4, 3)).astype(np.float32)
        ended = rng.random(4) < 0.3
        rms.update(raw[~ended])
        rollout_kernel._observe(raw, ended, (mean, var, count, 10.0, 1e-8), True, out)
        np.testing.assert_allclose(mean, rms.mean, rtol=1e-6)
        np.testing.assert_allclose(var, rms.var, rtol=1e-5)
        assert count[0] == pytest.approx(rms.count)
        expected = np.clip((raw - rms.mean) / np.sqrt(rms.var + 1e-8), -10, 10).astype(np.float32)
        np.testing.assert_allclose(out, expected, rtol=1e-5, atol=1e-6)


def _kernel_buffers(steps: int, n: int, obs_dim: int, width: int) -> tuple[np.ndarray, ...]:
    return (
        np.zeros((steps + 1, n, obs_dim), np.float32),
        np.zeros((steps, n, width), np.float32),
        np.zeros((steps + 1, n), np.float32),
        np.zeros((steps, n), np.float32),
        np.zeros((steps, n), np.float32),
        np.zeros((steps, n), bool),
        np.zeros((steps, n), bool),
        np.ones((steps + 1, n), bool),
    )


@pytest.mark.parametrize("env_id", ["Pendulum-v1", "CartPole-v1"])
def test_rollout_actions_log_probs_and_values_are_the_policys(env_id: str) -> None:
    """Gaussian: mean + std * noise, clipped to [-1, 1], mapped onto the Box; categorical: Gumbel-max."""
    model = _sb3_ppo(env_id, policy_kwargs={"net_arch": [16, 8]})
    env = gym.make(env_id)
    arch = architecture(env.observation_space, env.action_space, {"net_arch": [16, 8]})
    params = _params_of(model)
    n, rng = 64, np.random.default_rng(1)
    obs = rng.normal(0, 1, (n, arch.obs_dim)).astype(np.float32)
    discrete = isinstance(env.action_space, gym.spaces.Discrete)
    noise = (rng.gumbel if discrete else rng.standard_normal)(size=(n, arch.actions)).astype(np.float32) * 3
    buffers = _kernel_buffers(1, n, arch.obs_dim, 1 if discrete else arch.actions)
    buffers[0][0] = obs
    env_actions = np.zeros((n, 1 if discrete else arch.actions), np.float32)
    net = (*network(params, arch, "pi"), *network(params, arch, "vf"))
    log_std = params.get("log_std", np.zeros(1, np.float32))
    if discrete:
        bounds = (np.array([0.0], np.float32), np.array([1.0], np.float32), 2)
    else:
        bounds = (np.array([-2.0], np.float32), np.array([2.0], np.float32), 0)
    none = np.zeros(n, bool)
    stats = (np.zeros(arch.obs_dim), np.ones(arch.obs_dim), np.ones(1), 10.0, 1e-8)
    rollout_kernel.step(
        0,
        obs,
        none.astype(np.float32),
        none,
        none,
        False,
        stats,
        False,
        net,
        log_std,
        noise,
        (0.0, 1.0, 0.0),
        bounds,
        buffers,
        env_actions,
        True,
    )
    actions, values, log_probs = buffers[1][0], buffers[2][0], buffers[3][0]
    with torch.no_grad():
        tensor = torch.as_tensor(obs)
        their_values, their_log_probs, _ = model.policy.evaluate_actions(
            tensor, torch.as_tensor(actions[:, 0] if discrete else actions)
        )
        head = mlp(*network(params, arch, "pi"), obs)
    np.testing.assert_allclose(values, their_values.numpy()[:, 0], rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(log_probs, their_log_probs.numpy(), rtol=1e-5, atol=1e-5)
    if discrete:
        np.testing.assert_array_equal(actions[:, 0], np.argmax(head + noise, axis=1))
        np.testing.assert_array_equal(env_actions, actions)
    else:
        np.testing.assert_allclose(actions, head + np.exp(log_std) * noise, rtol=1e-5, atol=1e-6)
        assert (np.abs(actions) > 1).any()  # some are clipped before the mapping
        mapped = -2.0 + (np.clip(actions, -1, 1) + 1.0) * 0.5 * 4.0
        np.testing.assert_allclose(env_actions, mapped, rtol=1e-6, atol=1e-6)


def test_advantages_are_sb3s_gae_and_truncations_bootstrap_from_the_final_observation() -> None:
    from stable_baselines3.common.buffers import RolloutBuffer

    steps, n, gamma, lam = 40, 3, 0.97, 0.9
    rng = np.random.default_rng(3)
    rewards = rng.normal(0, 1, (steps, n)).astype(np.float32)
    values = rng.normal(0, 1, (steps + 1, n)).astype(np.float32)
    terminated = rng.random((steps, n)) < 0.1
    none = np.zeros((steps, n), bool)
    adv, ret = rollout_kernel.advantages(rewards, values, terminated, none, gamma, lam)
    buf = RolloutBuffer(
        steps, gym.spaces.Box(-1, 1, (1,)), gym.spaces.Box(-1, 1, (1,)), n_envs=n, gamma=gamma, gae_lambda=lam
    )
    starts = np.vstack([np.zeros((1, n), bool), terminated[:-1]])
    for t in range(steps):
        buf.add(np.zeros((n, 1)), np.zeros((n, 1)), rewards[t], starts[t], torch.as_tensor(values[t]), torch.zeros(n))
    buf.compute_returns_and_advantage(torch.as_tensor(values[steps]), terminated[-1])
    np.testing.assert_allclose(adv, buf.advantages, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(ret, buf.returns, rtol=1e-5, atol=1e-5)
    # a truncated step: its reward plus gamma times the value of its final observation (the next row)
    truncated = none.copy()
    truncated[10, 1] = True
    adv, _ = rollout_kernel.advantages(rewards, values, none, truncated, gamma, lam)
    expected = rewards[10, 1] + gamma * values[11, 1] - values[10, 1]
    assert adv[10, 1] == pytest.approx(expected, rel=1e-5)


# -- the trainer ------------------------------------------------------------------------------------


def test_the_update_is_compiled_once_and_the_rate_follows_its_schedule(tmp_path: Path) -> None:
    text = TINY_DAM.replace(
        "{schedule: kl_adaptive, initial: 1.0e-3, kl_threshold: 0.008}", "{schedule: cosine, initial: 1.0e-3}"
    )
    hp = load_preset(DAM, "ppo", _tiny(tmp_path, text))
    trainer = JaxPPO(DAM, hp, seed=0)
    trainer.start_episodes()
    rows = 64
    for k in range(1, 4):
        trainer.iteration()
        assert trainer.rate == pytest.approx(1e-3 * 0.5 * (1 + np.cos(np.pi * k * rows / 256)))
    assert trainer.update._cache_size() == 1  # type: ignore[attr-defined]  # jax.jit's compilations
    assert not trainer.rollout.valid.all()  # the 20-day episodes end inside the rollouts: autoreset rows


def test_value_statistics_take_the_values_then_the_returns_of_the_valid_rows(tmp_path: Path) -> None:
    hp = load_preset(DAM, "ppo", _tiny(tmp_path))
    trainer = JaxPPO(DAM, hp, seed=0)
    trainer.start_episodes()
    trainer.iteration()
    valid = trainer.rollout.valid[:32].sum()
    assert trainer.scaler is not None and trainer.scaler.count == 1 + 2 * valid


# -- whole iterations on dam against SB3's trainer (the dam paper preset's features) -------------------

#: The dam paper preset's PPO at a test's size: one env, normalised observations clipped at 5, standardised
#: value targets, the KL-adaptive rate (started high enough to move both ways within a few iterations).
DAM_PAPER_LIKE = """
algo: ppo
total_timesteps: 100000
n_envs: 1
normalize_obs: true
clip_obs: 5.0
value_scaler: true
policy_kwargs: {net_arch: [16, 16], log_std_init: -0.5}
hyperparams:
  learning_rate: {schedule: kl_adaptive, initial: 8.0e-4, kl_threshold: 0.008}
  n_steps: STEPS
  batch_size: BATCH
  n_epochs: 4
  gamma: 0.995
env_kwargs: {preset: train, sim_horizon: HORIZON}
eval_env_kwargs: {preset: validation, sim_horizon: 10}
eval_freq: 100000
eval_episodes: 1
"""


def _paired_iterations(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, horizon: int, steps: int, batch: int, sb3_steps: int, count: int
) -> Any:
    """Iterations of the JAX trainer and of SB3's (as ``train_sb3`` builds it) on the same draws; yield each.

    SB3's trainer: ``SkrlPPO`` (KL-adaptive rate, value scaler) on ``VecNormalize`` over the single DamEnv
    (``TrainingVecEnv``, ``RescaleAction``), started from the JAX trainer's parameters. Its Gaussian draws are
    the JAX trainer's of the valid rows, its mini-batch permutations the JAX update's. ``sb3_steps`` is SB3's
    ``n_steps``: the JAX trainer's rollout holds one autoreset row more per episode end.

    Yields:
        ``(trainer, model, rows, valid, jax_kls, sb3_kls)`` after each iteration's update.
    """
    from stable_baselines3.common.distributions import DiagGaussianDistribution
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    from gym4real.rl.sb3 import _algorithm, _rescale
    from gym4real.rl.vec_env import TrainingVecEnv

    text = DAM_PAPER_LIKE.replace("STEPS", str(steps)).replace("BATCH", str(batch)).replace("HORIZON", str(horizon))
    hp = load_preset(DAM, "ppo", _tiny(tmp_path, text))
    trainer = JaxPPO(DAM, hp, seed=0)
    env_kwargs = {"render_mode": None, **hp["env_kwargs"]}
    venv = make_vec_env(DAM, 1, seed=0, env_kwargs=env_kwargs, vec_env_cls=TrainingVecEnv, wrapper_class=_rescale)
    venv = VecNormalize(venv, norm_obs=True, norm_reward=False, clip_obs=hp["clip_obs"], gamma=0.995)
    sb3_batch = batch if sb3_steps == steps else sb3_steps  # the whole rollout, when the rows differ
    sb3_hp = {**hp, "hyperparams": {**hp["hyperparams"], "n_steps": sb3_steps, "batch_size": sb3_batch}}
    model = _algorithm(sb3.PPO, sb3_hp, venv, 0, None)
    model.set_logger(configure(None, []))
    trainer.params = {k: jnp.asarray(v) for k, v in _params_of(model).items()}
    trainer.opt_state = trainer.adam.init(trainer.params)
    _, callback = model._setup_learn(hp["total_timesteps"], None)  # resets the env, seeded 0
    callback.on_training_start(locals(), globals())
    trainer.start_episodes()  # seeded 0 too: the same first year
    draws: list[np.ndarray] = []
    noise = trainer._noise

    def recorded_noise(key: Any) -> np.ndarray:
        draws.append(np.asarray(noise(key)))
        return draws[-1]

    monkeypatch.setattr(trainer, "_noise", recorded_noise)
    queue: list[np.ndarray] = []

    def sample(self: Any) -> Any:
        return self.distribution.mean + self.distribution.stddev * torch.as_tensor(queue.pop(0))

    monkeypatch.setattr(DiagGaussianDistribution, "sample", sample)
    orders: list[np.ndarray] = []
    permutation = np.random.permutation
    monkeypatch.setattr(np.random, "permutation", lambda n: orders.pop(0) if n == steps else permutation(n))
    for _ in range(count):
        rows = trainer.collect()
        valid = rows["valid"].astype(bool)
        queue[:] = list(draws[-1][:, 0][valid])
        model.collect_rollouts(venv, callback, model.rollout_buffer, model.n_steps)
        assert not queue  # SB3 drew one action per valid row
        keys = jax.random.split(trainer._update_key, trainer.settings.n_epochs)
        orders[:] = [np.asarray(jax.random.permutation(k, trainer.settings.rows)) for k in keys]
        jax_kls = trainer.learn(rows)
        done = len(model.epoch_kls)
        model.train()
        yield trainer, model, rows, valid, jax_kls, model.epoch_kls[done:]


def _assert_near(ours: Any, theirs: Any, tol: float, name: str) -> None:
    """Equal within ``tol`` times the larger of 1 and SB3's largest magnitude."""
    theirs = np.asarray(theirs, dtype=float).ravel()
    atol = tol * max(1.0, float(np.abs(theirs).max()))
    np.testing.assert_allclose(np.asarray(ours, dtype=float).ravel(), theirs, rtol=0, atol=atol, err_msg=name)


def _assert_state_matches(trainer: JaxPPO, model: Any, jax_kls: Any, sb3_kls: Any, tol: float) -> None:
    """The value scaler's statistics and the weights (within ``tol``), the epochs' KLs (within ``5 tol``), the
    observation statistics and the adapted rate."""
    assert trainer.scaler is not None and model.value_scaler is not None
    mean, var, count = trainer.scaler.state()
    their_mean, their_var, their_count = model.value_scaler.state()
    assert count == their_count
    assert mean == pytest.approx(their_mean, rel=tol) and var == pytest.approx(their_var, rel=tol)
    rms = model.get_env().obs_rms
    np.testing.assert_allclose(trainer.stats[0], rms.mean, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(trainer.stats[1], rms.var, rtol=1e-6)
    assert trainer.stats[2][0] == pytest.approx(rms.count)
    np.testing.assert_allclose(jax_kls, sb3_kls, rtol=max(1e-3, 5 * tol), atol=1e-7)
    assert model.rate is not None and trainer.rate == pytest.approx(model.rate.rate, rel=1e-6)
    for name, value in _params_of(model).items():
        _assert_near(trainer.params[name], value, tol, name)


@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size")
def test_consecutive_iterations_on_dam_equal_sb3s_with_the_kl_adaptive_rate_and_the_value_scaler(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Four iterations of 64 days in a year (no episode end): each rollout's rows (normalised observations,
    actions, log-probabilities, standardised values and returns, advantages), then the scaler's and the
    observations' statistics, each epoch's KL, the adapted rate and the weights after the update."""
    rates = []
    for trainer, model, rows, valid, jax_kls, sb3_kls in _paired_iterations(tmp_path, monkeypatch, 365, 64, 16, 64, 4):
        assert valid.all()
        buffer = model.rollout_buffer
        for ours, theirs in (
            ("obs", buffer.observations),
            ("actions", buffer.actions),
            ("old_log_prob", buffer.log_probs),
            ("old_values", buffer.values),
            ("advantages", buffer.advantages),
            ("returns", buffer.returns),
        ):
            _assert_near(rows[ours], theirs, 1e-5, ours)
        _assert_state_matches(trainer, model, jax_kls, sb3_kls, 2e-5)
        rates.append(trainer.rate)
    steps = np.diff([8e-4, *rates])
    assert (steps > 0).any() and (steps < 0).any()  # the rate went up and down


@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size")
def test_truncated_years_on_dam_are_bootstrapped_and_normalised_as_sb3_does(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ten-day years, two iterations of three years each (33 rows with their autoreset rows, SB3's 30).

    The valid rows equal SB3's: each year's last reward bootstrapped with the value of its final observation,
    that observation left out of the statistics, the reset one merged. One difference is by design (see
    :mod:`gym4real.rl.rollout_kernel`): SB3 normalises the final observation after merging the reset one,
    the JAX trainer before (it arrives a step later), so the bootstrap values differ by the weight of one
    observation in the statistics (here 1 in 11 to 61; in a paper run 1 in hundreds to hundreds of thousands):
    advantages and returns to 2e-3, and the weights a step later to 1e-3.
    """
    for trainer, model, rows, valid, jax_kls, sb3_kls in _paired_iterations(tmp_path, monkeypatch, 10, 33, 33, 30, 2):
        assert valid.sum() == 30 and not valid[[10, 21, 32]].any()
        buffer = model.rollout_buffer
        for ours, theirs, tol in (
            ("obs", buffer.observations, 1e-5),
            ("actions", buffer.actions, 1e-5),
            ("old_log_prob", buffer.log_probs, 1e-5),
            ("advantages", buffer.advantages, 2e-3),
            ("returns", buffer.returns, 2e-3),
        ):
            _assert_near(rows[ours][valid], theirs, tol, ours)
        _assert_state_matches(trainer, model, jax_kls, sb3_kls, 1e-3)


def test_a_dam_model_acts_as_the_sb3_policy_that_selection_and_evaluate_run() -> None:
    """The validation-selected checkpoint and the test scores rest on deterministic actions: a JAX model's equal
    SB3's ``NormalizedPolicy`` (VecNormalize's statistics, the Gaussian's mean clipped to [-1, 1], mapped onto
    the release box) for the same weights and statistics, inside and outside the clip ranges."""
    from gym4real.rl.actor_critic import Normalization
    from gym4real.rl.sb3 import NormalizedPolicy

    env = gym.make(DAM)
    box, space = env.action_space, env.observation_space
    assert isinstance(box, gym.spaces.Box) and isinstance(space, gym.spaces.Box)
    model = sb3.PPO(
        "MlpPolicy",
        gym.wrappers.RescaleAction(env, np.float32(-1.0), np.float32(1.0)),
        policy_kwargs={"net_arch": [16, 16], "log_std_init": -0.5},
        device="cpu",
        seed=0,
    )
    with torch.no_grad():
        model.policy.action_net.weight.mul_(300.0)  # a trained head's size: some means beyond [-1, 1]
    rng = np.random.default_rng(5)
    dim = space.shape[0]
    mean, var = rng.normal(0, 50, dim), rng.uniform(0.5, 400, dim)
    stats = {"mean": mean, "var": var, "count": np.array(99.0), "clip_obs": np.array(5.0), "epsilon": np.array(1e-8)}
    obs = (mean + rng.normal(0, 8, (200, dim)) * np.sqrt(var)).astype(np.float32)  # some beyond the obs clip
    arch = architecture(space, box, {"net_arch": [16, 16]})
    ours = Model(arch, _params_of(model), Normalization(mean, var, 99.0, 5.0), space, box, True)
    theirs = NormalizedPolicy(model, stats, box).actions(obs)
    actions = ours.actions(obs)
    assert (actions == box.low[0]).any() and (actions == box.high[0]).any()
    assert ours.normalization is not None and (np.abs(ours.normalization(obs)) == 5.0).any()
    np.testing.assert_allclose(actions, theirs, rtol=1e-5, atol=1e-3)


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


#: Evaluations at 64, 128 and 192 steps and at the end.
EVERY_64 = TINY_DAM.replace("eval_freq: 128", "eval_freq: 64")


@pytest.mark.parametrize("beside", [False, True])
def test_a_resumed_run_equals_an_uninterrupted_one(tmp_path: Path, beside: bool) -> None:
    """Cut while its checkpoint's evaluation is pending, resumed in the other mode of evaluation."""
    preset = _tiny(tmp_path, EVERY_64)
    whole = train(DAM, "ppo", preset, seed=1, out=tmp_path / "whole", trainer="jax", eval_beside=beside)

    def stop(done: int, total: int) -> None:
        if done >= 192:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        train(DAM, "ppo", preset, seed=1, out=tmp_path / "cut", progress=stop, trainer="jax", eval_beside=beside)
    state = json.loads((tmp_path / "cut" / "checkpoint" / "state.json").read_text())
    assert state["timesteps"] == 128 and state["pending"]
    resumed = train(DAM, "ppo", preset, seed=1, out=tmp_path / "cut", trainer="jax", eval_beside=not beside)
    a, b = _arrays(whole.model_path), _arrays(resumed.model_path)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    assert whole.curve_csv.read_text() == resumed.curve_csv.read_text()
    record = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert record["trainer"] == "jax" and record["resumes"][0]["at"] == 128
    assert {"jax", "jaxlib", "optax"} <= set(record["versions"])
    assert whole.policy == f"ppo-jax:{whole.model_path}"


@pytest.mark.filterwarnings("error:the evaluation worker died:RuntimeWarning")  # the worker, not the fallback
def test_evaluations_beside_training_give_the_curve_and_the_model_of_in_line_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gym4real.cli import main
    from gym4real.rl import checkpoint_evaluations

    made = checkpoint_evaluations.CheckpointEvaluations
    beside_or_not: list[bool] = []
    monkeypatch.setattr(
        checkpoint_evaluations, "CheckpointEvaluations", lambda *a: beside_or_not.append(a[-1]) or made(*a)
    )
    preset = _tiny(tmp_path, EVERY_64)
    command = ["train", DAM, "--algo", "ppo", "--trainer", "jax", "--preset", preset, "--seed", "3", "--quiet"]
    assert main([*command, "--out", str(tmp_path / "inline"), "--no-eval-beside"]) == 0
    run = train(DAM, "ppo", preset, seed=3, out=tmp_path / "beside", trainer="jax", eval_beside=True)
    assert beside_or_not == [False, True]
    inline, beside = _arrays(tmp_path / "inline" / "model.npz"), _arrays(run.model_path)
    assert inline.keys() == beside.keys() and all(np.array_equal(inline[k], beside[k]) for k in inline)
    curve = (tmp_path / "inline" / "curve.csv").read_text()
    assert curve == run.curve_csv.read_text() and len(curve.splitlines()) == 1 + 4
    record = json.loads((tmp_path / "inline" / "run.json").read_text())
    assert record["eval_steps"] == run.eval_steps == 4 * 2 * 10  # two 10-day episodes an evaluation
    with pytest.raises(ConfigError, match="JAX trainer's"):
        train(DAM, "ppo", preset, out=tmp_path / "sb3", eval_beside=True)


def test_a_dead_evaluation_worker_costs_no_result(tmp_path: Path) -> None:
    from gym4real.rl.checkpoint_evaluations import CheckpointEvaluations

    trainer = JaxPPO(DAM, load_preset(DAM, "ppo", _tiny(tmp_path)), seed=0)
    snapshots = [trainer.model()]
    trainer.start_episodes()
    trainer.iteration()
    snapshots.append(trainer.model())
    kwargs = {"preset": "validation", "sim_horizon": 10}
    inline = CheckpointEvaluations(DAM, kwargs, 2, 7, beside=False)
    beside = CheckpointEvaluations(DAM, kwargs, 2, 7, beside=True)
    for k, model in enumerate(snapshots):
        inline.submit(k, model)
    expected = list(inline.results())
    beside.submit(0, snapshots[0])
    got = list(beside.results())
    beside._worker.kill()  # killed between two evaluations
    beside._worker.wait()
    with pytest.warns(RuntimeWarning, match="evaluation worker died"):
        beside.submit(1, snapshots[1])
    got += list(beside.results())
    assert [t for t, _, _ in got] == [0, 1] and not beside.beside
    for (_, _, a), (_, _, b) in zip(expected, got, strict=True):
        assert len(a) == 2 and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    inline.close()
    beside.close()


_RUN = """
import sys
from gym4real.rl.train import train
train("gym4real/dam-v0", "ppo", sys.argv[1], seed=2, out=sys.argv[2], trainer="jax")
"""


def test_the_same_seed_gives_the_same_model_bit_for_bit_with_one_or_two_threads(tmp_path: Path) -> None:
    preset = _tiny(tmp_path, TINY_DAM.replace("total_timesteps: 256", "total_timesteps: 128"))
    models = []
    for threads in ("1", "2"):
        env = {k: v for k, v in __import__("os").environ.items() if k != "XLA_FLAGS"}
        env |= {"OMP_NUM_THREADS": threads, "NUMBA_NUM_THREADS": threads, "MKL_NUM_THREADS": threads}
        out = tmp_path / f"threads{threads}"
        subprocess.run([sys.executable, "-c", _RUN, preset, str(out)], check=True, env=env)
        models.append(_arrays(out / "model.npz"))
    assert all(np.array_equal(models[0][k], models[1][k]) for k in models[0])
    assert models[0]["param/pi/0/w"].dtype == np.float32


def test_a_model_file_round_trips_through_evaluate(tmp_path: Path) -> None:
    run = train(DAM, "ppo", _tiny(tmp_path), seed=0, out=tmp_path / "run", trainer="jax")
    env = gym.make(DAM)
    model = load(run.model_path, env.observation_space, env.action_space)
    assert model.normalization is not None and model.rescaled
    evaluation = gym4real.evaluate({"mine": run.policy}, [DAM])
    direct = gym4real.benchmark(DAM, [model], episodes="test")
    (name,) = direct.returns
    scores = evaluation.envs[DAM].scores["mine"]
    np.testing.assert_array_equal(np.asarray(scores).ravel(), np.asarray(direct.objective_values(name)))


def test_a_model_file_holds_only_data_and_refuses_other_spaces(tmp_path: Path) -> None:
    env = gym.make("Pendulum-v1")
    arch = architecture(env.observation_space, env.action_space, {"net_arch": [4]})
    model = Model(arch, initial_parameters(arch, 0.0, 0), None, env.observation_space, env.action_space, True)
    path = tmp_path / "model.npz"
    model.save(path)
    arrays = _arrays(path)  # allow_pickle=False: no object arrays
    assert all(v.dtype != object for v in arrays.values())
    again = load(path, env.observation_space, env.action_space)
    obs = np.random.default_rng(0).normal(size=(7, 3)).astype(np.float32)
    np.testing.assert_array_equal(again.actions(obs), model.actions(obs))
    assert again(obs[0]).shape == (1,)
    other = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    with pytest.raises(PolicyError, match="observation space"):
        load(path, other, env.action_space)
    with pytest.raises(PolicyError, match="not a model file"):
        load(Path(__file__), env.observation_space, env.action_space)


# -- settings and the extra ----------------------------------------------------------------------------


def test_settings_the_trainer_does_not_implement_are_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="target_kl"):
        JaxPPO(DAM, load_preset(DAM, "ppo", _tiny(tmp_path, TINY_DAM.replace("n_epochs: 2", "target_kl: 0.1"))), 0)
    with pytest.raises(PolicyError, match="activation_fn"):
        architecture(gym.make(DAM).observation_space, gym.make(DAM).action_space, {"activation_fn": "ReLU"})
    with pytest.raises(ConfigError, match="trains PPO"):
        train("gym4real/wds-v0", "dqn", "smoke", out=tmp_path / "x", trainer="jax")


@pytest.mark.parametrize("missing", ["jax", "optax", "numba"])
def test_without_the_extra_the_trainer_names_it(missing: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setitem(sys.modules, missing, None)  # an import of it fails, as when it is not installed
    with pytest.raises(PolicyError, match=rf"\({missing} is missing\): `pip install \"gym4real-core\[jax\]\"`"):
        jax_modules()
    from gym4real.cli import main

    assert main(["train", DAM, "--algo", "ppo", "--trainer", "jax", "--out", str(tmp_path / "r"), "--quiet"]) != 0


def test_reproduce_with_the_jax_trainer_labels_its_section_runs_and_models(tmp_path: Path) -> None:
    from gym4real.results.reproduce import reproduce

    reproduce([DAM], "quick", [0], tmp_path, trainer="jax")
    section = tmp_path / "dam-v0-quick-jax"
    assert not (tmp_path / "dam-v0-quick").exists()  # the SB3 section is not touched
    episodes = section / "episodes.csv"
    assert "ppo-jax" in episodes.read_text() and ",ppo," not in episodes.read_text()
    assert (tmp_path / "dam-v0" / "quick" / "runs" / "ppo-jax" / "seed0" / "model.npz").exists()
    (listing,) = json.loads((section / "models.json").read_text())
    assert listing["trainer"] == "jax" and "--trainer jax" in listing["retrain"]
    assert "published-ppo-jax=ppo-jax:" in listing["evaluate"]
    report = json.loads((section / "report.json").read_text())
    assert report["presets"] == {"ppo-jax": "smoke"} and report["command"].endswith("--trainer jax")
    assert report["fingerprints"]["trainer"]["trainer"] == "jax"
    claims = json.loads((section / "claims.json").read_text())  # decided on the section's own agent
    assert {(c["policy"], c["trainer"]) for c in claims} == {("ppo-jax", "jax")}
    assert "not checked" not in {c["verdict"] for c in claims}
    from gym4real.results.currency import check
    from gym4real.results.results_page import write_page

    text = write_page(tmp_path, tmp_path / "page").read_text()
    assert "## `gym4real/dam-v0`, budget `quick`, trainer `ppo-jax` (PPO trained by JAX)" in text
    found = check(tmp_path / "page")  # its files as listed, its fingerprints the JAX trainer's
    assert found.lines == ["dam-v0-quick-jax: current"] and not found.damaged


@pytest.mark.parametrize("rows", [1, 7, 1625, 1626, 65536])  # 0, 1 and 2 rounds of jax's sort-based shuffle
def test_the_epoch_orders_are_jax_s_permutations_of_the_epoch_keys(rows: int) -> None:
    """The update took each epoch's ``jax.random.permutation`` inside its compiled call, where XLA's CPU sort cost
    0.38 s of a microgrid update's 0.85; :func:`epoch_orders` draws the same permutations before the call."""
    key = jax.random.PRNGKey(rows)
    orders = epoch_orders(key, rows, 3)
    assert orders.shape == (3, rows) and orders.dtype == np.int32
    for order, epoch_key in zip(orders, jax.random.split(key, 3), strict=True):
        np.testing.assert_array_equal(order, np.asarray(jax.random.permutation(epoch_key, rows)))
