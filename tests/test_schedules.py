"""Learning-rate schedules of the presets: values, words, validation, skrl's KL rule, and its SB3 PPO."""

from __future__ import annotations

import inspect
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gym4real.core.errors import ConfigError
from gym4real.rl.presets import load_preset
from gym4real.rl.schedules import (
    SB3_DEFAULT_LEARNING_RATE,
    KLAdaptive,
    KLAdaptiveRate,
    learning_rate_words,
    schedule,
)
from gym4real.rl.train import train


def test_cosine_is_the_reference_microgrid_annealing() -> None:
    cosine = schedule({"schedule": "cosine", "initial": 5e-5})
    total = 100 * 8 * 8760 * 4  # the reference's own total; its formula uses step / total only
    for done in (0.0, 0.1, 0.25, 0.5, 0.9, 1.0):
        step = done * total
        reference = 5e-5 * 0.5 * (1 + math.cos(math.pi * step / total))  # microgrid/ppo.py cosine_schedule
        assert cosine(1.0 - done) == pytest.approx(reference, rel=1e-12, abs=1e-20)
    assert (cosine(1.0), cosine(0.0)) == (5e-5, 0.0)


def test_annealed_schedules_at_known_progress_points() -> None:
    linear = schedule({"schedule": "linear", "initial": 1e-3, "final": 1e-4})
    assert [linear(p) for p in (1.0, 0.5, 0.0)] == pytest.approx([1e-3, 5.5e-4, 1e-4])
    cosine = schedule({"schedule": "cosine", "initial": 1e-3, "final": 1e-4})
    # half-way the cosine is at the midpoint; a quarter in it has fallen by (1 - cos(pi / 4)) / 2 of the range
    assert cosine(0.5) == pytest.approx(5.5e-4)
    assert cosine(0.75) == pytest.approx(1e-3 - 9e-4 * (1 - math.sqrt(0.5)) / 2)
    assert schedule(2e-4)(0.3) == schedule({"schedule": "constant", "initial": 2e-4})(0.9) == 2e-4


def test_schedules_in_words() -> None:
    assert schedule({"schedule": "cosine", "initial": 5e-5}).describe() == "cosine(5e-05->0)"
    assert schedule({"schedule": "linear", "initial": 1e-3, "final": 1e-5}).describe() == "linear(0.001->1e-05)"
    assert schedule(1e-3).describe() == "constant(0.001)"
    kl = {"schedule": "kl_adaptive", "initial": 8e-6, "kl_threshold": 0.008}
    assert schedule(kl).describe() == "kl_adaptive(8e-06, kl_threshold=0.008)"
    assert schedule({**kl, "factor": 2}).describe() == "kl_adaptive(8e-06, kl_threshold=0.008, factor=2)"
    dam = load_preset("gym4real/dam-v0", "ppo", "paper")
    assert learning_rate_words(dam) == "kl_adaptive(8e-06, kl_threshold=0.008)"
    assert learning_rate_words(load_preset("gym4real/microgrid-v0", "ppo", "paper")) == "cosine(5e-05->0)"
    assert learning_rate_words(load_preset("gym4real/elevator-v0", "qlearning", "paper")) == "constant(0.1)"


def test_sb3_default_learning_rates_are_sb3s() -> None:
    sb3 = pytest.importorskip("stable_baselines3")
    for algo, rate in SB3_DEFAULT_LEARNING_RATE.items():
        cls = getattr(sb3, algo.upper())
        assert inspect.signature(cls.__init__).parameters["learning_rate"].default == rate
    preset = load_preset("gym4real/wds-v0", "dqn", "smoke")
    assert preset["hyperparams"]["learning_rate"] == 1e-3  # a preset's own rate is kept


@pytest.mark.parametrize(
    ("rate", "message"),
    [
        ("{schedule: cosine, initial: 5.0e-5, final: .nan}", r"learning_rate.cosine.final`: .*finite"),
        ("{schedule: linear, initial: -1.0e-3}", r"field `hyperparams.learning_rate.linear.initial`: .*greater than 0"),
        ("{schedule: cosine, initial: 5.0e-5, finale: 0}", r"unknown field `hyperparams.learning_rate.cosine.finale`"),
        ("{schedule: cosin, initial: 5.0e-5}", r"field `hyperparams.learning_rate`: expected a positive number or a "),
        ("{schedule: kl_adaptive, initial: 8.0e-6, kl_threshold: 0}", r"learning_rate.kl_adaptive.kl_threshold`: "),
        ("{schedule: kl_adaptive, initial: 8.0e-6, factor: 1}", r"learning_rate.kl_adaptive.factor`: .*greater than 1"),
        ("{schedule: kl_adaptive, initial: 8.0e-6, min: 1.0e-5}", r"`initial` \(8e-06\) is outside \[`min`, `max`\]"),
        ("{schedule: linear, initial: 1.0e-4, final: 1.0e-3}", r"`final` \(0.001\) is above `initial` \(0.0001\)"),
        ("-0.1", r"field `hyperparams.learning_rate.number`: Input should be greater than 0"),
        (".inf", r"field `hyperparams.learning_rate.number`: Input should be a finite number"),
    ],
)
def test_a_bad_learning_rate_names_its_field(tmp_path: Path, rate: str, message: str) -> None:
    path = tmp_path / "ppo.yaml"
    path.write_text(f"algo: ppo\ntotal_timesteps: 64\nhyperparams: {{n_steps: 32, learning_rate: {rate}}}\n")
    with pytest.raises(ConfigError, match=message):
        load_preset("gym4real/elevator-v0", "ppo", str(path))


