"""Every registered smoke training preset trains, saves, reloads and acts; wrong model files are refused."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd
import pytest

import gym4real
from gym4real.bench.policies import make_policy
from gym4real.core.errors import ConfigError, PolicyError
from gym4real.core.registry import registry
from gym4real.rl.presets import load_preset
from gym4real.rl.train import default_out, train

SMOKE = sorted((e, a) for (e, a, p) in registry().trainings if p == "smoke" and e in gym4real.list_envs())


# picking-v1's smoke run trains on camera images for about a minute: a slow test (the latest gymnasium's run)
SLOW_SMOKE = {("gym4real/robofeeder-picking-v1", "ppo")}


@pytest.mark.parametrize(
    ("env_id", "algo"),
    [pytest.param(e, a, marks=[pytest.mark.slow] if (e, a) in SLOW_SMOKE else []) for e, a in SMOKE],
    ids=[f"{e.split('/')[1]}-{a}" for e, a in SMOKE],
)
def test_smoke_training_saves_reloads_and_acts(env_id: str, algo: str, tmp_path: Path) -> None:
    if algo in ("ppo", "dqn"):
        pytest.importorskip("stable_baselines3")
    run = train(env_id, algo, "smoke", seed=0, out=tmp_path)
    assert run.model_path.exists() and run.model_path.stat().st_size > 0
    curve = pd.read_csv(run.curve_csv)
    assert len(curve) >= 1 and curve["mean_return"].notna().all()
    assert (tmp_path / "curve.png").stat().st_size > 0
    env = gym.make(env_id)
    policy = make_policy(env_id, run.policy, env)
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        action = policy(obs)
        assert env.action_space.contains(action) or env.action_space.contains(
            env.action_space.dtype.type(action) if hasattr(env.action_space, "dtype") else action
        )
        obs, *_ = env.step(action)
    env.close()


def test_model_of_another_env_is_refused(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    other = gym.make("CartPole-v1")
    PPO("MlpPolicy", other, n_steps=64, batch_size=32, device="cpu").save(tmp_path / "model.zip")
    env = gym.make("gym4real/elevator-v0")
    with pytest.raises(PolicyError, match="trained on observation space"):
        make_policy("gym4real/elevator-v0", f"ppo:{tmp_path / 'model.zip'}", env)


def test_qtable_of_another_env_is_refused(tmp_path: Path) -> None:
    import numpy as np

    from gym4real.rl.tabular import save_qtable

    save_qtable(tmp_path / "q.npz", np.zeros((10, 3)), "gym4real/other-v0", "qlearning", np.array([10]))
    env = gym.make("gym4real/elevator-v0")
    with pytest.raises(PolicyError, match="trained on `gym4real/other-v0`"):
        make_policy("gym4real/elevator-v0", f"qlearning:{tmp_path / 'q.npz'}", env)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(PolicyError, match="not a gym4real Q-table"):
        make_policy("gym4real/elevator-v0", f"qlearning:{tmp_path / 'junk.npz'}", env)


def test_unknown_preset_lists_the_registered_ones() -> None:
    with pytest.raises(gym4real.core.ConfigError, match="qlearning/paper"):
        train("gym4real/elevator-v0", "qlearning", "huge")


def test_box_actions_are_learnt_on_minus_one_one_and_mapped_back() -> None:
    pytest.importorskip("stable_baselines3")
    import numpy as np

    from gym4real.rl.sb3 import NormalizedPolicy, rescaled

    box = gym.spaces.Box(0.0, 491.61, (1,), np.float32)
    assert rescaled(box) and not rescaled(gym.spaces.Box(-1.0, 1.0, (3,))) and not rescaled(gym.spaces.Discrete(3))

    class Model:
        def __init__(self, action: float) -> None:
            self.action = np.array([action], dtype=np.float32)

        def predict(self, obs, deterministic):
            return self.action, None

    for raw, expected in ((-1.0, 0.0), (0.0, 245.805), (1.0, 491.61), (3.0, 491.61)):
        action = NormalizedPolicy(Model(raw), None, box)(np.zeros(4))
        assert box.contains(action) and action[0] == pytest.approx(expected, rel=1e-6)


def test_every_registered_preset_is_valid() -> None:
    for env_id, algo, preset in registry().trainings:
        hp = load_preset(env_id, algo, preset)
        assert hp["algo"] == algo and hp["eval_env_kwargs"] is not None


ELEVATOR_SMOKE = """
algo: qlearning
episodes: 4
alpha: 0.1
gamma: 1.0
epsilon: {start: 1.0, decay: 0.9, min: 0.05}
eval_every: 2
eval_episodes: 1
patience: 5
env_kwargs: {duration: 300}
"""


def test_a_users_yaml_file_is_a_preset(tmp_path: Path) -> None:
    path = tmp_path / "mine.yml"
    path.write_text(ELEVATOR_SMOKE)
    run = train("gym4real/elevator-v0", "qlearning", str(path), seed=1, out=tmp_path / "run")
    assert run.model_path.exists()
    assert load_preset("gym4real/elevator-v0", "qlearning", str(path))["eval_env_kwargs"] == {"duration": 300}
    assert default_out("gym4real/elevator-v0", "qlearning", str(path), 1).name == "qlearning-mine-seed1"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("episodes: 4", "episodes: 4\nepisode: 3"), "unknown field `episode`"),
        (("gamma: 1.0", "gamma: 1.5"), r"field `gamma`: Input should be less than or equal to 1"),
        (("algo: qlearning", "algo: sarsa"), "says algo `sarsa`"),
    ],
)
def test_a_bad_preset_file_names_the_file_and_the_field(tmp_path: Path, edit: tuple[str, str], message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(ELEVATOR_SMOKE.replace(*edit))
    with pytest.raises(ConfigError, match=message) as err:
        load_preset("gym4real/elevator-v0", "qlearning", str(path))
    assert str(path) in str(err.value)


def test_an_unknown_sb3_hyperparameter_is_named(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    path = tmp_path / "ppo.yaml"
    path.write_text("algo: ppo\ntotal_timesteps: 64\nhyperparams: {n_steps: 32, lr: 0.1}\n")
    with pytest.raises(ConfigError, match=r"unknown field `hyperparams.lr` for PPO; expected some of .*learning_rate"):
        train("gym4real/elevator-v0", "ppo", str(path), out=tmp_path / "run")


def _elevator_preset(tmp_path: Path, **edits: str) -> str:
    text = ELEVATOR_SMOKE
    for key, value in edits.items():
        text = "\n".join(f"{key}: {value}" if line.startswith(f"{key}:") else line for line in text.splitlines())
        if f"\n{key}:" not in "\n" + text:
            text += f"\n{key}: {value}"
    path = tmp_path / "preset.yaml"
    path.write_text(text + "\n")
    return str(path)


def test_tabular_learning_curve_advances_in_episodes(tmp_path: Path) -> None:
    from gym4real.rl.curves import LearningCurve

    preset = _elevator_preset(tmp_path, episodes="6", eval_episodes="2", patience="10")
    run = train("gym4real/elevator-v0", "qlearning", preset, seed=1, out=tmp_path / "run")
    curve = pd.read_csv(run.curve_csv)
    assert curve["episodes"].tolist() == [2, 4, 6]  # the progress, not the evaluation's episode count
    assert curve["eval_episodes"].tolist() == [2, 2, 2]
    fig = LearningCurve.load(tmp_path / "run", "episodes").figure()
    low, high = fig.axes[0].get_xlim()
    assert low <= 2 < 6 <= high and high - low < 8


@pytest.mark.parametrize(("algo", "fidelity"), [("qlearning", "corrected"), ("sarsa", "upstream")])
def test_compiled_and_python_tabular_loops_learn_the_same_table(algo: str, fidelity: str, tmp_path: Path) -> None:
    pytest.importorskip("numba")
    import numpy as np

    from gym4real.rl.tabular import train_tabular

    hp = load_preset("gym4real/elevator-v0", algo, _elevator_preset(tmp_path, algo=algo, episodes="5"))
    hp["env_kwargs"] = hp["eval_env_kwargs"] = {"duration": 200, "fidelity": fidelity}
    tables, curves = [], []
    for compiled in (False, True):
        out = tmp_path / str(compiled)
        path, steps = train_tabular("gym4real/elevator-v0", hp, 7, out, compiled=compiled)
        tables.append(np.load(path)["q"])
        curves.append((out / "curve.csv").read_text())
        assert steps == {"train": 5 * 200, "eval": 2 * 200}
    assert np.abs(tables[0]).sum() > 0
    np.testing.assert_array_equal(tables[0], tables[1])
    assert curves[0] == curves[1]


def test_tabular_model_selection_never_sees_the_test_seeds(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from gym4real.bench.benchmark import protocol
    from gym4real.core.registry import load_object

    resets: dict[int, list[int | None]] = {}  # seeds of each env instance, in order of first reset
    reset = gym.Env.reset

    def recording_reset(self, *, seed=None, options=None):
        resets.setdefault(id(self), []).append(seed)
        return reset(self, seed=seed, options=options)

    monkeypatch.setattr(gym.Env, "reset", recording_reset)
    train("gym4real/elevator-v0", "qlearning", "smoke", seed=0, out=tmp_path)
    spec = protocol("gym4real/elevator-v0")
    test_seeds = {ep["seed"] for ep in load_object(spec.protocol)(dict(spec.env_kwargs))}
    training, validation = resets.values()  # the training env is reset first
    assert len(training) == 6 and validation and set(validation).isdisjoint(test_seeds)


def test_every_registered_preset_selects_on_seeds_disjoint_from_the_test_protocol(tmp_path: Path) -> None:
    from gym4real.rl.train import check_no_test_overlap

    for env_id, algo, preset in registry().trainings:
        check_no_test_overlap(env_id, algo, preset)
    bad = _elevator_preset(tmp_path, eval_seed="1250")
    with pytest.raises(ConfigError, match="selects its model on test episodes"):
        train("gym4real/elevator-v0", "qlearning", bad, out=tmp_path / "run")


def test_ppo_mini_batches_divide_every_rollout() -> None:
    """SB3 truncates the last mini-batch when batch_size does not divide n_steps * n_envs."""
    for env_id, algo, preset in registry().trainings:
        if algo == "ppo":
            hp = load_preset(env_id, algo, preset)
            rollout = hp["hyperparams"]["n_steps"] * hp["n_envs"]
            assert rollout % hp["hyperparams"].get("batch_size", 64) == 0, (env_id, preset)


class _Interrupt(Exception):
    pass


def test_an_interrupted_tabular_run_resumes_to_the_same_table(tmp_path: Path) -> None:
    import numpy as np

    preset = _elevator_preset(tmp_path, episodes="6", patience="10")
    whole = train("gym4real/elevator-v0", "qlearning", preset, seed=3, out=tmp_path / "whole")

    def stop_at_five(done: int, total: int) -> None:
        if done == 5:
            raise _Interrupt

    with pytest.raises(_Interrupt):
        train("gym4real/elevator-v0", "qlearning", preset, seed=3, out=tmp_path / "cut", progress=stop_at_five)
    assert (tmp_path / "cut" / "checkpoint.npz").exists() and not (tmp_path / "cut" / "run.json").exists()
    with np.load(tmp_path / "cut" / "checkpoint.npz") as cut:
        checkpointed_at = int(cut["episode"])  # the last validation before the interruption
    assert 0 < checkpointed_at < 5
    resumed = train("gym4real/elevator-v0", "qlearning", preset, seed=3, out=tmp_path / "cut")
    np.testing.assert_array_equal(np.load(resumed.model_path)["q"], np.load(whole.model_path)["q"])
    assert pd.read_csv(resumed.curve_csv).equals(pd.read_csv(whole.curve_csv))
    assert not (tmp_path / "cut" / "checkpoint.npz").exists()
    # the run records where it went on from, and with which code; the uninterrupted one records no resume
    resumes = json.loads((tmp_path / "cut" / "run.json").read_text())["resumes"]
    assert [(r["unit"], r["at"]) for r in resumes] == [("episodes", checkpointed_at)]
    assert resumes[0]["code_version"] == json.loads((tmp_path / "cut" / "run.json").read_text())["versions"].get(
        "gym4real (git)", "unknown"
    )
    assert json.loads((tmp_path / "whole" / "run.json").read_text())["resumes"] == []
    with pytest.raises(ConfigError, match="holds a run of other settings"):
        train("gym4real/elevator-v0", "qlearning", preset, seed=4, out=tmp_path / "cut")


def test_a_resumed_run_keeps_the_commit_and_cpu_that_started_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 47: a run started at X on machine A and resumed at Y on B said "trained by Y"; X and A were lost."""
    import importlib

    from gym4real.results.page_manifest import machines
    from gym4real.results.provenance import runs_table
    from gym4real.results.published_models import publish_models
    from gym4real.results.section_provenance import code_versions, run_provenance

    trainer = importlib.import_module("gym4real.rl.train")
    preset = _elevator_preset(tmp_path, episodes="6", patience="10")

    def segment(commit: str, cpu: str) -> None:
        monkeypatch.setattr(trainer, "git_version", lambda: commit)
        monkeypatch.setattr(trainer, "cpu_model", lambda: cpu)

    def stop_at_five(done: int, total: int) -> None:
        if done == 5:
            raise _Interrupt

    segment("aaa1111", "CPU A")
    with pytest.raises(_Interrupt):
        train("gym4real/elevator-v0", "qlearning", preset, seed=3, out=tmp_path / "cut", progress=stop_at_five)
    segment("bbb2222", "CPU B")
    run = train("gym4real/elevator-v0", "qlearning", preset, seed=3, out=tmp_path / "cut")
    record = json.loads((tmp_path / "cut" / "run.json").read_text())
    assert record["started"] == {"code_version": "aaa1111", "cpu": "CPU A"}
    assert [(r["code_version"], r["cpu"]) for r in record["resumes"]] == [("bbb2222", "CPU B")]
    assert (record["versions"]["gym4real (git)"], record["cpu"]) == ("bbb2222", "CPU B")  # the finishing process
    assert not (tmp_path / "cut" / "started.json").exists()  # taken over by run.json, as the resumes are
    runs = runs_table([run])
    assert runs[["trained_by", "started_on", "cpu"]].values.tolist() == [["aaa1111", "CPU A", "CPU B"]]
    trained, resumed = run_provenance(runs, "qlearning", 3)
    assert trained == "`aaa1111`" and resumed.endswith("episodes by `bbb2222`")
    assert code_versions(runs, "ccc3333") == "Trained at code version `aaa1111` (test phase at `ccc3333`)"
    runs.to_csv(tmp_path / "runs.csv", index=False)
    assert machines(tmp_path, {})["trained_on"] == {"CPU A": 1, "CPU B": 1}
    assert publish_models([run], tmp_path / "section", "quick")[0]["trained_by"] == "aaa1111"  # models.json
    # a run never interrupted started and finished at the same commit, on the same machine
    whole = train("gym4real/elevator-v0", "qlearning", preset, seed=3, out=tmp_path / "whole")
    assert json.loads((tmp_path / "whole" / "run.json").read_text())["started"] == {
        "code_version": "bbb2222",
        "cpu": "CPU B",
    }
    assert runs_table([whole])["trained_by"].tolist() == ["bbb2222"]


