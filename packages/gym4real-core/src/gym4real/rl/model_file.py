"""A Stable-Baselines3 model file read as data: nothing in it is unpickled.

SB3's ``load`` unpickles (cloudpickle) every entry of the zip's ``data`` JSON marked ``:serialized:``,
so a crafted file runs code the moment it is loaded. gym4real reads ``data`` itself first: an entry
that SB3 does not write for the file's algorithm (A2C, DDPG, DQN, PPO, SAC, TD3, and sb3-contrib's CrossQ,
QRDQN, TQC, TRPO) is refused by name,
and every entry it does write is replaced, through SB3's ``custom_objects``, by an object built here
(the environment's spaces, SB3's own policy and buffer classes, constant schedules, and the policy's
keyword arguments rebuilt from the text SB3 writes beside their pickle: literals, and torch's activation
and optimizer classes and SB3's feature extractors by name). The weights (``*.pth``) are read by SB3
with ``torch.load(weights_only=True)``, which loads tensors only.
"""

from __future__ import annotations

import ast
import json
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym

from gym4real.core.errors import PolicyError

#: Largest ``data`` entry read from a model file. SB3 writes a few KB plus the observation space, whose bounds
#: it prints element by element: about 120 bytes per element, 10.8 MB for picking-v1's 1 x 300 x 300 image.
MAX_DATA_BYTES = 256 * 2**20

#: Training state SB3 pickles in a model saved during or after ``learn`` (replaced by empty values).
TRAINING_STATE = frozenset(
    {"_last_obs", "_last_episode_starts", "_last_original_obs", "ep_info_buffer", "ep_success_buffer"}
)

#: Pickled entries SB3 writes for every algorithm (``policy_kwargs`` when they hold a class, as A2C's optimizer;
#: ``learning_rate`` when it is a schedule, as a preset's cosine or KL-adaptive rate).
_COMMON = TRAINING_STATE | {
    "policy_class",
    "observation_space",
    "action_space",
    "lr_schedule",
    "learning_rate",
    "policy_kwargs",
}
_ON_POLICY = _COMMON | {"rollout_buffer_class"}
_OFF_POLICY = _COMMON | {"replay_buffer_class", "train_freq", "action_noise"}

#: The pickled entries SB3 and sb3-contrib write for each algorithm; anything else pickled is refused.
SERIALIZED_ENTRIES: dict[str, frozenset[str]] = {
    "a2c": _ON_POLICY,
    "ppo": _ON_POLICY | {"clip_range", "clip_range_vf"},
    "dqn": _OFF_POLICY | {"exploration_schedule"},
    "sac": _OFF_POLICY,
    "td3": _OFF_POLICY,
    "ddpg": _OFF_POLICY,
    "qrdqn": _OFF_POLICY | {"exploration_schedule"},
    "tqc": _OFF_POLICY | {"target_entropy"},
    "trpo": _ON_POLICY,
    "crossq": _OFF_POLICY,
}

#: Algorithm key -> ``module:Class`` (sb3-contrib's where it is installed; its recurrent and maskable
#: PPO and ARS are left out: their policies need state or action masks that a plain policy call lacks).
SB3_ALGOS = {
    "a2c": "stable_baselines3:A2C",
    "ddpg": "stable_baselines3:DDPG",
    "dqn": "stable_baselines3:DQN",
    "ppo": "stable_baselines3:PPO",
    "sac": "stable_baselines3:SAC",
    "td3": "stable_baselines3:TD3",
    "crossq": "sb3_contrib:CrossQ",
    "qrdqn": "sb3_contrib:QRDQN",
    "tqc": "sb3_contrib:TQC",
    "trpo": "sb3_contrib:TRPO",
}


def algo_name(algo: str) -> str:
    """The class name of an algorithm key (``qrdqn`` -> ``QRDQN``)."""
    return SB3_ALGOS[algo].partition(":")[2]


#: Buffer classes of SB3 that a model file may name (only used to rebuild the algorithm object).
BUFFERS = ("RolloutBuffer", "DictRolloutBuffer", "ReplayBuffer", "DictReplayBuffer", "NStepReplayBuffer")

TRUST_NOTE = (
    "a model file is data: gym4real never unpickles it, and loads only the weights and the settings "
    f"that Stable-Baselines3 and sb3-contrib write for {', '.join(algo_name(a) for a in SB3_ALGOS)}"
)