def test_kl_adaptive_is_refused_for_dqn(tmp_path: Path) -> None:
    path = tmp_path / "dqn.yaml"
    rate = "{schedule: kl_adaptive, initial: 1.0e-4}"
    path.write_text(f"algo: dqn\ntotal_timesteps: 64\nhyperparams: {{learning_rate: {rate}}}\n")
    with pytest.raises(ConfigError, match=r"`kl_adaptive` adapts PPO's rate .* DQN has no epochs"):
        load_preset("gym4real/elevator-v0", "dqn", str(path))


def test_kl_adaptive_rate_follows_skrls_rule_on_a_recorded_kl_sequence() -> None:
    # skrl 1.4.3 KLAdaptiveLR.step: divide by lr_factor 1.5 when kl > 2 * threshold, multiply below threshold / 2
    rate = KLAdaptiveRate(KLAdaptive(schedule="kl_adaptive", initial=8e-6, kl_threshold=0.008))
    kls = [0.001, 0.001, 0.02, 0.01, 0.017, 0.0039, 0.004, 0.016, 0.0161]
    expected = [8e-6 * 1.5, 8e-6 * 1.5**2, 8e-6 * 1.5, 8e-6 * 1.5, 8e-6, 8e-6 * 1.5, 8e-6 * 1.5, 8e-6 * 1.5, 8e-6]
    assert [rate.update(kl) for kl in kls] == pytest.approx(expected, rel=1e-12)
    assert rate(0.3) == rate.rate  # SB3 calls it with the progress, which it ignores
    low = KLAdaptiveRate(KLAdaptive(schedule="kl_adaptive", initial=1.4e-6))  # skrl's bounds [1e-6, 1e-2]
    assert [low.update(1.0) for _ in range(2)] == [1e-6, 1e-6]
    high = KLAdaptiveRate(KLAdaptive(schedule="kl_adaptive", initial=8e-3))
    assert [high.update(0.0) for _ in range(2)] == [1e-2, 1e-2]
    assert KLAdaptiveRate(high.spec, rate=3e-3).rate == 3e-3  # a resumed run starts from its saved rate


def test_ppo_adapts_its_rate_after_each_epoch_from_sb3s_kl_estimate() -> None:
    pytest.importorskip("stable_baselines3")
    import gymnasium as gym

    from gym4real.rl.skrl_ppo import SkrlPPO

    spec = KLAdaptive(schedule="kl_adaptive", initial=3e-3, kl_threshold=1e-3, max=1.0)
    model = SkrlPPO(
        "MlpPolicy", gym.make("CartPole-v1"), rate=KLAdaptiveRate(spec), n_steps=64, batch_size=16, n_epochs=3, seed=0
    )
    model.learn(total_timesteps=128)
    assert len(model.epoch_kls) == 2 * 3  # two updates of three epochs
    replayed = KLAdaptiveRate(spec)
    rates = [replayed.update(kl) for kl in model.epoch_kls]
    assert len(set(rates)) > 1  # the rate moved
    assert model.rate.rate == rates[-1] == model.policy.optimizer.param_groups[0]["lr"]
    # SB3 logs the mean KL estimate of the last epoch: the very number the rate was adapted to
    assert model.logger.name_to_value["train/approx_kl"] == pytest.approx(model.epoch_kls[-1], rel=1e-5)


DAM_KL = """
algo: ppo
total_timesteps: 1024
normalize_obs: true
clip_obs: 5.0
value_scaler: true
policy_kwargs: {net_arch: [16, 16], log_std_init: -0.5}
hyperparams:
  learning_rate: {schedule: kl_adaptive, initial: 8.0e-6, kl_threshold: 0.008}
  n_steps: 256
  batch_size: 32
  n_epochs: 2
  gamma: 0.995
env_kwargs: {preset: train}
eval_env_kwargs: {preset: validation, sim_horizon: 30}
eval_freq: 512
eval_episodes: 1
"""


