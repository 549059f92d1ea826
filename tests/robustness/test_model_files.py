"""A trained-model file is data, never code: no entry of an SB3 zip is unpickled (issue 12, section 1).

Each crafted file carries a pickle that, if unpickled, creates a marker file. The marker must never
appear, whatever the entry that carries it and whichever entry point loads the file.
"""

from __future__ import annotations

import base64
import json
import pickle
import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from gym4real.bench.policies import make_policy
from gym4real.cli import main
from gym4real.core.errors import PolicyError

pytest.importorskip("stable_baselines3")


class _Touch:
    """Unpickling this creates ``marker`` (pathlib.Path.touch runs during ``pickle.loads``)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (Path.touch, (self.marker,))


def _payload(marker: Path) -> str:
    return base64.b64encode(pickle.dumps(_Touch(marker))).decode()


def _rewrite_data(path: Path, edit: Any) -> None:
    """Rewrite the ``data`` entry of a zip in place with ``edit(data)``."""
    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(entries["data"])
    edit(data)
    entries["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(path, "w") as archive:
        for name, raw in entries.items():
            archive.writestr(name, raw)


@pytest.mark.parametrize("kind", ["ppo", "dqn"])
def test_a_pickled_entry_sb3_does_not_write_is_refused_by_name(kind: str, tmp_path: Path) -> None:
    marker = tmp_path / "marker"
    model = tmp_path / "model.zip"
    with zipfile.ZipFile(model, "w") as archive:
        archive.writestr("data", json.dumps({"evil": {":type:": "<class 'object'>", ":serialized:": _payload(marker)}}))
    env = gym.make("gym4real/elevator-v0")
    with pytest.raises(PolicyError, match="pickled entry `evil`"):
        make_policy("gym4real/elevator-v0", f"{kind}:{model}", env)
    assert not marker.exists()


def _saved_model(kind: str, env_id: str, path: Path) -> None:
    import stable_baselines3 as sb3
    import torch

    from gym4real.rl.sb3 import _rescale

    env = _rescale(gym.make(env_id))
    policy = "MultiInputPolicy" if isinstance(env.observation_space, gym.spaces.Dict) else "MlpPolicy"
    algo = kind.removeprefix("sb3:")
    if algo == "ppo":
        model = sb3.PPO(policy, env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    elif algo == "a2c":  # A2C pickles its policy kwargs (the RMSprop optimizer class); these name an activation too
        kwargs = {"net_arch": [16], "activation_fn": torch.nn.ReLU}
        model = sb3.A2C(policy, env, n_steps=8, seed=0, device="cpu", policy_kwargs=kwargs)
    else:  # an off-policy algorithm of SB3 or sb3-contrib
        from gym4real.core.registry import load_object
        from gym4real.rl.model_file import SB3_ALGOS

        algo_cls = load_object(SB3_ALGOS[algo])
        model = algo_cls(policy, env, buffer_size=100, learning_starts=10, seed=0, device="cpu")
    model.learn(32)  # a model saved after training also pickles its training state (`_last_obs`, ...)
    model.save(path)


@pytest.mark.parametrize(
    ("kind", "env_id"),
    [
        ("ppo", "gym4real/dam-v0"),
        ("dqn", "gym4real/elevator-v0"),
        ("sb3:a2c", "gym4real/elevator-v0"),
        ("sb3:sac", "gym4real/dam-v0"),
        ("sb3:qrdqn", "gym4real/elevator-v0"),
        ("sb3:tqc", "gym4real/dam-v0"),
    ],
)
def test_no_entry_sb3_writes_is_unpickled_either(kind: str, env_id: str, tmp_path: Path) -> None:
    clean, crafted, marker = tmp_path / "clean" / "model.zip", tmp_path / "crafted" / "model.zip", tmp_path / "m"
    clean.parent.mkdir()
    crafted.parent.mkdir()
    _saved_model(kind, env_id, clean)
    crafted.write_bytes(clean.read_bytes())
    pickled: list[str] = []

    def poison(data: dict[str, Any]) -> None:
        for key, value in data.items():
            if isinstance(value, dict) and ":serialized:" in value:
                value[":serialized:"] = _payload(marker)
                pickled.append(key)

    _rewrite_data(crafted, poison)
    assert {"policy_class", "observation_space", "action_space", "lr_schedule", "_last_obs"} <= set(pickled)
    if kind == "sb3:a2c":
        assert "policy_kwargs" in pickled
    env = gym.make(env_id)
    reference, loaded = make_policy(env_id, f"{kind}:{clean}", env), make_policy(env_id, f"{kind}:{crafted}", env)
    assert not marker.exists()
    obs, _ = env.reset(seed=3)
    for _ in range(5):
        action = loaded(obs)
        np.testing.assert_array_equal(action, reference(obs))
        assert env.action_space.contains(action)
        obs, *_ = env.step(action)


@pytest.mark.parametrize("display", [None, "[-1. -1. -1.  0.]"])
def test_a_model_saved_under_the_other_gymnasium_version_loads(display: str | None, tmp_path: Path) -> None:
    """gymnasium 1.2 writes the bounds' display text (``low_repr``) beside a Box, later versions ``None``.

    The published models were saved under one version and are evaluated under both (CI runs 1.2.2, which
    RLlib pins): the text is not a property of the space, the bounds are.
    """
    model = tmp_path / "model.zip"
    _saved_model("ppo", "gym4real/dam-v0", model)

    def other_version(data: dict[str, Any]) -> None:
        data["observation_space"]["low_repr"] = display
        data["observation_space"]["high_repr"] = display

    _rewrite_data(model, other_version)
    env = gym.make("gym4real/dam-v0")
    obs, _ = env.reset(seed=0)
    assert env.action_space.contains(make_policy("gym4real/dam-v0", f"ppo:{model}", env)(obs))

    def other_bounds(data: dict[str, Any]) -> None:
        data["observation_space"]["high"] = "[   7.    1.    1. 1000.]"

    _rewrite_data(model, other_bounds)
    with pytest.raises(PolicyError, match=r"observation space of another kind \(high "):
        make_policy("gym4real/dam-v0", f"ppo:{model}", env)


def test_bench_refuses_a_crafted_model_and_runs_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    marker = tmp_path / "marker"
    model = tmp_path / "model.zip"
    _saved_model("ppo", "gym4real/dam-v0", model)
    _rewrite_data(model, lambda d: d.update(hook={":type:": "<class 'x'>", ":serialized:": _payload(marker)}))
    status = main(["bench", "gym4real/dam-v0", "--policies", f"ppo:{model}", "--episodes", "1", "--quiet"])
    assert status == 2 and not marker.exists()
    assert "pickled entry `hook`" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"not a zip", "not a zip archive"),
        (None, "has no `data` entry"),
        (b"{", "not the JSON"),
    ],
)
def test_a_file_that_is_not_a_model_is_a_clear_error(content: bytes | None, message: str, tmp_path: Path) -> None:
    model = tmp_path / "model.zip"
    if content == b"not a zip":
        model.write_bytes(content)
    else:
        with zipfile.ZipFile(model, "w") as archive:
            archive.writestr("data" if content else "other", content or b"")
    with pytest.raises(PolicyError, match=message):
        make_policy("gym4real/elevator-v0", f"ppo:{model}", gym.make("gym4real/elevator-v0"))


def test_policy_kwargs_that_are_not_literals_or_known_classes_are_refused(tmp_path: Path) -> None:
    marker, model = tmp_path / "marker", tmp_path / "model.zip"
    _saved_model("sb3:a2c", "gym4real/elevator-v0", model)

    def poison(data: dict[str, Any]) -> None:
        data["policy_kwargs"][":serialized:"] = _payload(marker)
        data["policy_kwargs"]["activation_fn"] = "<class 'os.system'>"

    _rewrite_data(model, poison)
    with pytest.raises(PolicyError, match="policy argument `activation_fn`"):
        make_policy("gym4real/elevator-v0", f"sb3:A2C:{model}", gym.make("gym4real/elevator-v0"))
    assert not marker.exists()


def test_an_algorithm_sb3_does_not_ship_is_refused(tmp_path: Path) -> None:
    model = tmp_path / "model.zip"
    _saved_model("sb3:a2c", "gym4real/elevator-v0", model)
    with pytest.raises(PolicyError, match="unknown Stable-Baselines3 algorithm `ars`"):
        make_policy("gym4real/elevator-v0", f"sb3:ars:{model}", gym.make("gym4real/elevator-v0"))


def test_the_data_entry_of_a_model_on_camera_images_is_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """SB3 prints the observation space's bounds into ``data``: 10.8 MB for picking-v1's 1 x 300 x 300 frames."""
    from gym4real.rl import model_file

    bounds = "[[[0. " + "0. " * 1_800_000 + "]]]"  # as long as SB3's text of the bounds in picking-v1's model
    space = {":type:": "<class 'gymnasium.spaces.box.Box'>", "low": bounds, "high": bounds, "shape": [1, 300, 300]}
    model = tmp_path / "model.zip"
    with zipfile.ZipFile(model, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("data", json.dumps({"observation_space": space}))
    assert zipfile.ZipFile(model).getinfo("data").file_size > 4 * 2**20  # over the old limit
    assert model_file.read_data(model)["observation_space"]["shape"] == [1, 300, 300]
    monkeypatch.setattr(model_file, "MAX_DATA_BYTES", 2**20)  # a larger entry is still refused, by its size
    with pytest.raises(PolicyError, match="bytes; a Stable-Baselines3 model writes a few KB"):
        model_file.read_data(model)


@pytest.mark.parametrize(
    ("kind", "env_id"), [("ppo", "gym4real/dam-v0"), ("dqn", "gym4real/elevator-v0"), ("sb3:sac", "gym4real/dam-v0")]
)
def test_a_model_without_its_optimizer_state_acts_as_the_trained_one_and_is_smaller(
    kind: str, env_id: str, tmp_path: Path
) -> None:
    """Published models: the trading ones were 4.5-6.4 MB, two thirds of it Adam's moments (issue 47)."""
    import stable_baselines3 as sb3
    import torch

    from gym4real.rl.model_file import save_without_optimizer_state

    trained, slim = tmp_path / "trained.zip", tmp_path / "slim.zip"
    _saved_model(kind, env_id, trained)
    save_without_optimizer_state(trained, slim)
    assert slim.stat().st_size < 0.6 * trained.stat().st_size
    with zipfile.ZipFile(trained) as full, zipfile.ZipFile(slim) as kept:
        assert full.namelist() == kept.namelist()
        optimizers = [n for n in full.namelist() if n.endswith("optimizer.pth")]
        assert optimizers and len(optimizers) == (3 if kind == "sb3:sac" else 1)
        for name in full.namelist():
            if name not in optimizers:  # settings and weights byte for byte
                assert full.read(name) == kept.read(name), name
    env = gym.make(env_id)
    reference, loaded = make_policy(env_id, f"{kind}:{trained}", env), make_policy(env_id, f"{kind}:{slim}", env)
    obs, _ = env.reset(seed=3)
    for _ in range(20):
        action = loaded(obs)
        np.testing.assert_array_equal(action, reference(obs))
        obs, *_ = env.step(action)
    if kind == "ppo":  # SB3 reads it too: the parameter groups are kept, the state is empty
        model = sb3.PPO.load(slim, device="cpu")
        assert model.policy.optimizer.state_dict()["state"] == {}
        original = sb3.PPO.load(trained, device="cpu").policy.parameters()
        for mine, theirs in zip(model.policy.parameters(), original, strict=True):
            assert torch.equal(mine, theirs)


