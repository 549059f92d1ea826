"""The JAX trainer's actor-critic as data: SB3's ``MlpPolicy`` in plain arrays, and its model file.

The network is Stable-Baselines3's ``ActorCriticPolicy`` with an ``MlpPolicy``: separate policy and value
networks of ``net_arch`` tanh layers, a linear action head (the Gaussian's mean for a Box, the logits for a
Discrete space), a linear value head and, for a Box, a state-independent ``log_std`` vector. Its
parameters are initialised as SB3 does (``ortho_init``): orthogonal weights with gain ``sqrt(2)`` in the
hidden layers, ``0.01`` in the action head, ``1`` in the value head, zero biases, ``log_std`` at
``log_std_init``. A weight is stored ``(inputs, outputs)``: a layer is ``x @ w + b``.

A model file (``model.npz``) is numpy arrays and one JSON text, read with ``allow_pickle=False``: loading it
runs no code. It holds the parameters (``param/<name>``), the observation normalisation statistics
(``obs_mean``, ``obs_var``, with ``clip_obs`` and ``epsilon`` in the JSON) and the spaces the model was
trained on (their bounds as arrays, their kind, shape and dtype in the JSON). :func:`load_ppo_jax` (the
``ppo-jax:PATH`` policies of ``gym4real evaluate`` and ``bench``) acts with it in numpy: jax is not needed
to evaluate a model, only to train one.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from gym4real.core.errors import PolicyError

#: The ``format`` of the model files this module writes and reads.
FORMAT = "gym4real-ppo-jax/1"

#: SB3's orthogonal-initialisation gains: hidden layers, the action head, the value head.
HIDDEN_GAIN, ACTION_GAIN, VALUE_GAIN = float(np.sqrt(2.0)), 0.01, 1.0


def mlp(weights: tuple[np.ndarray, ...], biases: tuple[np.ndarray, ...], x: np.ndarray) -> np.ndarray:
    """``x`` (rows) through the layers ``x @ w + b``, tanh after each but the last (numpy).

    The trainer computes the same layers in its compiled rollout (:mod:`gym4real.rl.rollout_kernel`) and in
    jax (:mod:`gym4real.rl.jax_update`); the tests hold the three to float tolerance.
    """
    h = x
    last = len(weights) - 1
    for i in range(len(weights)):
        h = h @ weights[i] + biases[i]
        if i < last:
            h = np.tanh(h)
    return h


def orthogonal(rng: np.random.Generator, inputs: int, outputs: int, gain: float) -> np.ndarray:
    """A ``(inputs, outputs)`` weight as ``torch.nn.init.orthogonal_`` draws a torch ``(outputs, inputs)`` one.

    A Gaussian matrix, made orthogonal by its QR decomposition with the signs of ``R``'s diagonal, scaled
    by ``gain``: its rows (or columns, whichever are fewer) are orthonormal times ``gain``.
    """
    rows, cols = outputs, inputs
    flat = rng.standard_normal((rows, cols))
    if rows < cols:
        flat = flat.T
    q, r = np.linalg.qr(flat)
    q = q * np.sign(np.diag(r))
    if rows < cols:
        q = q.T
    return np.ascontiguousarray((gain * q).T, dtype=np.float32)


@dataclass(frozen=True)
class Architecture:
    """The shape of an actor-critic.

    Attributes:
        obs_dim: Length of the (flat) observation.
        pi: Hidden layer sizes of the policy network.
        vf: Hidden layer sizes of the value network.
        actions: The action dimension of a Box, or the number of actions of a Discrete space.
        discrete: Whether the policy is a categorical one (Discrete actions).
    """

    obs_dim: int
    pi: tuple[int, ...]
    vf: tuple[int, ...]
    actions: int
    discrete: bool

    def layers(self, net: str) -> list[str]:
        """Parameter names of the layers of ``net`` (``pi`` or ``vf``), head last (``pi/0``, ..., ``pi/out``)."""
        sizes = self.pi if net == "pi" else self.vf
        return [f"{net}/{i}" for i in range(len(sizes))] + [f"{net}/out"]

    def sizes(self, net: str) -> list[int]:
        """Widths of ``net``'s layers from its input to its head."""
        head = self.actions if net == "pi" else 1
        return [self.obs_dim, *(self.pi if net == "pi" else self.vf), head]


