"""PPO's update in JAX, with Stable-Baselines3's semantics, as one jitted function per iteration.

:func:`make_update` returns ``update(params, opt_state, rate, key, batch)``: every epoch and mini-batch of
an iteration in one ``jax.jit`` of ``lax.scan`` over epochs and, inside, over mini-batches. Its shapes
are those of the rollout, the same at every iteration: it is compiled once. What it computes, each item
as SB3 2.x's ``PPO.train`` does (and tested against it on the same batch):

- **Mini-batches**: each epoch a fresh permutation of the rollout's rows (:func:`epoch_orders`, drawn before
  the call) cut into ``batch_size`` slices (the last one shorter when the rows do not divide), every row once
  per epoch. Rows marked invalid (the native env's autoreset steps, :mod:`gym4real.rl.rollout_kernel`) and
  the padding that makes the last slice full weigh 0: every mean below is over a mini-batch's valid rows.
- **Advantages** normalised per mini-batch: ``(A - mean) / (std + 1e-8)``, ``std`` with Bessel's correction
  (``torch.std``), not for a mini-batch of one row (``normalize_advantage``).
- **Clipped surrogate**: ``-mean(min(A r, A clip(r, 1 - eps, 1 + eps)))``, ``r = exp(log p - log p_old)``.
- **Value loss**: ``mean((R - V)^2)``, ``V`` clipped to ``V_old +- clip_range_vf`` when that is set.
- **Entropy**: ``loss = policy + ent_coef * (-mean(entropy)) + vf_coef * value``.
- **Gradient clipping**: ``torch.nn.utils.clip_grad_norm_``: the gradient scaled by
  ``min(max_grad_norm / (norm + 1e-6), 1)``, ``norm`` the global L2 norm of every parameter's gradient.
- **Adam** with SB3's ``eps = 1e-5`` (torch's betas 0.9, 0.999), stepped with the iteration's rate.
- **KL-adaptive rate** (skrl's ``KLAdaptiveLR``, :class:`~gym4real.rl.schedules.KLAdaptive`): the estimate
  ``mean((exp(d) - 1) - d)``, ``d = log p - log p_old``, of each mini-batch before its step, averaged over
  the epoch, adapts the rate after each epoch; other schedules give the rate of the iteration.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from gym4real.rl.actor_critic import Architecture
from gym4real.rl.schedules import KLAdaptive

#: Adam's epsilon in SB3's policies (``optimizer_kwargs["eps"] = 1e-5``).
ADAM_EPS = 1e-5

Params = dict[str, jax.Array]


@dataclass(frozen=True)
class UpdateSettings:
    """What the update needs besides the data: PPO's hyperparameters and the shapes.

    Attributes:
        arch: The actor-critic.
        rows: Rows of a rollout (``n_steps * n_envs``).
        n_epochs, batch_size, clip_range, clip_range_vf, ent_coef, vf_coef, max_grad_norm,
            normalize_advantage: SB3's PPO arguments of these names.
        kl_adaptive: The KL-adaptive schedule, or None for a rate given at each iteration.
    """

    arch: Architecture
    rows: int
    n_epochs: int
    batch_size: int
    clip_range: float
    clip_range_vf: float | None
    ent_coef: float
    vf_coef: float
    max_grad_norm: float
    normalize_advantage: bool
    kl_adaptive: KLAdaptive | None

    @property
    def minibatches(self) -> int:
        """Mini-batches of an epoch (the last one shorter when ``batch_size`` does not divide the rows)."""
        return -(-self.rows // self.batch_size)


def _shuffle_rounds(rows: int) -> int:
    """Rounds of sorting in ``jax.random.permutation`` of ``rows`` rows (two for 65,536: see :func:`epoch_orders`)."""
    return int(np.ceil(3 * np.log(max(1, rows)) / np.log(np.iinfo(np.uint32).max)))


@lru_cache(maxsize=8)
def _sort_keys(rows: int, epochs: int) -> Callable[[jax.Array], jax.Array]:
    """The compiled draw of :func:`epoch_orders`' sort keys, ``(epochs, rounds, rows)`` uint32, from one key."""

    def draw(key: jax.Array) -> jax.Array:
        def rounds(k: jax.Array) -> jax.Array:
            keys = []
            for _ in range(_shuffle_rounds(rows)):
                k, sub = jax.random.split(k)
                keys.append(jax.random.bits(sub, (rows,), jnp.uint32))
            return jnp.stack(keys) if keys else jnp.zeros((0, rows), jnp.uint32)

        return jax.vmap(rounds)(jax.random.split(key, epochs))

    return jax.jit(draw)


