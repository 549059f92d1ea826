"""Broken agents given to `gym4real evaluate` (and `bench`): one line naming the agent, the env and where, no
traceback (`--debug` shows it), exit status 2, and no result file. Bad multi-objective weights are refused.
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from gym4real.bench.agent_errors import AgentError
from gym4real.cli import main
from gym4real.core.errors import ConfigError
from gym4real.core.mo_spec import mo_spec

AGENTS = """
import time

import numpy as np


def nan_actions(env):
    return lambda obs: np.full(env.action_space.shape, np.nan)


def wrong_shape(env):
    return lambda obs: np.zeros(7)


def wrong_dtype(env):
    return lambda obs: np.array(["release"])


def out_of_space(env):
    return lambda obs: env.action_space.n


def no_action(env):
    return lambda obs: None


def float_for_discrete(env):
    return lambda obs: 1.5


def raising_factory(env):
    raise RuntimeError("no GPU here")


def exiting_factory(env):
    raise SystemExit(3)


def needs_a_config(env, config):
    return lambda obs: 0


def non_callable(env):
    return 42


def raising_policy(env):
    def act(obs):
        return 1 / 0

    return act


class BadReset:
    def __init__(self, env):
        self.space = env.action_space

    def reset(self, seed=None):
        raise ValueError("cannot reset")

    def __call__(self, obs):
        return self.space.sample()


def hangs(env):
    def act(obs):
        while True:
            time.sleep(0.01)

    return act


def refuses_weights(env, weights, seed=None):
    raise ValueError(f"weights {weights} are not the ones I was trained for")


NOT_A_POLICY = 3
"""


@pytest.fixture
def agents(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A working folder holding ``badagents.py`` (imported from it, as a user's module); yields the output folder."""
    (tmp_path / "badagents.py").write_text(textwrap.dedent(AGENTS))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path / "out"


DAM = "gym4real/dam-v0"
ELEVATOR = "gym4real/elevator-v0"


@pytest.mark.parametrize(
    ("agent", "env_id", "says"),
    [
        ("nan_actions", DAM, "test episode 0 (reset seed 0), step 0: action array([nan]) is not in the action space"),
        ("wrong_shape", DAM, "step 0: action array([0., 0., 0., 0., 0., 0., 0.]) is not in the action space"),
        ("wrong_dtype", DAM, "step 0: action array(['release'], dtype='<U7') is not in the action space"),
        ("out_of_space", ELEVATOR, "step 0: action np.int64(3) is not in the action space Discrete(3): 3 is outside"),
        ("no_action", DAM, "step 0: action None is not in the action space"),
        ("float_for_discrete", ELEVATOR, "step 0: action 1.5 is not in the action space Discrete(3): it is not an int"),
        ("raising_factory", DAM, "(seed 0): its factory `badagents:raising_factory` raised RuntimeError: no GPU here"),
        ("exiting_factory", DAM, "its factory `badagents:exiting_factory` raised SystemExit: 3"),
        ("needs_a_config", DAM, "raised TypeError: needs_a_config() missing 1 required positional argument"),
        ("non_callable", DAM, "(seed 0): `badagents:non_callable` returned int, not a policy"),
        ("NOT_A_POLICY", DAM, "(seed 0): `badagents:NOT_A_POLICY` is a int, not a policy or a factory"),
        ("raising_policy", DAM, "step 0: its policy raised ZeroDivisionError: division by zero; fix the agent"),
        ("BadReset", DAM, "step reset: its reset(seed) raised ValueError: cannot reset"),
    ],
)
def test_a_bad_agent_is_one_line_naming_agent_env_and_where_with_no_result_file(
    agents: Path, capsys: pytest.CaptureFixture[str], agent: str, env_id: str, says: str
) -> None:
    argv = ["evaluate", f"bad=badagents:{agent}", "--envs", env_id, "--out", str(agents), "--no-headroom"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"gym4real: error: agent `bad=badagents:{agent}` on `{env_id}` (seed 0)"), err
    assert says in err, err
    assert "\n" not in err and "Traceback" not in err
    assert "fix" in err  # every message says what to do
    assert not agents.exists()  # no score.json, CSV or figure of a failed evaluation


