"""Mistakes reported before anything runs, and in one line: policy names, seeds, missing domains and libraries.

Also the progress a long command prints: a line per tenth in a log (no bar redrawn into it), and a planner's
notice before it plans.
"""

from __future__ import annotations

import io
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from gym4real.cli import main
from gym4real.core.errors import ConfigError, EnvUnavailableError, MissingDependencyError


def test_a_mistyped_policy_is_refused_before_any_episode_with_the_nearest_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from gym4real.bench import benchmark as bench_mod

    episodes: list[Any] = []
    run_episode = bench_mod.run_episode
    monkeypatch.setattr(bench_mod, "run_episode", lambda *a, **k: episodes.append(a) or run_episode(*a, **k))
    out = tmp_path / "out"
    assert main(["bench", "gym4real/dam-v0", "--policies", "ead,maxx", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert episodes == [] and not out.exists()  # ead's 13 episodes were not run first
    assert err.startswith("gym4real: error: unknown policy `maxx` for `gym4real/dam-v0`. Did you mean `max`")
    assert "\n" not in err and "Traceback" not in err
    assert main(["bench", "gym4real/dam-v0", "--policies", "ead,pp:runs/model.zip", "--out", str(out)]) == 2
    assert "Did you mean `ppo`?" in capsys.readouterr().err  # a mistyped kind of model file
    assert episodes == []


def test_seeds_0_names_the_one_seed_form(capsys: pytest.CaptureFixture[str]) -> None:
    from gym4real.bench.seeds import check_seed_count, parse_seeds

    with pytest.raises(ConfigError, match="for the one seed 0 write `--seeds 0,`"):
        parse_seeds("0")
    assert parse_seeds("0,") == [0]
    with pytest.raises(ConfigError, match="for the one seed 0 write `0,`"):
        check_seed_count(0)
    argv = ["evaluate", "gym4real.core.policies:random_policy", "--envs", "gym4real/elevator-v0", "--seeds", "0"]
    assert main(argv) == 2
    assert "`--seeds 0,`" in capsys.readouterr().err


@pytest.fixture
def without_wds(monkeypatch: pytest.MonkeyPatch) -> Any:
    """The registry and Gymnasium's registry as in a process where gym4real-wds is not installed."""
    import gymnasium as gym

    from gym4real.core import registry as reg_mod

    installed = list(reg_mod._entry_points())
    monkeypatch.setattr(reg_mod, "_entry_points", lambda: [ep for ep in installed if ep.name != "wds"])
    monkeypatch.delenv("GYM4REAL_STRICT_PLUGINS", raising=False)
    monkeypatch.delitem(gym.registry, "gym4real/wds-v0")  # as in a fresh process, where it was never registered
    reg_mod.reload()
    reg_mod.register_envs()
    yield gym
    monkeypatch.undo()
    reg_mod.reload()
    reg_mod.register_envs()


def test_gymnasium_make_of_a_domain_not_installed_names_its_distribution_and_pip_install(without_wds: Any) -> None:
    import gym4real

    assert "gym4real/wds-v0" not in gym4real.list_envs()
    with pytest.raises(EnvUnavailableError) as raised:
        without_wds.make("gym4real/wds-v0")  # Gymnasium's own make, after `import gym4real`: not NameNotFound
    message = str(raised.value)
    assert "`gym4real-wds`, which is not installed" in message and "pip install" in message
    assert without_wds.make("gym4real/elevator-v0").unwrapped.spec.id == "gym4real/elevator-v0"


def test_gymnasium_make_of_a_disabled_domain_names_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    from gym4real.core import registry as reg_mod

    monkeypatch.setenv("GYM4REAL_DISABLE_PLUGINS", "wds")
    monkeypatch.delenv("GYM4REAL_STRICT_PLUGINS", raising=False)
    try:
        reg_mod.reload()
        with pytest.raises(EnvUnavailableError, match="GYM4REAL_DISABLE_PLUGINS disables"):
            reg_mod.env_spec("gym4real/wds-v0")
    finally:
        monkeypatch.undo()
        reg_mod.reload()


def _python(code: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, check=False, cwd=tmp_path
    )


#: Hides an installed library from a fresh interpreter (``import`` then raises ModuleNotFoundError).
HIDE = "import sys; sys.modules[{module!r}] = None\n"


@pytest.mark.parametrize(
    ("module", "requirement"), [("mujoco", '"mujoco<5,>=4"'), ("cv2", '"opencv-python-headless>=4.9"')]
)
def test_a_missing_robofeeder_library_is_one_line_naming_its_pip_install(
    module: str, requirement: str, tmp_path: Path
) -> None:
    command = ["bench", "gym4real/robofeeder-picking-v0", "--episodes", "1", "--out", str(tmp_path / "out")]
    done = _python(
        HIDE.format(module=module) + f"from gym4real.cli import main\nraise SystemExit(main({command!r}))", tmp_path
    )
    assert done.returncode == 2, done.stderr
    err = done.stderr.strip()
    assert err.startswith("gym4real: error: gym4real-robofeeder needs") and "\n" not in err, err
    assert f"pip install {requirement}" in err and "MUJOCO_GL" not in err
    made = _python(
        HIDE.format(module=module)
        + "import gymnasium as gym, gym4real\ngym.make('gym4real/robofeeder-picking-v0').reset(seed=0)",
        tmp_path,
    )
    last = made.stderr.strip().splitlines()[-1]
    assert last.startswith("gym4real.core.errors.MissingDependencyError: gym4real-robofeeder needs"), made.stderr
    assert f"pip install {requirement}" in last
    assert "During handling" not in made.stderr and "MUJOCO_GL" not in made.stderr  # one error, not a chain


def test_mujoco_gl_advice_only_for_a_gl_failure_of_a_backend_the_user_chose(monkeypatch: pytest.MonkeyPatch) -> None:
    from gym4real.robofeeder import _gl

    missing = ModuleNotFoundError("No module named 'mujoco'", name="mujoco")
    assert isinstance(_gl.import_error(missing), MissingDependencyError)
    gl_failure = ImportError("Cannot initialize a EGL device display")
    monkeypatch.setitem(_gl.CHOICE, "reason", "MUJOCO_GL set by the user")
    assert "MUJOCO_GL=" in str(_gl.import_error(gl_failure))
    assert "MUJOCO_GL" not in str(_gl.import_error(ImportError("libmujoco.so.4: cannot open shared object")))
    monkeypatch.setitem(_gl.CHOICE, "reason", "EGL device initialised")  # chosen by gym4real, not the user
    message = str(_gl.import_error(gl_failure))
    assert "MUJOCO_GL" not in message and 'pip install --force-reinstall "mujoco<5,>=4"' in message


def test_list_marks_the_ids_of_a_distribution_whose_libraries_are_missing(
    fake_plugins: Callable[..., Any], plugin_source: Callable[..., str], capsys: pytest.CaptureFixture[str]
) -> None:
    needy = ("needy-envs", "1.0", {"needy": "g4r_fake_needy"}, ["g4r-no-such-lib>=2", "numpy>=1", "pip; extra == 'x'"])
    fake_plugins(needy, modules={"g4r_fake_needy": plugin_source(["gym4real/needy-v0"])})
    assert main(["list"]) == 0
    rows = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert rows["gym4real/needy-v0"].split(None, 1)[1] == (
        'unavailable: needy-envs needs g4r-no-such-lib>=2, not installed here: `pip install "g4r-no-such-lib>=2"`'
    )
    assert "unavailable" not in rows["gym4real/elevator-v0"]  # its requirements are all installed


def test_progress_in_a_log_is_a_line_per_tenth_and_relays_a_planners_notice(tmp_path: Path) -> None:
    from gym4real.bench.progress import ProgressDisplay
    from gym4real.bench.upper_reference import PlanCache

    stream = io.StringIO()  # not a terminal
    shown = ProgressDisplay("gym4real/dam-v0", 130, "episodes", stream=stream)
    cache = PlanCache(tmp_path / "plans.json", "dam-dp-1 on gym4real/dam-v0")
    assert cache.get("a") is None and cache.get("b") is None  # a cold cache: announced once
    for done in range(1, 131):
        shown.advance()
        assert shown.done == done
    shown.close()
    PlanCache(tmp_path / "other.json").get("a")  # no display open: nothing printed
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue()
    assert lines[0].startswith("planning (dam-dp-1 on gym4real/dam-v0): ") and "(cached afterwards in " in lines[0]
    first_and_tenths = [f"gym4real/dam-v0: {n}/130 episodes" for n in [1, *range(13, 131, 13)]]
    assert [line.split(" (")[0] for line in lines[1:]] == first_and_tenths  # the first says it has started


def test_bench_in_a_log_prints_a_line_per_tenth_not_a_bar(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["bench", "gym4real/elevator-v0", "--episodes", "20", "--policies", "random", "--out", str(tmp_path)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "\r" not in err
    assert err.splitlines() == [
        line for line in err.splitlines() if line.startswith("gym4real/elevator-v0: ") and "episodes" in line
    ]
    assert len(err.splitlines()) == 11  # the first episode, then each tenth
