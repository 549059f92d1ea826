from __future__ import annotations

import re
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.bench.benchmark import benchmark
from gym4real.bench.policies import make_policy
from gym4real.core.datasets import resolve
from gym4real.rl.presets import load_preset
from gym4real.wds import WDSEnv, evaluation

ENV_ID = "gym4real/wds-v0"


@pytest.mark.parametrize(("name", "action"), [("p78", 2), ("p79", 1)])
def test_single_pump_baselines(name: str, action: int) -> None:
    env = gym.make(ENV_ID)
    policy = make_policy(ENV_ID, name, env)
    obs, _ = env.reset(seed=0)
    assert policy(obs) == action
    env.close()


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
@pytest.mark.parametrize("profile", [0, 3, 250])
def test_default_rule_switches_at_the_tank_thresholds(fidelity: str, profile: int) -> None:
    env = WDSEnv(fidelity=fidelity)
    policy = make_policy(ENV_ID, "default", env)
    policy.reset(0)
    obs, _ = env.reset(options={"profile_index": profile})
    status = {"P78": 1, "P79": 1}  # the file's initial status
    switches = 0
    while True:
        action = policy(obs)
        new = {"P78": action >> 1 & 1, "P79": action & 1}
        for pump, tank in (("P78", 0), ("P79", 1)):
            level = obs[tank]
            if level < 5.0:
                assert new[pump] == 1
            elif level > 8.0:
                assert new[pump] == 0
            else:
                assert new[pump] == status[pump]
            switches += new[pump] != status[pump]
        status = new
        obs, _, _, truncated, info = env.step(action)
        assert info["pumps"] == new
        if truncated:
            break
    assert switches > 0
    env.close()


def test_default_rule_first_action_upstream_is_both_on() -> None:
    env = WDSEnv(fidelity="upstream")
    policy = make_policy(ENV_ID, "default", env)
    obs, _ = env.reset(seed=0)
    assert policy(obs) == 3  # zeroed reset observation: both tanks "below 5 m"
    env.close()


def test_protocol_is_the_first_20_test_profiles() -> None:
    episodes = evaluation.test_episodes({"preset": "test"})
    assert [e["options"]["profile_index"] for e in episodes] == list(range(20))
    assert len({e["seed"] for e in episodes}) == 20


def test_benchmark_runs_and_ranks_policies(tmp_path) -> None:
    """The paper's baselines rank Default > Random > P78 = P79 (the two pumps are identical and in parallel)."""
    result = benchmark(ENV_ID, policies=["random", "p78", "p79", "default"], out=tmp_path)
    returns = {k: np.array(v) for k, v in result.returns.items()}
    for rets in returns.values():
        assert len(rets) == 20
        assert all(-2 * 168 <= r <= 168 for r in rets)
    np.testing.assert_allclose(returns["p78"], returns["p79"], rtol=1e-6)  # up to the solver's tolerance
    assert (returns["default"] > np.maximum(returns["random"], returns["p78"])).all()  # every episode
    assert returns["random"].mean() > returns["p78"].mean()
    comps = result.components["default"]
    np.testing.assert_allclose(np.add(comps["dsr"], comps["overflow"]), result.returns["default"], rtol=1e-9)
    assert (tmp_path / "summary.csv").exists()


def toolkit_week(folder: Path, pattern: np.ndarray, hydraulic_step: int) -> dict[int, tuple[np.ndarray, list[int]]]:
    """One week of Anytown run by owa-epanet's toolkit alone, EPANET executing the file's [CONTROLS].

    The network file is edited as a user would: its four control lines uncommented and PAT1 (the pattern
    of every junction) replaced by the week's multipliers. Returns, at every hydraulic time solved, the
    tank levels (T41, T42) and the pump settings (P78, P79; 1 open, 0 closed) EPANET applied.
    """
    tk = pytest.importorskip("epanet.toolkit")
    text = resolve("wds/anytown").read_text()
    text = re.sub(r"^;(LINK P7[89] .*)$", r"\1", text, flags=re.MULTILINE)
    lines = [" PAT1 " + " ".join(repr(float(v)) for v in pattern[i : i + 6]) for i in range(0, len(pattern), 6)]
    text = re.sub(r"^ PAT1 .*$", "\n".join(lines), text, flags=re.MULTILINE)  # EPANET reads 1024 chars a line
    inp = folder / "anytown_controls.inp"
    inp.write_text(text)
    ph = tk.createproject()
    tk.open(ph, str(inp), str(folder / "report.rpt"), "")
    try:
        assert tk.getcount(ph, tk.CONTROLCOUNT) == 4
        for code, value in ((tk.DURATION, 604_800), (tk.PATTERNSTEP, 3600), (tk.REPORTSTEP, 3600)):
            tk.settimeparam(ph, code, value)
        tk.settimeparam(ph, tk.HYDSTEP, hydraulic_step)
        tanks = [tk.getnodeindex(ph, t) for t in ("T41", "T42")]
        pumps = [tk.getlinkindex(ph, p) for p in ("P78", "P79")]
        tk.openH(ph)
        tk.initH(ph, 0)
        out = {}
        while True:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t = tk.runH(ph)
            levels = np.array([tk.getnodevalue(ph, k, tk.PRESSURE) for k in tanks])
            out[t] = (levels, [int(tk.getlinkvalue(ph, k, tk.SETTING) > 0) for k in pumps])
            if tk.nextH(ph) == 0:
                return out
    finally:
        tk.closeH(ph)
        tk.close(ph)
        tk.deleteproject(ph)


