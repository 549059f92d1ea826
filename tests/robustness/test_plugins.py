"""Plugins cannot hijack an id or a domain's entry point, stop the interpreter, or stay half-registered.

Each case installs fake distributions beside the real ones (the ``fake_plugins`` fixture of ``tests/conftest.py``).
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

import gym4real
from gym4real.core.errors import EnvUnavailableError, PluginLoadError
from gym4real.core.registry import Registry, registry

FakePlugins = Callable[..., Registry]


@pytest.mark.parametrize("first", [True, False], ids=["fake-listed-first", "fake-listed-last"])
def test_a_second_distribution_named_like_a_domain_is_a_reported_conflict(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str], first: bool
) -> None:
    evil = ("evil-wds", "6.6", {"wds": "g4r_fake_wds"})
    reg = fake_plugins(evil, modules={"g4r_fake_wds": plugin_source(["gym4real/wds-v0"])}, first=first)
    assert "gym4real/wds-v0" not in reg.envs  # neither the real plugin nor the impostor wins
    assert "gym4real/elevator-v0" in reg.envs
    errors = [e for e in gym4real.plugin_errors() if e.plugin == "wds"]
    assert sorted(e.distribution for e in errors) == ["evil-wds", "gym4real-wds"]
    for err in errors:
        assert err.phase == "conflict"
        assert "evil-wds" in str(err) and "gym4real-wds" in str(err) and "pip uninstall" in str(err)
    with pytest.raises(EnvUnavailableError, match="evil-wds"):
        gym4real.make("gym4real/wds-v0")
    with pytest.raises(PluginLoadError, match="evil-wds"):
        registry(strict=True)


def test_a_plugin_that_sorts_first_cannot_take_over_another_domains_id(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str]
) -> None:
    squatter = ("aaa-envs", "1.0", {"aaa": "g4r_fake_aaa"})
    reg = fake_plugins(squatter, modules={"g4r_fake_aaa": plugin_source(["gym4real/dam-v0"])})
    assert "gym4real/dam-v0" not in reg.envs
    assert "gym4real/elevator-v0" in reg.envs
    errors = {e.plugin: e for e in gym4real.plugin_errors()}
    assert sorted(errors) == ["aaa", "dam"]
    for err in errors.values():
        assert err.phase == "conflict" and "`gym4real/dam-v0`" in err.error
        assert "aaa-envs" in str(err) and "gym4real-dam" in str(err)
    with pytest.raises(EnvUnavailableError, match="aaa-envs"):
        gym4real.make("gym4real/dam-v0")
    with pytest.raises(PluginLoadError, match="conflict"):
        registry(strict=True)


@pytest.mark.parametrize("case", ["id-claimed-twice", "entry-point-name-claimed-twice"])
def test_gymnasium_make_of_an_id_lost_to_a_conflict_names_both_distributions_and_the_fix(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str], case: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`gymnasium.make`, not only `gym4real.make`: our error, never Gymnasium's bare `NameNotFound`."""
    import gymnasium as gym

    from gym4real.core.registry import register_envs

    name = "aaa" if case == "id-claimed-twice" else "dam"
    reg = fake_plugins(
        ("aaa-envs", "1.0", {name: "g4r_fake_aaa"}), modules={"g4r_fake_aaa": plugin_source(["gym4real/dam-v0"])}
    )
    assert "gym4real/dam-v0" not in reg.envs
    monkeypatch.delitem(gym.registry, "gym4real/dam-v0")  # as in a fresh process, where it was never registered
    register_envs()
    with pytest.raises(EnvUnavailableError) as raised:
        gym.make("gym4real/dam-v0")
    message = str(raised.value)
    assert "aaa-envs" in message and "gym4real-dam" in message
    assert "`pip uninstall aaa-envs`" in message and "`pip uninstall gym4real-dam`" in message
    assert gym.make("gym4real/elevator-v0").unwrapped.spec.id == "gym4real/elevator-v0"


@pytest.mark.parametrize(
    "statement",
    [
        "import sys; sys.exit(3)",
        "raise SystemExit('bye')",
        "raise GeneratorExit",
        "class Stop(BaseException): pass\nraise Stop('stop')",
    ],
    ids=["sys.exit", "SystemExit", "GeneratorExit", "BaseException"],
)
def test_an_exit_at_plugin_import_is_reported_and_does_not_escape(fake_plugins: FakePlugins, statement: str) -> None:
    reg = fake_plugins(("quitter", "1.0", {"quitter": "g4r_fake_exit"}), modules={"g4r_fake_exit": statement})
    assert "gym4real/elevator-v0" in reg.envs
    [err] = gym4real.plugin_errors()
    assert (err.plugin, err.distribution, err.phase) == ("quitter", "quitter", "import")