def test_an_action_error_names_the_space_and_the_info_command(agents: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["evaluate", "bad=badagents:nan_actions", "--envs", DAM, "--out", str(agents), "--no-headroom"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "fix: return an action of the action space Box(" in err and f"`gym4real info {DAM}`" in err


def test_debug_raises_the_agents_own_exception_with_its_traceback(agents: Path) -> None:
    argv = ["evaluate", "bad=badagents:raising_factory", "--envs", DAM, "--out", str(agents), "--no-headroom"]
    with pytest.raises(AgentError) as raised:
        main([*argv, "--debug"])
    cause = raised.value.__cause__.__cause__  # AgentError <- the factory's PolicyError <- the agent's own
    assert isinstance(cause, RuntimeError) and str(cause) == "no GPU here"
    assert cause.__traceback__ is not None
    assert not agents.exists()


def test_an_agent_that_hangs_is_stopped_at_the_episode_timeout(
    agents: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "slow=badagents:hangs", "--envs", DAM, "--out", str(agents), "--no-headroom"]
    assert main([*argv, "--episode-timeout", "0.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(
        f"gym4real: error: agent `slow=badagents:hangs` on `{DAM}` (seed 0), test episode 0 (reset seed 0), step 0: "
        "did not finish within 0.5 s (--episode-timeout)"
    ), err
    assert not agents.exists()
    assert main([*argv, "--episode-timeout", "0"]) == 2
    assert "must be a positive number of seconds, not 0.0" in capsys.readouterr().err


def test_a_factory_given_seeds_it_cannot_take_is_refused_before_its_first_episode(
    agents: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "bad=badagents:nan_actions", "--envs", DAM, "--seeds", "0,1", "--out", str(agents)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert (
        "agent `bad=badagents:nan_actions` on `gym4real/dam-v0` (seed 0): `badagents:nan_actions` takes no `seed`"
        in err
    )


def test_a_bad_policy_in_bench_names_it_and_the_episode(agents: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", DAM, "--policies", "badagents:raising_policy", "--out", str(agents), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(
        f"gym4real: error: policy `badagents:raising_policy` on `{DAM}`, episode 0 (reset seed 0), step 0: its policy "
        "raised ZeroDivisionError"
    ), err
    assert not agents.exists()


def test_a_weight_conditioned_factory_that_refuses_its_weights_is_named_with_them(
    agents: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--mo", "mo=badagents:refuses_weights", "--envs", "gym4real/dam-mo-v0", "--out", str(agents)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(
        "gym4real: error: agent `mo=badagents:refuses_weights` (seed 0, policy w=1,0) on `gym4real/dam-mo-v0`: its "
        "factory `mo` raised ValueError: weights (1.0, 0.0) are not the ones I was trained for when called as "
        "`factory(env, weights=(1.0, 0.0))`"
    ), err
    assert "Traceback" not in err and not agents.exists()


@pytest.mark.parametrize(
    ("weights", "says"),
    [
        ([np.nan, 1.0], "got [nan, 1.0]: shortage = nan"),
        ([1.0, -0.5], "got [1.0, -0.5]: flooding = -0.5"),
        ([0.0, 0.0], "all 0"),
        ([np.inf, 0.0], "shortage = inf"),
        ([1.0], "has 2 objectives ['shortage', 'flooding']"),
    ],
)
def test_multi_objective_weights_are_finite_non_negative_and_not_all_zero(weights: list[float], says: str) -> None:
    spec = mo_spec("gym4real/dam-mo-v0")
    components = ("deficit", "overflow", "starving", "wasted_water", "clipping")
    for use in (lambda: spec.reward_weights(weights, components), lambda: spec.component_weights(weights)):
        with pytest.raises(ConfigError) as raised:
            use()
        assert says in str(raised.value) and "one finite, non-negative weight each, not all 0" in str(raised.value)
    np.testing.assert_array_equal(spec.reward_weights([0.0, 2.0], components), [0.0, 2.0, 0.0, 0.0, 0.0])