def epoch_orders(key: jax.Array, rows: int, epochs: int) -> np.ndarray:
    """Each epoch's order of the rows, ``(epochs, rows)`` int32: ``jax.random.permutation``'s, drawn before the update.

    Epoch ``e``'s order is ``jax.random.permutation(k, rows)`` for ``k = jax.random.split(key, epochs)[e]``, the
    same integers. jax shuffles by sorting the rows, stably, by random 32-bit keys, in rounds (two for 65,536
    rows); XLA's CPU sort took 0.38 s of the 0.85 s of a microgrid update. Here jax draws the same keys (one
    compiled call for every epoch) and numpy sorts each round's ``key << 32 | position``, whose order is the
    stable order by key (0.03 s for ten epochs). ``tests/test_jax_ppo.py`` holds it equal to ``jax.random.permutation``.
    """
    keys = np.asarray(_sort_keys(rows, epochs)(key)).astype(np.uint64)
    position = np.arange(rows, dtype=np.uint64)
    orders = np.empty((epochs, rows), dtype=np.int32)
    for epoch in range(epochs):
        order = np.arange(rows, dtype=np.int32)
        for draw in keys[epoch]:
            composite = (draw << np.uint64(32)) | position
            composite.sort()
            order = order[(composite & np.uint64(0xFFFFFFFF)).astype(np.intp)]
        orders[epoch] = order
    return orders


def optimizer() -> optax.GradientTransformation:
    """Adam's moments as torch's Adam keeps them (the rate is applied by the update)."""
    return optax.scale_by_adam(b1=0.9, b2=0.999, eps=ADAM_EPS)


def _mlp(params: Params, names: list[str], x: jax.Array) -> jax.Array:
    """The layers of :func:`gym4real.rl.actor_critic.mlp` in jax."""
    for k, name in enumerate(names):
        x = x @ params[f"{name}/w"] + params[f"{name}/b"]
        if k < len(names) - 1:
            x = jnp.tanh(x)
    return x