def hourly(env: WDSEnv, profile: int, policy=None) -> tuple[np.ndarray, list[list[int]], float]:
    """Tank levels at every hour, the pumps of every interval and the week's mean DSR."""
    obs, info = env.reset(options={"profile_index": profile})
    levels, pumps, dsr = [list(info["tanks"].values())], [], []
    if policy is not None:
        policy.reset(0)
    while True:
        obs, _, _, truncated, info = env.step(policy(obs) if policy is not None else 0)
        levels.append(list(info["tanks"].values()))
        pumps.append(list(info["pumps"].values()))
        dsr.append(info["dsr"])
        if truncated:
            return np.array(levels), pumps, float(np.mean(dsr))


@pytest.mark.parametrize(
    ("profile", "exact_tank_events"),
    [(0, False), (5, False), (4, None)],  # tanks reach their limits in 0 and 5, not in 4
)
def test_controls_mode_is_epanet_executing_the_network_controls(
    tmp_path: Path, profile: int, exact_tank_events: bool | None
) -> None:
    """`pump_control="controls"` is an independent owa-epanet run of the .inp with its controls active, bit for bit.

    The corrected mode's exact tank events (a tank EPANET would empty in under half a second is emptied)
    change the run only where a tank reaches a limit; without them the run is EPANET's own everywhere.
    """
    env = WDSEnv(preset="test", pump_control="controls", fixes={"exact_tank_events": exact_tank_events})
    try:
        assert env.added_controls == 4 and env.disabled_controls == 0
        levels, pumps, _ = hourly(env, profile)
        reference = toolkit_week(tmp_path, env._pattern, env.effective_hydraulic_step)
    finally:
        env.close()
    np.testing.assert_array_equal(levels, [reference[3600 * h][0] for h in range(169)])
    assert pumps == [reference[3600 * h][1] for h in range(168)]
    assert len({tuple(p) for p in pumps}) > 2  # the controls switched the pumps


@pytest.mark.parametrize("profile", [0, 1, 5])
def test_default_rule_approximates_the_network_controls(tmp_path: Path, profile: int) -> None:
    """The hourly rule follows EPANET's controls exactly until their first switch, then at the next decision."""
    env, exact = WDSEnv(preset="test"), WDSEnv(preset="test", pump_control="controls")
    try:
        levels, pumps, dsr = hourly(env, profile, make_policy(ENV_ID, "default", env))
        reference = toolkit_week(tmp_path, env._pattern, env.effective_hydraulic_step)
        _, _, exact_dsr = hourly(exact, profile)
    finally:
        env.close()
        exact.close()
    times = sorted(reference)
    first = next(t for t in times if reference[t][1] != [1, 1])  # EPANET's first switch (both pumps start on)
    decision = -(-first // 3600)  # the rule sees it at the first decision at or after it
    assert all(p == [1, 1] for p in pumps[:decision])
    switched = [i for i, s in enumerate(reference[first][1]) if s == 0]
    assert all(pumps[decision][i] == 0 for i in switched)
    # the same hydraulics until then (the env re-solves at each decision: the solver's tolerance)
    hours = [t // 3600 for t in times if t % 3600 == 0 and t <= first]
    np.testing.assert_allclose(levels[hours], [reference[3600 * h][0] for h in hours], rtol=0, atol=1e-5)
    assert dsr == pytest.approx(exact_dsr, rel=0.02)


@pytest.mark.parametrize("preset", ["paper", "smoke"])
def test_dqn_presets(preset: str) -> None:
    hp = load_preset(ENV_ID, "dqn", preset)
    assert hp["algo"] == "dqn" and hp["policy_kwargs"] == {"net_arch": [64, 64]}
    h = hp["hyperparams"]
    assert (h["gamma"], h["learning_rate"], h["batch_size"], h["train_freq"]) == (0.99, 1e-3, 32, 4)
    assert (h["exploration_fraction"], h["exploration_final_eps"]) == (0.1, 0.05)
    if preset == "paper":
        assert hp["n_envs"] == 8 and h["buffer_size"] == 1_000_000
    else:
        assert hp["total_timesteps"] <= 4000 and hp["n_envs"] <= 2
    gym.make(ENV_ID, **hp["env_kwargs"]).close()
    gym.make(ENV_ID, **hp["eval_env_kwargs"]).close()


def test_dqn_paper_budget_is_the_references_episode_stopping_rule() -> None:
    """The reference stops with SB3's StopTrainingOnMaxEpisodes(max_episodes=100) ("# Episodes 100") on 8 envs."""
    pytest.importorskip("stable_baselines3")
    from types import SimpleNamespace

    from stable_baselines3.common.callbacks import StopTrainingOnMaxEpisodes

    hp = load_preset(ENV_ID, "dqn", "paper")
    env = gym.make(ENV_ID, **hp["env_kwargs"])
    length = 0
    env.reset(seed=0)
    truncated = False
    while not truncated:  # every training episode is truncated after a week of hourly decisions
        *_, truncated, _ = env.step(env.action_space.sample())
        length += 1
    env.close()
    stop = StopTrainingOnMaxEpisodes(max_episodes=100)
    stop.init_callback(SimpleNamespace(get_env=lambda: SimpleNamespace(num_envs=hp["n_envs"])))  # type: ignore[arg-type]
    calls = 0
    while True:  # SB3 calls back once per step of the vector env: the envs end their episodes together
        calls += 1
        stop.locals = {"dones": np.full(hp["n_envs"], calls % length == 0)}
        if not stop._on_step():
            break
    assert stop.n_episodes == 100 * hp["n_envs"]
    assert hp["total_timesteps"] == calls * hp["n_envs"]
