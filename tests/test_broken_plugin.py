"""A broken plugin is reported once and hides nothing; strict mode raises."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from importlib import metadata as importlib_metadata

import pytest

import gym4real
from gym4real.core import registry as reg_mod
from gym4real.core.errors import EnvUnavailableError, PluginLoadError

BROKEN = importlib_metadata.EntryPoint(
    name="wds", value="gym4real_no_such_module._plugin", group=reg_mod.ENTRY_POINT_GROUP
)


@pytest.fixture
def broken(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    real = list(reg_mod._entry_points())
    others = [ep for ep in real if ep.name != "wds"]
    monkeypatch.setattr(reg_mod, "_entry_points", lambda: [*others, BROKEN])
    monkeypatch.delenv("GYM4REAL_STRICT_PLUGINS", raising=False)
    reg_mod.reload()
    yield
    monkeypatch.undo()
    reg_mod.reload()


def test_broken_plugin_does_not_hide_the_others(broken: None, caplog: pytest.LogCaptureFixture) -> None:
    assert "gym4real/elevator-v0" in gym4real.list_envs()
    errors = gym4real.plugin_errors()
    assert len(errors) == 1
    err = errors[0]
    assert err.plugin == "wds" and err.phase == "import" and "ModuleNotFoundError" in err.error
    assert "pip install --force-reinstall gym4real-wds" in str(err)
    with pytest.raises(EnvUnavailableError, match="wds"):
        gym4real.make("gym4real/wds-v0")


def test_broken_plugin_is_logged_once(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    monkeypatch.setattr(reg_mod, "_entry_points", lambda: [BROKEN])
    monkeypatch.delenv("GYM4REAL_STRICT_PLUGINS", raising=False)
    with caplog.at_level(logging.WARNING, logger="gym4real.plugins"):
        reg_mod.reload()
        gym4real.list_envs()
        gym4real.list_envs()
    assert len([r for r in caplog.records if "gym4real_no_such_module" in r.getMessage()]) == 1
    monkeypatch.undo()
    reg_mod.reload()


def test_strict_mode_raises(broken: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_STRICT_PLUGINS", "1")
    with pytest.raises(PluginLoadError, match="wds"):
        gym4real.list_envs()


def test_a_raising_hook_is_isolated(monkeypatch: pytest.MonkeyPatch) -> None:
    import types

    bad = types.ModuleType("gym4real_bad_hooks")

    @gym4real.core.hookimpl
    def gym4real_register_envs() -> list[object]:
        raise RuntimeError("boom")

    bad.gym4real_register_envs = gym4real_register_envs  # type: ignore[attr-defined]
    ep = importlib_metadata.EntryPoint(name="bad", value="gym4real_bad_hooks", group=reg_mod.ENTRY_POINT_GROUP)
    monkeypatch.setitem(__import__("sys").modules, "gym4real_bad_hooks", bad)
    real = list(reg_mod._entry_points())
    monkeypatch.setattr(reg_mod, "_entry_points", lambda: [*real, ep])
    monkeypatch.delenv("GYM4REAL_STRICT_PLUGINS", raising=False)
    reg_mod.reload()
    try:
        assert "gym4real/elevator-v0" in gym4real.list_envs()
        [err] = gym4real.plugin_errors()
        assert err.phase == "gym4real_register_envs" and "boom" in err.error
    finally:
        monkeypatch.undo()
        reg_mod.reload()