def test_a_run_recorded_before_its_start_was_names_the_commit_that_finished_it(tmp_path: Path) -> None:
    """An old run.json without ``started``: runs.csv keeps the finishing commit and does not invent a start CPU."""
    from gym4real.bench.versions import NOT_RECORDED
    from gym4real.results.provenance import runs_table

    run = train("gym4real/elevator-v0", "qlearning", _elevator_preset(tmp_path, episodes="4"), seed=1, out=tmp_path)
    record = json.loads((tmp_path / "run.json").read_text())
    del record["started"]
    record["versions"]["gym4real (git)"] = "ddd4444"
    (tmp_path / "run.json").write_text(json.dumps(record))
    assert runs_table([run])[["trained_by", "started_on"]].values.tolist() == [["ddd4444", NOT_RECORDED]]
    # a start by code without a version (no checkout, no GYM4REAL_CODE_VERSION) is not a commit either
    (tmp_path / "run.json").write_text(json.dumps({**record, "started": {"code_version": "unknown", "cpu": "CPU A"}}))
    assert runs_table([run])[["trained_by", "started_on"]].values.tolist() == [[NOT_RECORDED, "CPU A"]]


TRADING_DQN = """
algo: dqn
total_timesteps: 408
n_envs: 2
policy_kwargs: {net_arch: [16]}
hyperparams: {learning_starts: 20, buffer_size: 1000, batch_size: 8, train_freq: 4}
env_kwargs: {preset: train}
eval_env_kwargs: {preset: validation}
eval_freq: 136
eval_episodes: 2
"""