def architecture(
    observation_space: gym.Space[Any], action_space: gym.Space[Any], policy_kwargs: dict[str, Any] | None
) -> Architecture:
    """The actor-critic of an ``MlpPolicy`` with ``policy_kwargs`` (``net_arch``; ``log_std_init`` is a value).

    ``net_arch`` is a list (both networks) or ``{pi: [...], vf: [...]}``; SB3's default is ``[64, 64]``.

    Raises:
        PolicyError: A space other than a flat Box observation and a Box or Discrete action, or a
            ``policy_kwargs`` key the trainer does not implement.
    """
    kwargs = dict(policy_kwargs or {})
    unknown = sorted(set(kwargs) - {"net_arch", "log_std_init"})
    if unknown:
        raise PolicyError(
            f"the JAX PPO trainer implements `policy_kwargs` net_arch and log_std_init, not `{unknown[0]}`: "
            "remove it or train with `--trainer sb3`"
        )
    if not isinstance(observation_space, gym.spaces.Box) or len(observation_space.shape) != 1:
        raise PolicyError(
            f"the JAX PPO trainer takes a flat Box observation, not {observation_space}: train with `--trainer sb3`"
        )
    if isinstance(action_space, gym.spaces.Box) and len(action_space.shape) == 1:
        actions, discrete = int(action_space.shape[0]), False
    elif isinstance(action_space, gym.spaces.Discrete):
        actions, discrete = int(action_space.n), True
    else:
        raise PolicyError(
            f"the JAX PPO trainer takes a flat Box or a Discrete action, not {action_space}: train with `--trainer sb3`"
        )
    arch = kwargs.get("net_arch", [64, 64])
    pi, vf = (arch.get("pi", []), arch.get("vf", [])) if isinstance(arch, dict) else (arch, arch)
    return Architecture(int(observation_space.shape[0]), tuple(pi), tuple(vf), actions, discrete)


