"""The reference's pretrained PPO agents (SB3 ``CnnPolicy`` exported to ONNX), run with onnxruntime.

Both graphs sample inside (``RandomNormalLike`` for picking, ``Multinomial`` for planning), so the same
input gives a different action on every call, from onnxruntime's own generator. To act
deterministically, or stochastically from the env's generator, the graph is extended in memory with
one more output: the action-net output (the Gaussian mean, or the logits) feeding the sampler.
The policy's ``log_std`` is read from the graph's initialisers. The batch dimension is fixed at 1.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np

from gym4real.core.errors import DataFileError, PolicyError
from gym4real.core.install_hint import require
from gym4real.robofeeder.portable_math import exp

ACTION_NET_WEIGHT = "policy.action_net.weight"
LOG_STD = "policy.log_std"


def _load(path: Path) -> tuple[object, str, np.ndarray | None, tuple[int, ...]]:
    """Session with the action-net output exposed; its name, ``log_std`` and the input shape."""
    onnx = require("onnx", "gym4real-robofeeder", "onnx")
    ort = require("onnxruntime", "gym4real-robofeeder", "onnxruntime")
    numpy_helper = require("onnx.numpy_helper", "gym4real-robofeeder", "onnx")

    if not path.is_file():
        raise DataFileError(f"pretrained agent `{path}` does not exist")
    try:
        model = onnx.load(str(path))
    except Exception as exc:
        raise DataFileError(f"cannot read the ONNX agent `{path}`: {exc}") from exc
    heads = [n.output[0] for n in model.graph.node if ACTION_NET_WEIGHT in n.input]
    if len(heads) != 1:
        msg = f"`{path}` is not an SB3 policy export: expected one node reading `{ACTION_NET_WEIGHT}`"
        raise DataFileError(msg)
    if heads[0] not in {o.name for o in model.graph.output}:
        model.graph.output.append(onnx.ValueInfoProto(name=heads[0]))
    log_std = None
    for init in model.graph.initializer:
        if init.name == LOG_STD:
            log_std = numpy_helper.to_array(init).astype(np.float32).reshape(-1)
    dims = model.graph.input[0].type.tensor_type.shape.dim
    shape = tuple(int(d.dim_value) for d in dims)
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    session = ort.InferenceSession(model.SerializeToString(), options, providers=["CPUExecutionProvider"])
    return session, heads[0], log_std, shape


class _OnnxPolicy:
    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.session, self.head, self.log_std, self.input_shape = _load(self.path)
        self.input_name = self.session.get_inputs()[0].name  # type: ignore[attr-defined]

    def _head(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float32)
        if x.shape == self.input_shape[1:]:
            x = x[None]
        if x.shape != self.input_shape:
            msg = f"agent `{self.path.name}` expects observations of shape {self.input_shape[1:]}, got {x.shape}"
            raise PolicyError(msg)
        (out,) = self.session.run([self.head], {self.input_name: x})  # type: ignore[attr-defined]
        return np.asarray(out, dtype=np.float32).reshape(-1)

    def __getstate__(self) -> dict[str, object]:
        return {k: v for k, v in self.__dict__.items() if k != "session"} | {"session": None}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self.session, self.head, self.log_std, self.input_shape = _load(self.path)


class OnnxPickingAgent(_OnnxPolicy):
    """The pretrained grasp agent: a (1, 50, 50) crop in [0, 1] -> (dx, dy, theta~), unclipped.

    Args:
        path: The ONNX file (``robofeeder-picking.onnx`` layout).
        mode: ``"mean"`` (deterministic) or ``"sample"`` (mean + std * N(0, 1) from the caller's generator).
        clip: Clip actions to [-1, 1] (the reference does not).
    """

    def __init__(self, path: str | Path, mode: Literal["mean", "sample"] = "mean", clip: bool = True) -> None:
        super().__init__(path)
        if self.log_std is None or self.log_std.shape != (3,):
            raise DataFileError(f"`{path}` is not a 3-dimensional Gaussian picking policy (no `{LOG_STD}` of size 3)")
        self.mode = mode
        self.clip = clip

    def __call__(self, obs: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """The action for one crop."""
        action = self._head(obs)
        if self.mode == "sample":
            if rng is None:
                raise PolicyError("a sampling agent needs the caller's `rng` (np.random.Generator)")
            std = exp(np.asarray(self.log_std, dtype=float)).astype(np.float32)
            action = action + std * rng.standard_normal(3).astype(np.float32)
        if self.clip:
            action = np.clip(action, -1.0, 1.0)
        return action.astype(np.float32)


class OnnxPlanningAgent(_OnnxPolicy):
    """The pretrained planning agent: (N, 50, 50) crops -> crop index (1..N) or 0 (idle).

    The reference's ``robofeeder-planning.onnx`` ignores its input: the first tanh layer of its policy head
    (256 units) is saturated at +-1 for any observation brighter than about 0.01, so its logits are the same
    for every real observation (all ones and noise too) and the argmax is always crop 1; only an all-black
    observation gives other logits (idle). As a baseline it never idles: it picks whatever is in crop 1.

    Args:
        path: The ONNX file (``robofeeder-planning.onnx`` layout).
        mode: ``"mean"`` (argmax of the logits) or ``"sample"`` (softmax sample from the caller's generator).
    """

    def __init__(self, path: str | Path, mode: Literal["mean", "sample"] = "mean") -> None:
        super().__init__(path)
        self.mode = mode

    def logits(self, obs: np.ndarray) -> np.ndarray:
        """The action-net output (N + 1 logits) for one observation."""
        return self._head(obs).astype(np.float64)

    def __call__(self, obs: np.ndarray, rng: np.random.Generator | None = None) -> int:
        """The action for one observation."""
        logits = self.logits(obs)
        if self.mode == "mean":
            return int(np.argmax(logits))
        if rng is None:
            raise PolicyError("a sampling agent needs the caller's `rng` (np.random.Generator)")
        p = exp(logits - logits.max())
        return int(rng.choice(len(p), p=p / p.sum()))