def test_an_interrupted_sb3_run_resumes_from_its_checkpoint(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    import numpy as np

    path = tmp_path / "dqn.yaml"
    path.write_text(TRADING_DQN)

    def stop_after_the_second_evaluation(done: int, total: int) -> None:
        if done >= 300:
            raise _Interrupt

    out = tmp_path / "run"
    with pytest.raises(_Interrupt):
        train("gym4real/trading-v0", "dqn", str(path), seed=0, out=out, progress=stop_after_the_second_evaluation)
    state = json.loads((out / "checkpoint" / "state.json").read_text())
    assert state["timesteps"] == 272
    with np.load(out / "checkpoint" / state["slot"] / "buffer.npz") as buffer:
        # 272 steps of 2 envs are 136 rows; SB3 stores a step's row after calling back, so 135 are saved
        assert len(buffer["rewards"]) == 135
    run = train("gym4real/trading-v0", "dqn", str(path), seed=0, out=out)
    # DQN collects train_freq (4) steps of both envs at a time: the budget 408 is a multiple of 8
    assert run.env_steps == 408 and not (out / "checkpoint").exists()
    assert pd.read_csv(run.curve_csv)["timesteps"].tolist() == [136, 272, 408]
    assert [(r["unit"], r["at"]) for r in json.loads((out / "run.json").read_text())["resumes"]] == [("timesteps", 272)]


def test_a_run_killed_while_writing_a_checkpoint_resumes_from_the_one_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A run killed halfway through writing its second checkpoint (a session's end, a lost node) resumes."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.base_class import BaseAlgorithm

    path = tmp_path / "dqn.yaml"
    path.write_text(TRADING_DQN)
    original = BaseAlgorithm.save
    checkpoints: list[str] = []

    def dies_in_the_second_checkpoint(self: BaseAlgorithm, to: Any, *args: Any, **kwargs: Any) -> None:
        if "checkpoint" in str(to):
            checkpoints.append(str(to))
            if len(checkpoints) == 2:  # half a model file written, then the process is gone
                Path(to).write_bytes(b"PK\x03\x04 half a zip")
                raise _Interrupt
        original(self, to, *args, **kwargs)

    monkeypatch.setattr(BaseAlgorithm, "save", dies_in_the_second_checkpoint)
    out = tmp_path / "run"
    with pytest.raises(_Interrupt):
        train("gym4real/trading-v0", "dqn", str(path), seed=0, out=out)
    assert json.loads((out / "checkpoint" / "state.json").read_text())["timesteps"] == 136
    monkeypatch.setattr(BaseAlgorithm, "save", original)
    run = train("gym4real/trading-v0", "dqn", str(path), seed=0, out=out)
    assert run.env_steps == 408 and not (out / "checkpoint").exists()
    assert pd.read_csv(run.curve_csv)["timesteps"].tolist() == [136, 272, 408]


def test_dam_and_wds_select_their_models_on_held_out_data() -> None:
    from gym4real.bench.benchmark import protocol
    from gym4real.core.registry import load_object

    dam = load_preset("gym4real/dam-v0", "ppo", "paper")
    train_years = set(gym.make("gym4real/dam-v0", **dam["env_kwargs"]).unwrapped.years)
    validation_years = set(gym.make("gym4real/dam-v0", **dam["eval_env_kwargs"]).unwrapped.years)
    spec = protocol("gym4real/dam-v0")
    test_years = {ep["options"]["year"] for ep in load_object(spec.protocol)(dict(spec.env_kwargs))}
    assert (len(train_years), len(validation_years), len(test_years)) == (39, 13, 13)
    assert train_years.isdisjoint(validation_years) and test_years.isdisjoint(train_years | validation_years)

    if "gym4real/wds-v0" not in gym4real.list_envs():
        return
    wds = load_preset("gym4real/wds-v0", "dqn", "paper")
    train_demand = gym.make("gym4real/wds-v0", **wds["env_kwargs"]).unwrapped.config.demand
    validation_demand = gym.make("gym4real/wds-v0", **wds["eval_env_kwargs"]).unwrapped.config.demand
    spec = protocol("gym4real/wds-v0")
    test_profiles = {ep["options"]["profile_index"] for ep in load_object(spec.protocol)(dict(spec.env_kwargs))}
    start, stop = validation_demand.test_indices
    assert train_demand.split == "train" and validation_demand.split == "test"
    assert test_profiles.isdisjoint(range(start, stop))


def test_a_copy_outside_git_records_the_code_version_its_launcher_states(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import subprocess

    from gym4real.bench import versions
    from gym4real.rl import train as train_module

    def no_git(*args: object, **kwargs: object) -> subprocess.CompletedProcess[str]:
        return subprocess.CompletedProcess(args, 128, "", "fatal: not a git repository")

    monkeypatch.setattr(versions.subprocess, "run", no_git)
    monkeypatch.delenv("GYM4REAL_CODE_VERSION", raising=False)
    assert "gym4real (git)" not in train_module.versions()
    monkeypatch.setenv("GYM4REAL_CODE_VERSION", "abc1234")
    assert train_module.versions()["gym4real (git)"] == "abc1234 (stated)"


def test_a_greedy_table_acts_as_its_q_table_in_every_state(tmp_path: Path) -> None:
    """The published form of a Q-table (:func:`save_greedy_table`) picks, in every state, the action the trained
    table's greedy policy picks: unvisited (all-zero) rows and tied maxima included (``np.argmax`` takes the
    first), with the table's identity kept."""
    from gym4real.rl.tabular import save_greedy_table, save_qtable

    rng = np.random.default_rng(0)
    q = rng.normal(size=(1000, 3))
    q[:100] = 0.0  # states never visited
    q[100:200, 1:] = q[100:200, :1] + 1.0  # actions 1 and 2 tied at the maximum
    radices = np.array([10, 10, 10])
    save_qtable(tmp_path / "full.npz", q, "gym4real/elevator-v0", "qlearning", radices)
    save_greedy_table(tmp_path / "full.npz", tmp_path / "greedy.npz")
    with np.load(tmp_path / "greedy.npz") as greedy:
        assert greedy["q"].dtype == np.int8 and greedy["q"].shape == q.shape
        assert np.array_equal(np.argmax(greedy["q"], axis=1), np.argmax(q, axis=1))
        assert np.argmax(greedy["q"][150]) == 1 and np.argmax(greedy["q"][50]) == 0
        assert str(greedy["env_id"]) == "gym4real/elevator-v0" and str(greedy["algo"]) == "qlearning"
        assert np.array_equal(greedy["radices"], radices)


def test_the_learning_curve_figure_is_drawn_once_when_the_run_ends(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each evaluation redrew curve.png: 0.4 s of the training process each, 100 times in a microgrid run."""
    from gym4real.rl.curves import LearningCurve

    drawn: list[int] = []
    figure = LearningCurve.figure

    def counted(self: LearningCurve) -> Any:
        drawn.append(len(self.rows))
        return figure(self)

    monkeypatch.setattr(LearningCurve, "figure", counted)
    preset = _elevator_preset(tmp_path, episodes="6", eval_episodes="2", patience="10")
    run = train("gym4real/elevator-v0", "qlearning", preset, seed=1, out=tmp_path / "run")
    assert len(pd.read_csv(run.curve_csv)) == 3
    assert drawn == [3]  # once, with every evaluation
    assert (tmp_path / "run" / "curve.png").stat().st_size > 0