def test_the_published_copy_is_a_function_of_the_trained_file_whenever_it_is_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An unpublished model (picking-v1's, 137 MiB) is listed by its published copy's SHA-256: a later upload
    re-creates that copy from the trained file, so the copy must not depend on when it is written."""
    import time

    from gym4real.rl.model_file import save_without_optimizer_state

    trained, first, later = tmp_path / "trained.zip", tmp_path / "first.zip", tmp_path / "later.zip"
    _saved_model("ppo", "gym4real/dam-v0", trained)
    save_without_optimizer_state(trained, first)
    now = time.time()
    monkeypatch.setattr(time, "time", lambda: now + 3 * 365 * 86400)  # written three years later
    save_without_optimizer_state(trained, later)
    assert later.read_bytes() == first.read_bytes()


def test_a_file_whose_optimizer_entry_is_not_an_optimizer_state_is_not_published(tmp_path: Path) -> None:
    import io

    import torch

    from gym4real.rl.model_file import save_without_optimizer_state

    trained = tmp_path / "model.zip"
    _saved_model("ppo", "gym4real/dam-v0", trained)
    forged = tmp_path / "forged.zip"
    with zipfile.ZipFile(trained) as full, zipfile.ZipFile(forged, "w") as out:
        for name in full.namelist():
            buffer = io.BytesIO()
            torch.save({"weights": torch.zeros(3)}, buffer)
            out.writestr(name, buffer.getvalue() if name == "policy.optimizer.pth" else full.read(name))
    with pytest.raises(PolicyError, match=r"`policy\.optimizer\.pth` is not an optimizer's state"):
        save_without_optimizer_state(forged, tmp_path / "slim.zip")
