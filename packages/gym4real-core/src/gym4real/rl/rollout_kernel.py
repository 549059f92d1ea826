"""The JAX trainer's rollout in compiled code (numba): one call per vector step, and the advantages.

:func:`step` is the whole per-step work besides the environment: it takes the results of the previous
vector step, merges the observations into the running statistics and normalises them (VecNormalize), then
runs the policy and value networks (:func:`gym4real.rl.actor_critic.mlp`, compiled), samples the actions
from noise drawn beforehand, maps them onto the action space and writes everything into the rollout's
buffers. :func:`advantages` is SB3's GAE over the buffers.

The native vector envs reset a copy at the step after its episode ends (Gymnasium's next-step autoreset:
that step's action is ignored, its reward is 0, its observation the reset one). The row of such a step
is marked invalid: it holds no transition, and the update leaves it out. Its forward pass is on the
ended episode's final observation, so its value is the one a truncated episode's last reward is
bootstrapped with (SB3's ``reward += gamma * V(terminal_observation)``). Those final observations are left
out of the running statistics, as VecNormalize, which never sees them among the returned observations,
leaves them out. One timing differs: VecNormalize merges the reset observation (returned in the same step)
before it normalises the final one, while here the reset observation arrives a step later, so the final
observation is normalised without it: the statistics it is normalised with lack one observation of their
count (tested against SB3 on dam, ``tests/test_jax_ppo.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_HALF_LOG_2PI = 0.5 * np.log(2.0 * np.pi)


@njit(cache=True)
def _tanh(x: float) -> float:
    """``tanh`` of a float32 through one ``exp`` (half the time of the C library's ``tanhf``; error below 1e-7)."""
    e = np.exp(np.float32(-2.0) * abs(x))
    t = (np.float32(1.0) - e) / (np.float32(1.0) + e)
    return t if x >= 0 else -t


@njit(cache=True)
def _mlp(weights: tuple[np.ndarray, ...], biases: tuple[np.ndarray, ...], x: np.ndarray) -> np.ndarray:
    """:func:`gym4real.rl.actor_critic.mlp` as loops (a few rows: numba's matrix product costs more than the work).

    The hidden layers' ``tanh`` is :func:`_tanh`: the networks' outputs are numpy's to 1e-6.
    """
    h = x
    last = len(weights) - 1
    for layer in range(len(weights)):
        w, b = weights[layer], biases[layer]
        out = np.empty((h.shape[0], w.shape[1]), dtype=np.float32)
        for r in range(h.shape[0]):
            out[r] = b
            for k in range(w.shape[0]):
                hk = h[r, k]
                for o in range(w.shape[1]):
                    out[r, o] += hk * w[k, o]
            if layer < last:
                for o in range(w.shape[1]):
                    out[r, o] = _tanh(out[r, o])
        h = out
    return h


@njit(cache=True)
def _observe(
    raw: np.ndarray,
    ended: np.ndarray,
    stats: tuple[np.ndarray, np.ndarray, np.ndarray, float, float],
    normalize: bool,
    out: np.ndarray,
) -> None:
    """Merge the rows of ``raw`` that are not final observations into the statistics; normalise all rows.

    ``stats`` is ``(mean, var, count (one element), clip, epsilon)``; the batch's moments are merged with
    SB3's ``RunningMeanStd.update_from_moments`` (population variance of the batch).
    """
    if not normalize:
        out[:] = raw
        return
    mean, var, count, clip, eps = stats
    n, d = raw.shape
    rows = 0
    for i in range(n):
        if not ended[i]:
            rows += 1
    if rows > 0:
        for j in range(d):
            s = 0.0
            for i in range(n):
                if not ended[i]:
                    s += raw[i, j]
            batch_mean = s / rows
            s2 = 0.0
            for i in range(n):
                if not ended[i]:
                    s2 += (raw[i, j] - batch_mean) ** 2
            batch_var = s2 / rows
            delta = batch_mean - mean[j]
            total = count[0] + rows
            m2 = var[j] * count[0] + batch_var * rows + delta * delta * count[0] * rows / total
            mean[j] = mean[j] + delta * rows / total
            var[j] = m2 / total
        count[0] += rows
    for i in range(n):
        for j in range(d):
            x = (raw[i, j] - mean[j]) / np.sqrt(var[j] + eps)
            out[i, j] = min(max(x, -clip), clip)


@njit(cache=True)
def step(
    t: int,
    raw: np.ndarray,
    reward: np.ndarray,
    terminated: np.ndarray,
    truncated: np.ndarray,
    observe: bool,
    stats: tuple[np.ndarray, np.ndarray, np.ndarray, float, float],
    normalize: bool,
    net: tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...], tuple[np.ndarray, ...], tuple[np.ndarray, ...]],
    log_std: np.ndarray,
    noise: np.ndarray,
    value_scale: tuple[float, float, float],
    bounds: tuple[np.ndarray, np.ndarray, int],
    buffers: tuple[np.ndarray, ...],
    env_actions: np.ndarray,
    act: bool,
) -> None:
    """One vector step's work on row ``t`` of the buffers (see the module docstring).

    Args:
        t: The row: the step whose observation is ``raw`` (``observe``) and whose action is drawn (``act``).
        raw: The previous vector step's observations (read when ``observe``, as the next three).
        reward: Its rewards.
        terminated: Its terminations.
        truncated: Its truncations.
        observe: Merge and normalise ``raw`` into row ``t`` and record the previous step's results in row
            ``t - 1`` (False at the first row of a rollout, which holds the previous rollout's last observation).
        stats: The running observation statistics (see :func:`_observe`).
        normalize: Whether observations are normalised.
        net: The policy's weights and biases, then the value network's.
        log_std: The Gaussian's log standard deviations (unused for a categorical policy).
        noise: Row ``t``'s standard normal (Gaussian) or Gumbel (categorical) draws, ``(copies, actions)``.
        value_scale: ``(mean, std, clip)``: values are ``std * clip(v, -clip, clip) + mean`` (clip 0: ``v``).
        bounds: ``(low, high, mode)``: mode 0 maps ``[-1, 1]`` onto the bounds, 1 clips to them, 2 is discrete.
        buffers: ``obs, actions, values, log_probs, rewards, terminated, truncated, valid``.
        env_actions: Where the actions the environment takes are written, ``(copies, actions)`` (a discrete
            action as its number, one column).
        act: Draw the actions (False computes only the values: the bootstrap row after a rollout).
    """
    obs, actions, values, log_probs, rewards, terms, truncs, valid = buffers
    if observe:
        rewards[t - 1] = reward
        terms[t - 1] = terminated
        truncs[t - 1] = truncated
        ended = terminated | truncated
        _observe(raw, ended, stats, normalize, obs[t])
        for i in range(ended.size):
            valid[t, i] = not ended[i]
    x = obs[t]
    pi_w, pi_b, vf_w, vf_b = net
    v = _mlp(vf_w, vf_b, x)
    mean, std, clip = value_scale
    for i in range(x.shape[0]):
        value = v[i, 0]
        if clip > 0.0:
            value = std * min(max(value, -clip), clip) + mean
        values[t, i] = value
    if not act:
        return
    head = _mlp(pi_w, pi_b, x)
    low, high, mode = bounds
    for i in range(x.shape[0]):
        if mode == 2:
            best = 0
            for k in range(head.shape[1]):
                if head[i, k] + noise[i, k] > head[i, best] + noise[i, best]:
                    best = k
            top = head[i, 0]
            for k in range(head.shape[1]):
                top = max(top, head[i, k])
            total = 0.0
            for k in range(head.shape[1]):
                total += np.exp(head[i, k] - top)
            log_probs[t, i] = head[i, best] - top - np.log(total)
            actions[t, i, 0] = best
            env_actions[i, 0] = best + low[0]
            continue
        lp = 0.0
        for k in range(head.shape[1]):
            a = head[i, k] + np.exp(log_std[k]) * noise[i, k]
            actions[t, i, k] = a
            lp += -0.5 * noise[i, k] * noise[i, k] - log_std[k] - _HALF_LOG_2PI
            if mode == 0:
                env_actions[i, k] = low[k] + (min(max(a, -1.0), 1.0) + 1.0) * 0.5 * (high[k] - low[k])
            else:
                env_actions[i, k] = min(max(a, low[k]), high[k])
        log_probs[t, i] = lp