def test_an_exit_in_a_registration_hook_is_reported_and_does_not_escape(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str]
) -> None:
    body = "@hookimpl\ndef gym4real_register_datasets():\n    import sys; sys.exit(4)\n"
    dist = ("quitter", "1.0", {"quitter": "g4r_fake_exit_hook"})
    reg = fake_plugins(dist, modules={"g4r_fake_exit_hook": plugin_source(["gym4real/quitter-v0"], body=body)})
    assert "gym4real/quitter-v0" not in reg.envs
    [err] = gym4real.plugin_errors()
    assert err.phase == "gym4real_register_datasets" and "SystemExit" in err.error


def test_a_keyboard_interrupt_at_plugin_import_still_interrupts(fake_plugins: FakePlugins) -> None:
    dist = ("quitter", "1.0", {"quitter": "g4r_fake_interrupt"})
    with pytest.raises(KeyboardInterrupt):
        fake_plugins(dist, modules={"g4r_fake_interrupt": "raise KeyboardInterrupt"})


@pytest.mark.parametrize(
    "entry_point", ["g4r_no_such_module.env:GhostEnv", "g4r_fake_ghost_pkg.env:GhostEnv"], ids=["package", "module"]
)
def test_a_missing_env_module_is_reported_at_discovery_not_raised_at_make(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str], entry_point: str
) -> None:
    dist = ("ghost-envs", "1.0", {"ghost": "g4r_fake_ghost"})
    modules = {
        "g4r_fake_ghost": plugin_source(["gym4real/ghost-v0"], entry_point=entry_point),
        "g4r_fake_ghost_pkg.__init__": "",
    }
    reg = fake_plugins(dist, modules=modules)
    assert "gym4real/ghost-v0" not in reg.envs
    [err] = gym4real.plugin_errors()
    missing = entry_point.partition(":")[0]
    assert err.plugin == "ghost" and f"`{missing}`" in err.error and "ghost-envs" in str(err)
    with pytest.raises(EnvUnavailableError, match=missing):
        gym4real.make("gym4real/ghost-v0")


def test_a_plugin_with_a_good_and_a_duplicate_id_registers_neither(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str]
) -> None:
    dist = ("half-envs", "1.0", {"half": "g4r_fake_half"})
    reg = fake_plugins(dist, modules={"g4r_fake_half": plugin_source(["gym4real/half-v0", "gym4real/elevator-v0"])})
    assert "gym4real/half-v0" not in reg.envs and "gym4real/elevator-v0" not in reg.envs
    assert "half" not in reg.owners.values()
    errors = {e.plugin: e for e in gym4real.plugin_errors()}
    assert sorted(errors) == ["elevator", "half"]
    assert all(e.phase == "conflict" and "half-envs" in str(e) for e in errors.values())


def test_an_id_registered_twice_by_one_plugin_registers_nothing(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str]
) -> None:
    dist = ("twice-envs", "1.0", {"twice": "g4r_fake_twice"})
    reg = fake_plugins(dist, modules={"g4r_fake_twice": plugin_source(["gym4real/twice-v0", "gym4real/twice-v0"])})
    assert "gym4real/twice-v0" not in reg.envs
    [err] = gym4real.plugin_errors()
    assert err.plugin == "twice" and "`gym4real/twice-v0`" in err.error


def test_a_plugin_whose_later_hook_fails_keeps_none_of_its_records(
    fake_plugins: FakePlugins, plugin_source: Callable[..., str]
) -> None:
    body = "@hookimpl\ndef gym4real_register_baselines():\n    raise RuntimeError('no baselines today')\n"
    dist = ("partial-envs", "1.0", {"partial": "g4r_fake_partial"})
    reg = fake_plugins(dist, modules={"g4r_fake_partial": plugin_source(["gym4real/partial-v0"], body=body)})
    assert "gym4real/partial-v0" not in reg.envs
    assert "partial" not in reg.owners.values()
    [err] = gym4real.plugin_errors()
    assert err.phase == "gym4real_register_baselines" and "no baselines today" in err.error