def test_a_resumed_run_starts_from_its_saved_rate_and_value_statistics(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("stable_baselines3")
    from gym4real.rl import skrl_ppo

    class _Interrupt(Exception):
        pass

    def stop_after_the_first_checkpoint(done: int, total: int) -> None:
        if done > 512:
            raise _Interrupt

    preset = tmp_path / "dam.yaml"
    preset.write_text(DAM_KL)
    out = tmp_path / "run"
    with pytest.raises(_Interrupt):
        train("gym4real/dam-v0", "ppo", str(preset), seed=0, out=out, progress=stop_after_the_first_checkpoint)
    saved = json.loads((out / "checkpoint" / "state.json").read_text())
    # the checkpoint at 512 steps follows one update of two epochs: at 8e-6 the policy barely moves, its KL
    # is below the band and the rate has grown; the value statistics have merged one rollout's values and returns
    assert saved["learning_rate"] > 8e-6 and saved["value_scaler"][2] == 1 + 2 * 256

    started: list[tuple[float, list[float]]] = []
    original = skrl_ppo.SkrlPPO.__init__

    def record(self: Any, *args: Any, rate: KLAdaptiveRate, value_scaler: Any, **kwargs: Any) -> None:
        started.append((rate.rate, value_scaler.state()))
        original(self, *args, rate=rate, value_scaler=value_scaler, **kwargs)

    monkeypatch.setattr(skrl_ppo.SkrlPPO, "__init__", record)
    run = train("gym4real/dam-v0", "ppo", str(preset), seed=0, out=out)
    assert started == [(saved["learning_rate"], saved["value_scaler"])] and run.env_steps == 1024


def _merged(groups: list[np.ndarray]) -> tuple[float, float]:
    """Mean and variance of skrl's prior (one value 0, variance 1) merged with ``groups`` by the law of total
    variance, each group's own variance taken with Bessel's correction as ``torch.var`` does."""
    counts = np.array([1.0] + [g.size for g in groups])
    means = np.array([0.0] + [g.mean() for g in groups])
    within = np.array([1.0] + [g.var(ddof=1) for g in groups])
    mean = float(np.sum(counts * means) / counts.sum())
    return mean, float(np.sum(counts * within + counts * (means - mean) ** 2) / counts.sum())


def test_running_standard_scaler_merges_batches_as_skrl() -> None:
    pytest.importorskip("stable_baselines3")
    import torch as th

    from gym4real.rl.skrl_ppo import RunningStandardScaler

    rng = np.random.default_rng(0)
    batches = [rng.normal(3.0, 2.0, size=(64, 2)), rng.normal(-1.0, 0.5, size=(32, 2)), rng.normal(7.0, 1.0, 5)]
    scaler = RunningStandardScaler()
    for i, batch in enumerate(batches):
        scaler.update(batch)
        mean, var = _merged(batches[: i + 1])
        assert (scaler.mean, scaler.var, scaler.count) == pytest.approx(
            (mean, var, 1 + sum(b.size for b in batches[: i + 1]))
        )
    x = np.array([mean, mean + 100 * np.sqrt(var)], dtype=np.float32)
    np.testing.assert_allclose(scaler.standardize(x), [0.0, 5.0], atol=1e-6)  # clipped at 5 standard deviations
    restored = scaler.restore(th.tensor([1.0, -9.0]))
    np.testing.assert_allclose(restored.numpy(), [mean + np.sqrt(var), mean - 5 * np.sqrt(var)], rtol=1e-6)


def test_ppo_value_targets_are_standardised_as_skrls_value_preprocessor() -> None:
    pytest.importorskip("stable_baselines3")
    import gymnasium as gym
    import torch as th

    from gym4real.rl.skrl_ppo import RunningStandardScaler, SkrlPPO

    scaler = RunningStandardScaler(mean=10.0, var=4.0, count=50.0)  # a scale the untrained net does not have
    model = SkrlPPO("MlpPolicy", gym.make("CartPole-v1"), value_scaler=scaler, n_steps=64, batch_size=16, seed=0)
    model.train = lambda: None  # the rollout only: the value net stays the one that collected it
    model.learn(total_timesteps=64)
    buffer = model.rollout_buffer
    with th.no_grad():
        net = model.policy.predict_values(th.as_tensor(buffer.observations.reshape(64, -1))).numpy().reshape(64, 1)
    values = 2.0 * np.clip(net, -5, 5) + 10.0  # the net's outputs in reward units, with the statistics of the rollout
    returns = buffer.advantages + values  # SB3's returns: the advantages (unscaled) plus the values

    def standardized(x: np.ndarray, mean: float, var: float) -> np.ndarray:
        return np.clip((x - mean) / (np.sqrt(var) + 1e-8), -5, 5)

    # skrl merges the values first and standardises them, then merges the returns and standardises them
    first = RunningStandardScaler(10.0, 4.0, 50.0)
    first.update(values)
    np.testing.assert_allclose(buffer.values, standardized(values, first.mean, first.var), rtol=1e-4, atol=1e-5)
    first.update(returns)
    np.testing.assert_allclose(buffer.returns, standardized(returns, first.mean, first.var), rtol=1e-4, atol=1e-5)
    assert (scaler.mean, scaler.var, scaler.count) == pytest.approx((first.mean, first.var, 50.0 + 2 * 64))
    assert "predict_values" not in vars(model.policy)  # the reward-unit values were the rollout's only