@njit(cache=True)
def advantages(
    rewards: np.ndarray,
    values: np.ndarray,
    terminated: np.ndarray,
    truncated: np.ndarray,
    gamma: float,
    gae_lambda: float,
) -> tuple[np.ndarray, np.ndarray]:
    """SB3's GAE(lambda) advantages and returns of a rollout, truncated episodes bootstrapped.

    ``values`` has one row more than the rewards: the values of the observations after the last step. A
    step that truncated its episode gets ``gamma`` times the value of its final observation (the next row,
    see the module docstring) added to its reward, as SB3 adds it; an ended episode's advantage does not
    reach back past its last step.

    Returns:
        The advantages and the returns (advantages plus values), ``(steps, copies)``.
    """
    steps, n = rewards.shape
    adv = np.zeros((steps, n), dtype=np.float32)
    last = np.zeros(n, dtype=np.float32)
    for t in range(steps - 1, -1, -1):
        for i in range(n):
            r = rewards[t, i]
            if truncated[t, i] and not terminated[t, i]:
                r = np.float32(r + gamma * values[t + 1, i])
            not_done = 0.0 if (terminated[t, i] or truncated[t, i]) else 1.0
            delta = r + gamma * values[t + 1, i] * not_done - values[t, i]
            last[i] = delta + gamma * gae_lambda * not_done * last[i]
            adv[t, i] = last[i]
    return adv, adv + values[:steps]