def evaluate_actions(
    params: Params, arch: Architecture, obs: jax.Array, actions: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Values, log-probabilities and entropies of ``actions`` (rows), as SB3's ``evaluate_actions``.

    A Box policy is a diagonal Gaussian of the action head's mean and ``exp(log_std)``; a Discrete one a
    categorical of the head's logits (``actions`` its indices, one column).
    """
    head = _mlp(params, arch.layers("pi"), obs)
    values = _mlp(params, arch.layers("vf"), obs)[:, 0]
    if arch.discrete:
        logp_all = jax.nn.log_softmax(head)
        index = actions[:, 0].astype(jnp.int32)
        log_prob = jnp.take_along_axis(logp_all, index[:, None], axis=1)[:, 0]
        entropy = -jnp.sum(jnp.exp(logp_all) * logp_all, axis=1)
        return values, log_prob, entropy
    log_std = params["log_std"]
    z = (actions - head) / jnp.exp(log_std)
    log_prob = jnp.sum(-0.5 * z * z - log_std - 0.5 * np.log(2.0 * np.pi), axis=1)
    entropy = jnp.broadcast_to(jnp.sum(0.5 + 0.5 * np.log(2.0 * np.pi) + log_std), log_prob.shape)
    return values, log_prob, entropy


def losses(params: Params, settings: UpdateSettings, batch: dict[str, jax.Array]) -> tuple[jax.Array, jax.Array]:
    """PPO's loss of a mini-batch and its KL estimate (see the module docstring); rows weigh ``batch["valid"]``.

    ``batch`` holds ``obs``, ``actions``, ``old_log_prob``, ``old_values``, ``advantages``, ``returns`` and
    ``valid`` (1 or 0) of the mini-batch's rows.
    """
    s = settings
    w = batch["valid"]
    n = jnp.sum(w)
    safe_n = jnp.maximum(n, 1.0)

    def mean(x: jax.Array) -> jax.Array:
        return jnp.sum(w * x) / safe_n

    values, log_prob, entropy = evaluate_actions(params, s.arch, batch["obs"], batch["actions"])
    adv = batch["advantages"]
    if s.normalize_advantage:
        mu = mean(adv)
        std = jnp.sqrt(jnp.sum(w * (adv - mu) ** 2) / jnp.maximum(n - 1.0, 1.0))
        adv = jnp.where(n > 1, (adv - mu) / (std + 1e-8), adv)
    log_ratio = log_prob - batch["old_log_prob"]
    ratio = jnp.exp(log_ratio)
    surrogate = jnp.minimum(adv * ratio, adv * jnp.clip(ratio, 1.0 - s.clip_range, 1.0 + s.clip_range))
    policy_loss = -mean(surrogate)
    predicted = values
    if s.clip_range_vf is not None:
        old = batch["old_values"]
        predicted = old + jnp.clip(values - old, -s.clip_range_vf, s.clip_range_vf)
    value_loss = mean((batch["returns"] - predicted) ** 2)
    entropy_loss = -mean(entropy)
    kl = mean(jax.lax.stop_gradient((ratio - 1.0) - log_ratio))
    return policy_loss + s.ent_coef * entropy_loss + s.vf_coef * value_loss, kl


def clip_gradients(grads: Params, max_norm: float) -> Params:
    """``torch.nn.utils.clip_grad_norm_``: scale by ``min(max_norm / (norm + 1e-6), 1)``."""
    norm = jnp.sqrt(sum(jnp.sum(g * g) for g in jax.tree_util.tree_leaves(grads)))
    coef = jnp.minimum(max_norm / (norm + 1e-6), 1.0)
    return jax.tree_util.tree_map(lambda g: g * coef, grads)


def _next_rate(spec: KLAdaptive, rate: jax.Array, kl: jax.Array) -> jax.Array:
    """:meth:`KLAdaptive.next_rate` in jax."""
    up = jnp.minimum(rate * spec.factor, spec.max)
    down = jnp.maximum(rate / spec.factor, spec.min)
    above, below = kl > spec.kl_threshold * spec.kl_factor, kl < spec.kl_threshold / spec.kl_factor
    return jnp.where(above, down, jnp.where(below, up, rate))


def make_update(settings: UpdateSettings) -> Callable[..., Any]:
    """The jitted update of one iteration: ``update(params, opt_state, rate, orders, data)``.

    ``orders`` holds each epoch's permutation of the rows (:func:`epoch_orders`), ``data`` the rollout's rows
    (the fields of :func:`losses`, ``settings.rows`` of them). Returns the new parameters, optimizer state and
    rate, and the mean KL estimate of each epoch.
    """
    s = settings
    adam = optimizer()
    padded = s.minibatches * s.batch_size

    def minibatch(carry: tuple[Any, Any, jax.Array], batch: dict[str, jax.Array]) -> tuple[Any, jax.Array]:
        params, opt_state, rate = carry
        (_, kl), grads = jax.value_and_grad(losses, has_aux=True)(params, s, batch)
        grads = clip_gradients(grads, s.max_grad_norm)
        steps, opt_state = adam.update(grads, opt_state, params)
        params = jax.tree_util.tree_map(lambda p, u: p - rate * u, params, steps)
        return (params, opt_state, rate), kl

    def epoch(
        carry: tuple[Any, Any, jax.Array], order: jax.Array, data: dict[str, jax.Array]
    ) -> tuple[tuple[Any, Any, jax.Array], jax.Array]:
        order = jnp.concatenate([order, jnp.full(padded - s.rows, s.rows, dtype=order.dtype)])
        batches = {k: v[order].reshape(s.minibatches, s.batch_size, *v.shape[1:]) for k, v in data.items()}
        carry, kls = jax.lax.scan(minibatch, carry, batches)
        kl = jnp.mean(kls)
        if s.kl_adaptive is not None:
            params, opt_state, rate = carry
            carry = (params, opt_state, _next_rate(s.kl_adaptive, rate, kl))
        return carry, kl

    @jax.jit
    def update(
        params: Params, opt_state: Any, rate: jax.Array, orders: jax.Array, data: dict[str, jax.Array]
    ) -> tuple[Params, Any, jax.Array, jax.Array]:
        # one padding row of weight 0 at index `rows` fills the last mini-batch
        data = {k: jnp.concatenate([v, jnp.zeros((1, *v.shape[1:]), v.dtype)]) for k, v in data.items()}
        (params, opt_state, rate), kls = jax.lax.scan(lambda c, o: epoch(c, o, data), (params, opt_state, rate), orders)
        return params, opt_state, rate, kls

    return update