def read_data(path: Path) -> dict[str, Any]:
    """Return the ``data`` JSON of an SB3 zip, without deserialising anything.

    Raises:
        PolicyError: Not a zip, no ``data`` entry, an oversized or malformed one.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            try:
                info = archive.getinfo("data")
            except KeyError:
                raise PolicyError(
                    f"`{path}` is not a Stable-Baselines3 model file: the zip has no `data` entry"
                ) from None
            if info.file_size > MAX_DATA_BYTES:
                raise PolicyError(
                    f"`{path}`: its `data` entry is {info.file_size} bytes; a Stable-Baselines3 model writes a few KB "
                    f"and about 120 bytes per element of its observation space (at most {MAX_DATA_BYTES} read)"
                )
            raw = archive.read(info)
    except zipfile.BadZipFile as exc:
        raise PolicyError(f"`{path}` is not a Stable-Baselines3 model file (not a zip archive): {exc}") from exc
    try:
        data = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PolicyError(f"`{path}`: the `data` entry is not the JSON that Stable-Baselines3 writes: {exc}") from exc
    if not isinstance(data, dict):
        raise PolicyError(f"`{path}`: the `data` entry must be a JSON object, not {type(data).__name__}")
    return data


def serialized_entries(data: dict[str, Any]) -> list[str]:
    """Return the keys of ``data`` that SB3 would unpickle."""
    return sorted(k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v)


def _described(space: gym.Space[Any]) -> dict[str, Any]:
    """The JSON description SB3 writes beside a pickled space (type and attributes, as text)."""
    from stable_baselines3.common.save_util import data_to_json

    described: dict[str, Any] = json.loads(data_to_json({"space": space}))["space"]
    return described


def _check_space(path: Path, key: str, saved: Any, expected: gym.Space[Any]) -> None:
    """Compare the description of a saved space with the environment's (attributes both versions write).

    The pickle, the generator and the display text of the bounds (``low_repr``/``high_repr``: gymnasium 1.2
    writes text, later versions ``None``) are left out; the bounds themselves are compared.
    """
    mine = _described(expected)
    ignored = {":serialized:", "_np_random", "low_repr", "high_repr"}
    theirs = saved if isinstance(saved, dict) else {}
    differing = sorted(k for k in (set(mine) & set(theirs)) - ignored if str(mine[k]) != str(theirs[k]))
    if ":type:" not in theirs or theirs[":type:"] != mine[":type:"] or differing:
        what = "; ".join(f"{k} {theirs.get(k)} instead of {mine.get(k)}" for k in differing) or (
            f"{theirs.get(':type:')} instead of {mine[':type:']}"
        )
        raise PolicyError(
            f"model `{path}` was trained on {key.replace('_', ' ')} of another kind ({what}); this environment has "
            f"{expected}: train the model on this environment, or use the environment and config it was trained on"
        )


def _policy_class(path: Path, algo_cls: Any, saved: Any) -> type:
    """The SB3 policy class the file names, among those the algorithm ships."""
    saved = saved if isinstance(saved, dict) else {}
    for cls in dict.fromkeys(algo_cls.policy_aliases.values()):
        init = getattr(cls.__init__, "__qualname__", "")
        if saved.get("__module__") == cls.__module__ and str(saved.get("__init__", "")).startswith(
            f"<function {init} "
        ):
            found: type = cls
            return found
    names = sorted(algo_cls.policy_aliases)
    raise PolicyError(
        f"model `{path}`: its policy class ({saved.get('__module__')}, {saved.get('__init__')}) is not one that "
        f"Stable-Baselines3 ships for {algo_cls.__name__} ({', '.join(names)}); {TRUST_NOTE}"
    )


def _buffer_class(path: Path, saved: Any) -> type:
    from stable_baselines3.common import buffers

    init = str(saved.get("__init__", "")) if isinstance(saved, dict) else ""
    for name in BUFFERS:
        if init.startswith(f"<function {name}.__init__ "):
            cls: type = getattr(buffers, name)
            return cls
    raise PolicyError(f"model `{path}`: its buffer class ({init or 'unnamed'}) is not one of SB3's {list(BUFFERS)}")


def _named_classes() -> dict[str, type]:
    """``str(cls)`` -> cls for the classes a policy's keyword arguments may name.

    Those are torch's activation modules and optimizers and SB3's feature extractors.
    """
    import torch
    from stable_baselines3.common import torch_layers

    found: dict[str, type] = {}
    for module, base in (
        (torch.nn.modules.activation, torch.nn.Module),
        (torch.optim, torch.optim.Optimizer),
        (torch_layers, torch_layers.BaseFeaturesExtractor),
    ):
        for value in vars(module).values():
            if isinstance(value, type) and issubclass(value, base):
                found[str(value)] = value
    return found


def _policy_kwargs(path: Path, saved: Any) -> dict[str, Any]:
    """The policy's keyword arguments, rebuilt from the text SB3 writes beside their pickle.

    Raises:
        PolicyError: A value that is neither a literal nor a class named in :func:`_named_classes`.
    """
    described = saved if isinstance(saved, dict) else {}
    classes = _named_classes()
    kwargs: dict[str, Any] = {}
    for key, value in described.items():
        if key.startswith(":"):
            continue
        if not isinstance(value, str):  # SB3 wrote it as JSON
            kwargs[key] = value
        elif value in classes:
            kwargs[key] = classes[value]
        else:
            try:
                kwargs[key] = ast.literal_eval(value)
            except (ValueError, SyntaxError):
                raise PolicyError(
                    f"model `{path}`: its policy argument `{key}` ({value[:80]}) is neither a literal nor a torch "
                    f"activation, optimizer or SB3 feature extractor class; it was not loaded ({TRUST_NOTE})"
                ) from None
    return kwargs


def custom_objects(
    path: Path, algo: str, algo_cls: Any, observation_space: gym.Space[Any], action_space: gym.Space[Any]
) -> dict[str, Any]:
    """Return SB3 ``custom_objects`` that replace every pickled entry of the file, so none is unpickled.

    Args:
        path: The model zip.
        algo: A key of :data:`SERIALIZED_ENTRIES` (``a2c``, ``ppo``, ...).
        algo_cls: The SB3 algorithm class.
        observation_space: The space the model must have been trained on.
        action_space: Likewise for actions (``[-1, 1]`` for a rescaled Box).

    Raises:
        PolicyError: A pickled entry that SB3 does not write for ``algo`` (named), a policy or buffer
            class SB3 does not ship, or spaces that differ from the environment's.
    """
    from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit
    from stable_baselines3.common.utils import ConstantSchedule

    data = read_data(path)
    pickled = serialized_entries(data)
    refused = [k for k in pickled if k not in SERIALIZED_ENTRIES[algo]]
    if refused:
        raise PolicyError(
            f"model `{path}` holds pickled entr{'y' if len(refused) == 1 else 'ies'} "
            f"{', '.join(f'`{k}`' for k in refused)} that Stable-Baselines3 does not write for {algo_name(algo)}; "
            f"it was not loaded ({TRUST_NOTE}). Save the model with Stable-Baselines3's own `save`"
        )
    if "policy_class" not in data or "observation_space" not in data or "action_space" not in data:
        raise PolicyError(f"model `{path}` is not a {algo_name(algo)} model file: it names no policy class or spaces")
    _check_space(path, "observation_space", data["observation_space"], observation_space)
    _check_space(path, "action_space", data["action_space"], action_space)
    constant: Callable[[float], float] = ConstantSchedule(0.0)
    replacements: dict[str, Any] = {
        "policy_class": _policy_class(path, algo_cls, data["policy_class"]),
        "observation_space": observation_space,
        "action_space": action_space,
        "lr_schedule": constant,
        "learning_rate": constant,
        "clip_range": constant,
        "clip_range_vf": None,
        "exploration_schedule": constant,
        "train_freq": TrainFreq(1, TrainFrequencyUnit.STEP),
        "action_noise": None,  # exploration noise of training; a deterministic policy never draws it
        "target_entropy": 0.0,  # TQC's entropy target, a training setting that acting never reads
        **dict.fromkeys(TRAINING_STATE),
    }
    if "policy_kwargs" in pickled:
        replacements["policy_kwargs"] = _policy_kwargs(path, data["policy_kwargs"])
    for key in ("rollout_buffer_class", "replay_buffer_class"):
        if key in pickled:
            replacements[key] = _buffer_class(path, data[key])
    objects = {k: replacements[k] for k in pickled}
    if "replay_buffer_class" in pickled:  # inference only: no need for the file's (up to 1M-transition) buffer
        objects["buffer_size"] = 1
    return objects


def save_without_optimizer_state(source: Path, path: Path) -> None:
    """Write a copy of the SB3 model file ``source`` whose optimizers hold no per-parameter state.

    Every entry is kept byte for byte (the settings, the weights, the optimizers' parameter groups) except
    the optimizers' state (Adam's moments: two more copies of the weights, which acting never reads),
    written empty as a freshly built optimizer's is, and the entries are deflated (the text of the spaces'
    bounds shrinks a hundredfold). SB3's ``load`` and :func:`gym4real.rl.sb3.load_model` read the copy as
    they read ``source``, with the same weights and deterministic actions; training resumed from it would
    restart Adam's moments.

    Raises:
        PolicyError: ``source`` is not a zip, or an ``*optimizer.pth`` entry is not an optimizer's state.
    """
    import io

    import torch

    try:
        with zipfile.ZipFile(source) as archive, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as out:
            for info in archive.infolist():
                content = archive.read(info)
                if info.filename.endswith("optimizer.pth"):  # SB3's `<object>.optimizer.pth` entries
                    state = torch.load(io.BytesIO(content), map_location="cpu", weights_only=True)
                    if not isinstance(state, dict) or set(state) != {"state", "param_groups"}:
                        raise PolicyError(
                            f"`{source}`: its entry `{info.filename}` is not an optimizer's state "
                            "(a dict of `state` and `param_groups`); save the model with Stable-Baselines3's `save`"
                        )
                    buffer = io.BytesIO()
                    torch.save({"state": {}, "param_groups": state["param_groups"]}, buffer)
                    content = buffer.getvalue()
                out.writestr(zipfile.ZipInfo(info.filename, date_time=info.date_time), content, zipfile.ZIP_DEFLATED)
    except zipfile.BadZipFile as exc:
        raise PolicyError(f"`{source}` is not a Stable-Baselines3 model file (not a zip archive): {exc}") from exc
