from __future__ import annotations

import gc
import importlib.util
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

import gym4real
from gym4real.core.datasets import resolve
from gym4real.core.errors import DataFileError
from gym4real.wds import WDSEnv
from gym4real.wds import engine as en
from gym4real.wds.network import parse_controls

ANYTOWN = resolve("wds/anytown")


def write_variant(tmp_path: Path, old: str, new: str, name: str = "variant.inp") -> Path:
    text = ANYTOWN.read_text()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


@pytest.fixture(autouse=True)
def private_tempdir(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """Give each test its own temp folder, so files of tests running in parallel never count."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path_factory.mktemp("tempdir")))


def leftover_tmp() -> set[str]:
    return {p.name for p in Path(tempfile.gettempdir()).glob("gym4real-wds-*")}


def test_codes_match_the_toolkit() -> None:
    tk = pytest.importorskip("epanet.toolkit")
    for name in [
        "NODECOUNT",
        "LINKCOUNT",
        "CONTROLCOUNT",
        "RULECOUNT",
        "JUNCTION",
        "TANK",
        "PUMP",
        "ELEVATION",
        "DEMAND",
        "HEAD",
        "PRESSURE",
        "TANKLEVEL",
        "TANKDIAM",
        "MINVOLUME",
        "MINLEVEL",
        "MAXLEVEL",
        "TANKVOLUME",
        "MAXVOLUME",
        "DEMANDFLOW",
        "FULLDEMAND",
        "INITSTATUS",
        "FLOW",
        "STATUS",
        "SETTING",
        "LOWLEVEL",
        "HILEVEL",
        "DURATION",
        "HYDSTEP",
        "PATTERNSTEP",
        "PATTERNSTART",
        "REPORTSTEP",
        "PDA",
        "CONST_HP",
        "CMH",
    ]:
        if hasattr(en, name):
            assert getattr(en, name) == getattr(tk, name), name
    assert en.FLOW_TO_M3H[tk.CMH] == 1.0


def test_engine_info_is_reported() -> None:
    info = en.engine_info()
    assert info["engine"] in en.ENGINES
    assert info["epanet_version"] == "2.3.05"
    assert info["engine_version"] == en.PINS[info["engine"]]
    extra = gym4real.env_info("gym4real/wds-v0").extra
    assert extra["engine"] == info["engine"] and extra["epanet_version"] == "2.3.05"
    e = WDSEnv()
    _, reset_info = e.reset(seed=0)
    assert reset_info["engine"] == info["engine_label"]
    e.close()


@pytest.mark.skipif(importlib.util.find_spec("epyt") is None, reason="epyt (the fallback engine) is not installed")
@pytest.mark.parametrize(
    ("fidelity", "pump_control"), [("corrected", "agent"), ("upstream", "agent"), ("corrected", "controls")]
)
def test_fallback_engine_gives_identical_results(fidelity: str, pump_control: str) -> None:
    runs = []
    for engine in ("owa-epanet", "epyt"):
        e = WDSEnv(engine=engine, fidelity=fidelity, pump_control=pump_control)
        assert e.engine_label.startswith(engine)
        obs, _ = e.reset(seed=4, options={"profile_index": 11})
        trace = [obs]
        for k in range(300):
            obs, r, _, truncated, _ = e.step((k // 5) % 4)
            trace += [obs, r]
            if truncated:
                break
        runs.append(trace)
        e.close()
    for x, y in zip(*runs, strict=True):
        np.testing.assert_array_equal(x, y)


def test_malformed_network_gives_epanets_message(tmp_path: Path) -> None:
    bad = write_variant(tmp_path, " J3              \t15.2400 ", " J3              \tabc ")
    with pytest.raises(DataFileError, match=r"Error 200.*Error 202: illegal numeric value abc"):
        WDSEnv(network=str(bad))
    with pytest.raises(DataFileError, match="does not exist"):
        WDSEnv(network=str(tmp_path / "missing.inp"))
    no_pumps = write_variant(tmp_path, " P79             \tR40", ";P79             \tR40", "one_pump.inp")
    no_pumps.write_text(no_pumps.read_text().replace(" P78             \tR40", ";P78             \tR40"))
    with pytest.raises(DataFileError, match="0 pump"):
        WDSEnv(network=str(no_pumps))
    assert not leftover_tmp()


def test_other_networks_are_read_from_the_file(tmp_path: Path) -> None:
    three = write_variant(
        tmp_path,
        " P79             \tR40             \tJ20             \tHEAD H1\t        SPEED 1;",
        " P79             \tR40             \tJ20             \tHEAD H1\t        SPEED 1;\n"
        " P80             \tR40             \tJ20             \tHEAD H1\t        SPEED 1;",
    )
    e = WDSEnv(network=str(three))
    try:
        assert e.network.pump_ids == ("P78", "P79", "P80")
        assert e.action_space.n == 8
        e.reset(options={"profile_index": 0})
        _, _, _, _, info = e.step(0b001)
        assert info["pumps"] == {"P78": 0, "P79": 0, "P80": 1}
        assert info["volumes"]["pumped"] > 0
    finally:
        e.close()


def test_controls_are_parsed_commented_or_not() -> None:
    text = ANYTOWN.read_text()
    assert parse_controls(text) == [
        ("P78", "OPEN", "T41", "BELOW", 5.0),
        ("P78", "CLOSED", "T41", "ABOVE", 8.0),
        ("P79", "OPEN", "T42", "BELOW", 5.0),
        ("P79", "CLOSED", "T42", "ABOVE", 8.0),
    ]
    active = text.replace(";LINK P78  OPEN    IF NODE T41                BELOW  5", "LINK P78 OPEN IF NODE T41 BELOW 4")
    assert parse_controls(active)[0] == ("P78", "OPEN", "T41", "BELOW", 4.0)


def test_active_controls_are_read_but_never_applied(tmp_path: Path) -> None:
    text = ANYTOWN.read_text()
    for line in text.splitlines():
        if line.startswith(";LINK"):
            text = text.replace(line, line[1:].replace("BELOW  5", "BELOW  4").replace("ABOVE  8", "ABOVE  9"))
    path = tmp_path / "controlled.inp"
    path.write_text(text)
    e = WDSEnv(network=str(path))
    try:
        assert e.disabled_controls == 4
        assert [(r.pump, r.tank, r.low, r.high) for r in e.pump_rules] == [
            ("P78", "T41", 4.0, 9.0),
            ("P79", "T42", 4.0, 9.0),
        ]
        assert e.pump_rules_source == "network [CONTROLS]"
        e.reset(options={"profile_index": 0})
        for _ in range(24):  # tanks drain below 4 m: EPANET would open the pumps
            _, _, _, _, info = e.step(0)
            assert info["volumes"]["pumped"] == 0.0
        assert min(info["tanks"].values()) < 4.0
    finally:
        e.close()


def test_rules_fall_back_to_the_config(tmp_path: Path) -> None:
    path = tmp_path / "no_controls.inp"
    path.write_text("\n".join(ln for ln in ANYTOWN.read_text().splitlines() if not ln.startswith(";LINK")))
    e = WDSEnv(network=str(path), default_rule=[{"pump": "P78", "tank": "T42", "low": 3.0, "high": 6.0}])
    try:
        assert e.pump_rules_source == "config `default_rule`"
        assert [(r.pump, r.tank, r.low, r.high) for r in e.pump_rules] == [("P78", "T42", 3.0, 6.0)]
    finally:
        e.close()


def test_no_files_left_behind(tmp_path: Path) -> None:
    before_cwd = set(os.listdir("."))
    e = WDSEnv()
    e.reset(seed=0)
    for _ in range(10):
        e.step(3)
    assert not leftover_tmp()  # the report file's folder is gone as soon as EPANET has opened it
    e.close()
    assert set(os.listdir(".")) == before_cwd
    assert not leftover_tmp()
    assert sorted(p.name for p in ANYTOWN.parent.iterdir()) == ["anytown_map.inp"]


def test_no_leak_across_resets_and_envs() -> None:
    e = WDSEnv()
    for _ in range(20):  # warm up allocator and buffers
        e.reset()
    fds, rss = open_fds(), rss_kib()
    for k in range(1000):
        e.reset(options={"profile_index": k})
    e.step(3)
    assert open_fds() == fds
    assert rss_kib() - rss < 4096  # KiB
    e.close()
    with pytest.raises(RuntimeError, match="closed"):
        e.reset()
    e.close()  # idempotent
    fds = open_fds()
    for _ in range(30):
        WDSEnv().reset(seed=0)  # dropped without close(): released by the garbage collector
    gc.collect()
    assert open_fds() == fds
    assert not leftover_tmp()


def test_auto_engine_falls_back_and_explains(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing() -> None:
        raise ModuleNotFoundError("No module named 'epanet'", name="epanet")

    monkeypatch.setattr(en, "_BACKENDS", {})
    monkeypatch.setattr(en, "_OwaBackend", missing)
    if importlib.util.find_spec("epyt") is not None:
        assert en.backend("auto").name == "epyt"
        monkeypatch.setattr(en, "_BACKENDS", {})
    monkeypatch.setattr(en, "_CtypesBackend", missing)
    with pytest.raises(en.ConfigError, match=r"pip install owa-epanet==2\.3\.5"):
        en.backend("auto")
    assert en.engine_info()["engine"] is None


@pytest.mark.parametrize(("interval", "hyd"), [(1800, 300), (7200, 3600), (3600, 900)])
def test_other_decision_intervals(interval: int, hyd: int) -> None:
    e = WDSEnv(decision_interval=interval, hydraulic_step=hyd, duration=86_400)
    try:
        assert e.effective_hydraulic_step == min(hyd, interval, 3600)
        e.reset(options={"profile_index": 4})
        n, truncated = 0, False
        while not truncated:
            _, _, _, truncated, info = e.step(n % 4)
            n += 1
            assert info["time"] == n * interval
        assert n == 86_400 // interval
    finally:
        e.close()


def test_only_the_engines_bare_warning_is_ignored() -> None:
    """owa-epanet's ``Warning("WARNING")``, attributed to the engine module that calls ``runH``, is silenced by
    the filter an engine sets when it opens; the same warning from anywhere else, and any other warning from
    the engine module, still reach the user."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.resetwarnings()  # no filter at all: what a user's fresh filters would be
        WDSEnv().close()  # opening an engine sets the filter
        warnings.warn_explicit("WARNING", Warning, en.__file__, 1, module=en.__name__)
        warnings.warn_explicit("WARNING", Warning, "user.py", 1, module="user")
        warnings.warn_explicit("pressure low", UserWarning, en.__file__, 2, module=en.__name__)
    assert [(str(w.message), w.filename) for w in caught] == [("WARNING", "user.py"), ("pressure low", en.__file__)]