def initial_parameters(arch: Architecture, log_std_init: float, seed: int) -> dict[str, np.ndarray]:
    """SB3's initial parameters of ``arch`` (see the module docstring), drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    params: dict[str, np.ndarray] = {}
    for net, head_gain in (("pi", ACTION_GAIN), ("vf", VALUE_GAIN)):
        sizes = arch.sizes(net)
        names = arch.layers(net)
        for k, name in enumerate(names):
            gain = head_gain if k == len(names) - 1 else HIDDEN_GAIN
            params[f"{name}/w"] = orthogonal(rng, sizes[k], sizes[k + 1], gain)
            params[f"{name}/b"] = np.zeros(sizes[k + 1], dtype=np.float32)
    if not arch.discrete:
        params["log_std"] = np.full(arch.actions, log_std_init, dtype=np.float32)
    return params


def network(params: dict[str, Any], arch: Architecture, net: str) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """The weights and the biases of ``net`` (``pi`` or ``vf``), input layer first, as :func:`mlp` takes them."""
    names = arch.layers(net)
    return tuple(params[f"{n}/w"] for n in names), tuple(params[f"{n}/b"] for n in names)


@dataclass
class Normalization:
    """VecNormalize's observation statistics: ``clip((obs - mean) / sqrt(var + epsilon), -clip, clip)``."""

    mean: np.ndarray
    var: np.ndarray
    count: float
    clip: float
    epsilon: float = 1e-8

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """Normalised observations, as float32 (as VecNormalize returns them)."""
        return np.clip((obs - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip, self.clip).astype(np.float32)


def _space_record(space: gym.Space[Any], prefix: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    if isinstance(space, gym.spaces.Discrete):
        return {"kind": "Discrete", "n": int(space.n), "start": int(space.start)}, {}
    assert isinstance(space, gym.spaces.Box)
    record = {"kind": "Box", "shape": list(space.shape), "dtype": str(space.dtype)}
    return record, {f"{prefix}_low": space.low, f"{prefix}_high": space.high}


def _same_space(record: dict[str, Any], arrays: Any, prefix: str, space: gym.Space[Any]) -> bool:
    if isinstance(space, gym.spaces.Discrete):
        return record == {"kind": "Discrete", "n": int(space.n), "start": int(space.start)}
    if not isinstance(space, gym.spaces.Box):
        return False
    if record != {"kind": "Box", "shape": list(space.shape), "dtype": str(space.dtype)}:
        return False
    return bool(
        np.array_equal(arrays[f"{prefix}_low"], space.low) and np.array_equal(arrays[f"{prefix}_high"], space.high)
    )


@dataclass
class Model:
    """A trained actor-critic: its architecture, parameters, normalisation and the spaces it acts in.

    Attributes:
        arch: The network's shape.
        params: Parameter name -> float32 array (see :func:`initial_parameters`).
        normalization: The observation statistics, or None when observations are not normalised.
        observation_space: The environment's observation space.
        action_space: The environment's action space (a bounded Box is acted in ``[-1, 1]`` and mapped onto it).
        rescaled: Whether actions are learnt in ``[-1, 1]`` and mapped onto the Box's bounds.
    """

    arch: Architecture
    params: dict[str, np.ndarray]
    normalization: Normalization | None
    observation_space: gym.Space[Any]
    action_space: gym.Space[Any]
    rescaled: bool

    def heads(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The action head (Gaussian means or logits) and the values of a batch of observations (rows)."""
        x = self.normalization(obs) if self.normalization is not None else np.asarray(obs, dtype=np.float32)
        return mlp(*network(self.params, self.arch, "pi"), x), mlp(*network(self.params, self.arch, "vf"), x)[:, 0]

    def actions(self, obs: Any) -> np.ndarray:
        """The deterministic actions of a batch of observations (rows): the Gaussian's mean, or the likeliest action.

        A Box action is clipped to ``[-1, 1]`` and mapped onto the bounds (``rescaled``), else clipped to
        the Box, as SB3's ``predict`` and :class:`~gym4real.rl.sb3.NormalizedPolicy` do.
        """
        head, _ = self.heads(np.asarray(obs).reshape(-1, self.arch.obs_dim))
        if self.arch.discrete:
            return np.argmax(head, axis=1).astype(np.int64) + int(self.action_space.start)  # type: ignore[attr-defined]
        space = self.action_space
        assert isinstance(space, gym.spaces.Box)
        if self.rescaled:
            low, high = space.low, space.high
            return (low + (np.clip(head, -1.0, 1.0) + 1.0) * 0.5 * (high - low)).astype(space.dtype)
        return np.clip(head, space.low, space.high).astype(space.dtype)

    def __call__(self, obs: Any) -> Any:
        """The deterministic action of one observation."""
        return self.actions(np.asarray(obs)[None])[0]

    def save(self, path: Path) -> None:
        """Write the model file (see the module docstring)."""
        obs_record, obs_arrays = _space_record(self.observation_space, "observation")
        act_record, act_arrays = _space_record(self.action_space, "action")
        meta: dict[str, Any] = {
            "format": FORMAT,
            "obs_dim": self.arch.obs_dim,
            "pi": list(self.arch.pi),
            "vf": list(self.arch.vf),
            "actions": self.arch.actions,
            "discrete": self.arch.discrete,
            "rescaled": self.rescaled,
            "observation_space": obs_record,
            "action_space": act_record,
            "normalization": None,
        }
        arrays: dict[str, Any] = {f"param/{k}": v for k, v in self.params.items()} | obs_arrays | act_arrays
        norm = self.normalization
        if norm is not None:
            meta["normalization"] = {"clip": norm.clip, "epsilon": norm.epsilon, "count": norm.count}
            arrays |= {"obs_mean": norm.mean, "obs_var": norm.var}
        with path.open("wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **arrays)


def load(path: str | Path, observation_space: gym.Space[Any], action_space: gym.Space[Any]) -> Model:
    """Read a model file for an environment with these spaces.

    Raises:
        PolicyError: Not such a model file, or one trained on other spaces (named).
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as exc:
        raise PolicyError(f"`{path}` is not a model file of the JAX PPO trainer ({FORMAT}): {exc}") from exc
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        found = meta.get("format") if isinstance(meta, dict) else None
        raise PolicyError(f"`{path}` is not a model file of the JAX PPO trainer: format {found!r}, expected {FORMAT!r}")
    for key, space in (("observation", observation_space), ("action", action_space)):
        if not _same_space(meta[f"{key}_space"], arrays, key, space):
            raise PolicyError(
                f"model `{path}` was trained on {key} space {meta[f'{key}_space']} (bounds in the file); this "
                f"environment has {space}: train the model on this environment, or use the one it was trained on"
            )
    arch = Architecture(meta["obs_dim"], tuple(meta["pi"]), tuple(meta["vf"]), meta["actions"], meta["discrete"])
    params = {k.removeprefix("param/"): v for k, v in arrays.items() if k.startswith("param/")}
    norm = meta["normalization"]
    normalization = (
        None
        if norm is None
        else Normalization(arrays["obs_mean"], arrays["obs_var"], float(norm["count"]), norm["clip"], norm["epsilon"])
    )
    return Model(arch, params, normalization, observation_space, action_space, bool(meta["rescaled"]))


def load_ppo_jax(env: gym.Env[Any, Any], path: str | Path) -> Model:
    """Policy loader of ``ppo-jax:PATH``: the model file's deterministic policy for ``env``."""
    return load(path, env.observation_space, env.action_space)
