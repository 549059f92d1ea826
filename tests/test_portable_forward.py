"""The portable forward pass (:mod:`gym4real.rl.portable_forward`): torch's numbers to float rounding, a fixed order.

That its bits do not depend on the CPU's kernels is tested where it matters, on robofeeder's episodes under
other dispatch settings (``packages/gym4real-robofeeder/tests/test_robofeeder_cpu_dispatch.py``).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from gym4real.core.errors import PolicyError

pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO

from gym4real.rl.portable_forward import deterministic_actions, forward, tree_sum


def _pairwise(values: list[np.float32]) -> np.float32:
    """The documented order, one float32 addition at a time: first half plus second half, an odd last carried."""
    while len(values) > 1:
        half = len(values) // 2
        paired = [np.float32(values[i] + values[half + i]) for i in range(half)]
        values = paired + values[2 * half :]
    return values[0]


@pytest.mark.parametrize("n", [1, 2, 3, 7, 64, 101])
def test_tree_sum_adds_in_the_documented_order(n: int) -> None:
    rows = np.random.default_rng(n).normal(size=(3, n)).astype(np.float32)
    found = tree_sum(rows)
    for row, value in zip(rows, found, strict=True):
        assert value == _pairwise(list(row))
        assert abs(float(value) - float(np.sum(row.astype(np.float64)))) <= 1e-5 * max(1.0, float(np.abs(row).sum()))


class _Spaces(gym.Env):  # type: ignore[type-arg]
    """A stand-in env with the spaces of a policy under test (never stepped)."""

    def __init__(self, observation_space: gym.Space, action_space: gym.Space) -> None:  # type: ignore[type-arg]
        self.observation_space, self.action_space = observation_space, action_space


def _policy(obs_space: gym.Space, action_space: gym.Space, policy: str, net_arch: list[int]) -> object:  # type: ignore[type-arg]
    kwargs = {"net_arch": net_arch, **({"normalize_images": False} if policy == "CnnPolicy" else {})}
    model = PPO(policy, _Spaces(obs_space, action_space), policy_kwargs=kwargs, seed=3, device="cpu", n_steps=64)
    model.policy.set_training_mode(False)
    return model.policy


CASES = {
    "cnn-gaussian": (gym.spaces.Box(0.0, 1.0, (1, 48, 48), np.float32), gym.spaces.Box(-1, 1, (3,)), "CnnPolicy"),
    "cnn-categorical": (gym.spaces.Box(0.0, 1.0, (3, 40, 40), np.float32), gym.spaces.Discrete(4), "CnnPolicy"),
    "mlp-gaussian": (gym.spaces.Box(-5.0, 5.0, (7,), np.float32), gym.spaces.Box(-1, 1, (2,)), "MlpPolicy"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_portable_actions_are_torch_s_to_float_rounding(case: str) -> None:
    import torch

    obs_space, action_space, kind = CASES[case]
    policy = _policy(obs_space, action_space, kind, [32, 16])
    obs_space.seed(0)
    obs = np.stack([obs_space.sample() for _ in range(5)])
    tensor, _ = policy.obs_to_tensor(obs)  # type: ignore[attr-defined]
    with torch.no_grad():
        features = policy.extract_features(tensor, policy.pi_features_extractor)  # type: ignore[attr-defined]
        logits = policy.action_net(policy.mlp_extractor.forward_actor(features))  # type: ignore[attr-defined]
        expected = policy._predict(tensor, deterministic=True).numpy()  # type: ignore[attr-defined]
    found = deterministic_actions(policy, obs)
    portable_logits = forward(
        policy.action_net,
        forward(policy.mlp_extractor.policy_net, forward(policy.pi_features_extractor, obs.astype(np.float32))),
    )  # type: ignore[attr-defined]
    np.testing.assert_allclose(portable_logits, logits.numpy(), rtol=1e-5, atol=1e-6)
    if isinstance(action_space, gym.spaces.Discrete):
        assert found.tolist() == expected.tolist()
    else:
        np.testing.assert_allclose(found, expected, rtol=1e-5, atol=1e-6)


def test_a_row_s_action_does_not_depend_on_the_batch_it_is_in() -> None:
    obs_space, action_space, kind = CASES["cnn-gaussian"]
    policy = _policy(obs_space, action_space, kind, [32])
    obs_space.seed(1)
    obs = np.stack([obs_space.sample() for _ in range(4)])
    batch = deterministic_actions(policy, obs)
    for i in range(len(obs)):
        assert batch[i].tobytes() == deterministic_actions(policy, obs[i : i + 1])[0].tobytes()


def test_a_layer_it_does_not_compute_is_named() -> None:
    from torch import nn

    with pytest.raises(PolicyError, match="`LeakyReLU` layer"):
        forward(nn.Sequential(nn.Linear(3, 2), nn.LeakyReLU()), np.ones((1, 3), np.float32))
    with pytest.raises(PolicyError, match="unpadded"):
        forward(nn.Conv2d(1, 2, 3, padding=1), np.ones((1, 1, 5, 5), np.float32))


def test_only_the_protocols_that_declare_it_score_with_the_portable_forward(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """robofeeder's three protocols declare ``portable_forward`` (named in their fingerprint); dam's does not."""
    import gym4real  # noqa: F401
    from gym4real.bench.reference import installed_fingerprint
    from gym4real.rl.sb3 import load_model

    for env_id, portable in (("gym4real/robofeeder-picking-v0", True), ("gym4real/dam-v0", False)):
        env = gym.make(env_id, preset="test")
        kind = "CnnPolicy" if portable else "MlpPolicy"
        kwargs = {"net_arch": [8], **({"normalize_images": False} if portable else {})}
        space = gym.spaces.Box(-1, 1, env.action_space.shape) if not portable else env.action_space
        PPO(kind, _Spaces(env.observation_space, space), policy_kwargs=kwargs, seed=0, device="cpu").save(
            tmp_path / "m.zip"
        )
        assert load_model(env, tmp_path / "m.zip", "ppo").portable is portable, env_id
        env.close()
        assert ("policy_forward" in installed_fingerprint(env_id)) is portable, env_id
