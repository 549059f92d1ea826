"""A policy's forward pass that computes the same bits on every CPU: for envs that amplify an action's last bit.

PyTorch picks its kernels for the CPU it runs on: oneDNN's convolutions, MKL's matrix products and ATen's
vectorised ``tanh`` return other last bits with AVX-512 than with AVX2 (measured: ``ATEN_CPU_CAPABILITY=avx2``,
``MKL_ENABLE_INSTRUCTIONS=AVX2``, ``ONEDNN_MAX_CPU_ISA=AVX2``). Most envs take such an action as it is, but
a robot's contacts turn a last-bit difference of a target into another grasp: a picking-v0 PPO agent scored 63
of its 100 test episodes differently under AVX2-only dispatch (``docs/robofeeder-determinism.md``).

Here the deterministic action of a Stable-Baselines3 actor-critic policy is computed in numpy from the
policy's weights with elementwise operations only, each one correctly rounded IEEE arithmetic whatever the
SIMD width: a product of a layer is every term multiplied out, then summed in a fixed pairwise tree
(:func:`tree_sum`); ``tanh`` is the C library's, in double precision, rounded to float32. No BLAS, no fused
multiply-add, no reordering. The result is the torch forward's to float rounding (about 1e-6 relative), not
to the bit: an env that declares :attr:`~gym4real.core.specs.BenchmarkSpec.portable_forward` scores every
model-file policy this way, and its published rows are this forward's.

Layers: ``Linear``, ``Conv2d`` (no padding, dilation or groups), ``ReLU``, ``Tanh``, ``Flatten``,
``Identity`` and ``Sequential`` of them; feature extractors ``NatureCNN`` and ``FlattenExtractor``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gym4real.core.errors import PolicyError

#: At most this many float32 products are held at once (a chunk of a layer's output units): 32 MB.
_CHUNK = 8_000_000


def tree_sum(terms: np.ndarray) -> np.ndarray:
    """The sum over the last axis in a fixed pairwise order: the first half plus the second, until one is left.

    An odd count carries its last term to the next round. Every addition is elementwise, so the order (and
    the rounding) does not depend on the CPU's vector width, as numpy's own ``sum`` does.
    """
    while terms.shape[-1] > 1:
        n = terms.shape[-1]
        half = n // 2
        paired = terms[..., :half] + terms[..., half : 2 * half]
        terms = paired if n % 2 == 0 else np.concatenate([paired, terms[..., 2 * half :]], axis=-1)
    return terms[..., 0]


def _products(x: np.ndarray, weight: np.ndarray, bias: np.ndarray | None) -> np.ndarray:
    """``x @ weight.T + bias`` for rows ``x`` (..., K) and ``weight`` (O, K), through :func:`tree_sum`."""
    rows = x.reshape(-1, x.shape[-1])
    out = np.empty((rows.shape[0], weight.shape[0]), dtype=np.float32)
    step = max(1, _CHUNK // max(1, rows.shape[0] * weight.shape[1]))
    for start in range(0, weight.shape[0], step):
        w = weight[start : start + step]
        out[:, start : start + step] = tree_sum(rows[:, None, :] * w[None, :, :])
    if bias is not None:
        out += bias
    return out.reshape(*x.shape[:-1], weight.shape[0])


def _conv2d(x: np.ndarray, weight: np.ndarray, bias: np.ndarray | None, stride: tuple[int, int]) -> np.ndarray:
    """A valid 2-D convolution (PyTorch's cross-correlation) of ``x`` (N, C, H, W) as patches times weights."""
    out_c, _, kh, kw = weight.shape
    windows = np.lib.stride_tricks.sliding_window_view(x, (kh, kw), axis=(2, 3))[:, :, :: stride[0], :: stride[1]]
    n, c, oh, ow = windows.shape[:4]
    patches = np.ascontiguousarray(windows.transpose(0, 2, 3, 1, 4, 5)).reshape(n, oh * ow, c * kh * kw)
    out = _products(patches, weight.reshape(out_c, -1), bias)  # (N, OH*OW, O)
    return np.ascontiguousarray(out.transpose(0, 2, 1)).reshape(n, out_c, oh, ow)


def _tanh(x: np.ndarray) -> np.ndarray:
    values = np.fromiter(map(math.tanh, x.ravel().tolist()), float, x.size)
    return values.astype(np.float32).reshape(x.shape)


def _array(tensor: Any) -> np.ndarray | None:
    return None if tensor is None else tensor.detach().cpu().numpy().astype(np.float32)


def forward(module: Any, x: np.ndarray) -> np.ndarray:
    """Apply a torch module (the layers the module docstring lists) to float32 ``x``.

    Raises:
        PolicyError: A layer this forward does not compute, named.
    """
    from torch import nn

    if isinstance(module, nn.Sequential):
        for layer in module:
            x = forward(layer, x)
        return x
    if isinstance(module, nn.Linear):
        return _products(x, _array(module.weight), _array(module.bias))  # type: ignore[arg-type]
    if isinstance(module, nn.Conv2d):
        if module.padding not in ((0, 0), "valid") or module.dilation != (1, 1) or module.groups != 1:
            raise PolicyError(
                f"the portable forward computes unpadded, undilated, ungrouped convolutions, not `{module}`"
            )
        return _conv2d(x, _array(module.weight), _array(module.bias), module.stride)  # type: ignore[arg-type]
    if isinstance(module, nn.ReLU):
        return np.maximum(x, np.float32(0.0))
    if isinstance(module, nn.Tanh):
        return _tanh(x)
    if isinstance(module, nn.Flatten):
        return x.reshape(x.shape[0], -1)
    if isinstance(module, nn.Identity):
        return x
    name = type(module).__name__
    if name == "NatureCNN":
        return forward(module.linear, forward(module.cnn, x))
    if name == "FlattenExtractor":
        return forward(module.flatten, x)
    raise PolicyError(
        f"the portable forward does not compute a `{name}` layer (it computes Linear, Conv2d, ReLU, Tanh, Flatten, "
        "NatureCNN and FlattenExtractor): score this model on an env without `portable_forward`"
    )


def deterministic_actions(policy: Any, obs: Any) -> np.ndarray:
    """What ``policy._predict(obs_tensor, deterministic=True)`` returns, computed by :func:`forward`.

    ``policy`` is an SB3 ``ActorCriticPolicy`` (PPO, A2C) with a Gaussian or categorical action head; ``obs``
    a batch, first axis the rows. The observation is preprocessed by SB3 itself (a float cast, and the
    ``/255`` of images it normalises: elementwise, the same bits everywhere).

    Raises:
        PolicyError: Another kind of policy or action distribution, a Dict observation space, or a layer
            :func:`forward` does not compute.
    """
    import torch
    from stable_baselines3.common.distributions import CategoricalDistribution, DiagGaussianDistribution
    from stable_baselines3.common.policies import ActorCriticPolicy
    from stable_baselines3.common.preprocessing import preprocess_obs

    if not isinstance(policy, ActorCriticPolicy) or not isinstance(
        policy.action_dist, (DiagGaussianDistribution, CategoricalDistribution)
    ):
        raise PolicyError(
            f"the portable forward scores actor-critic policies with a Gaussian or categorical action head (PPO, "
            f"A2C), not `{type(policy).__name__}`: score this model on an env without `portable_forward`"
        )
    tensor, _ = policy.obs_to_tensor(obs)
    with torch.inference_mode():
        x = preprocess_obs(tensor, policy.observation_space, normalize_images=policy.normalize_images)
    if isinstance(x, dict):
        raise PolicyError("the portable forward scores policies of array observations, not of a Dict space")
    features = forward(policy.pi_features_extractor, x.cpu().numpy().astype(np.float32))
    latent = forward(policy.mlp_extractor.policy_net, features)
    out = forward(policy.action_net, latent)
    if isinstance(policy.action_dist, CategoricalDistribution):
        return np.argmax(out, axis=1)  # the first of equal logits, as torch's argmax
    return out
