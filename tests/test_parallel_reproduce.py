"""`gym4real reproduce --jobs N`: the same results as one job, a killed worker's run resumed, the plan's estimates."""

from __future__ import annotations

import itertools
import json
import os
import signal
import threading
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from gym4real.core.rl.estimate import budget_units, estimate, wall_time
from gym4real.core.rl.plan import Item, plan
from gym4real.core.rl.progress import PlanProgress
from gym4real.core.rl.runner import train_plan
from gym4real.core.rl.train import train

# A PPO run of a few seconds on short dam episodes (the registered smoke preset trains for half a minute).
DAM_PPO = """
algo: ppo
total_timesteps: 256
n_envs: 2
normalize_obs: true
policy_kwargs: {net_arch: [8]}
hyperparams: {n_steps: 64, batch_size: 32, n_epochs: 2}
env_kwargs: {preset: train, sim_horizon: 60}
eval_env_kwargs: {preset: validation, sim_horizon: 60}
eval_freq: 128
eval_episodes: 1
eval_seed: 10000
"""


class Recorder(PlanProgress):
    """A silent progress bar that records what the executor told it."""

    def __init__(self, total: int) -> None:
        super().__init__(total, show=False)
        self.events: list[tuple[str, int, int]] = []

    def item(self, env_id: str, done: int, total: int, key: int = -1) -> None:
        super().item(env_id, done, total, key)
        self.events.append(("progress", key, done))

    def retry(self, key: int, message: str) -> None:
        super().retry(key, message)
        self.events.append(("retry", key, 0))

    def close_item(self, key: int = -1) -> None:
        super().close_item(key)
        self.events.append(("closed", key, 0))


def _plan(out: Path, preset_dir: Path) -> list[Item]:
    items = plan("gym4real/elevator-v0", "quick", 1, out)  # Q-learning and SARSA, compiled
    (preset_dir / "dam_ppo.yaml").write_text(DAM_PPO)
    ppo = str(preset_dir / "dam_ppo.yaml")
    return [*items, Item("gym4real/dam-v0", "ppo", ppo, 3, out / "dam-v0" / "quick" / "runs" / "ppo" / "seed3")]


def _model(item: Item) -> dict[str, bytes]:
    """The trained weights: the Q-table, or the SB3 zip's parameter files (its other entries hold times)."""
    if item.algo == "ppo":
        with zipfile.ZipFile(item.folder / "model.zip") as z:
            return {name: z.read(name) for name in ("policy.pth", "policy.optimizer.pth")}
    with np.load(item.folder / "qtable.npz") as data:
        return {"q": data["q"].tobytes()}


@pytest.mark.slow
def test_two_jobs_train_the_same_runs_as_one(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    one, two = _plan(tmp_path / "one", tmp_path), _plan(tmp_path / "two", tmp_path)
    first = train_plan(one, jobs=1)
    bar = Recorder(len(two))
    second = train_plan(two, bar, jobs=2)
    assert [o.item for o in second] == two and all(o.run is not None for o in first + second), second
    for a, b in zip(one, two, strict=True):
        assert (a.folder / "curve.csv").read_bytes() == (b.folder / "curve.csv").read_bytes(), b.folder
        assert _model(a) == _model(b), b.folder
    assert sorted(key for kind, key, _ in bar.events if kind == "closed") == [0, 1, 2]
    assert bar.closed == len(two) and not bar.running


def _workers() -> list[int]:
    """This process's spawned worker processes."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (entry / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == os.getpid() and b"spawn_main" in cmdline:
            found.append(int(entry.name))
    return found


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds the worker processes in /proc (Linux)")
def test_a_killed_workers_run_resumes_from_its_checkpoint_to_the_uninterrupted_result(tmp_path: Path) -> None:
    preset = tmp_path / "long.yaml"
    preset.write_text(
        "algo: qlearning\nepisodes: 150\nalpha: 0.1\ngamma: 1.0\nepsilon: {start: 1.0, decay: 0.97, min: 0.05}\n"
        "eval_every: 15\neval_episodes: 2\npatience: 100\nmin_improvement: 0.1\neval_seed: 10000\n"
        "env_kwargs: {duration: 600}\neval_env_kwargs: {duration: 600}\n"
    )
    whole = train("gym4real/elevator-v0", "qlearning", str(preset), seed=5, out=tmp_path / "whole")
    folder = tmp_path / "out" / "elevator-v0" / "quick" / "runs" / "qlearning" / "seed5"
    items = [
        Item("gym4real/elevator-v0", "qlearning", str(preset), 5, folder),
        *plan("gym4real/elevator-v0", "quick", 1, tmp_path / "out")[1:],
    ]
    killed: dict[str, int] = {}

    def kill_after_the_first_checkpoint() -> None:
        deadline = time.monotonic() + 120
        while not (folder / "checkpoint.npz").exists() and time.monotonic() < deadline:
            time.sleep(0.005)
        with np.load(folder / "checkpoint.npz") as data:
            killed["episode"] = int(data["episode"])
        for pid in _workers():
            os.kill(pid, signal.SIGKILL)
        killed["workers"] = len(_workers())

    killer = threading.Thread(target=kill_after_the_first_checkpoint)
    killer.start()
    bar = Recorder(len(items))
    outcomes = train_plan(items, bar, jobs=2)
    killer.join()
    assert all(o.run is not None for o in outcomes), outcomes
    mine = [(kind, done) for kind, key, done in bar.events if key == 0]
    assert ("retry", 0) in mine, "the run finished before its worker was killed"
    after = mine[mine.index(("retry", 0)) + 1 :]
    # the new worker starts from the checkpoint (or a later one), not from the first episode
    assert after[0][0] == "progress" and after[0][1] > killed["episode"] >= 15
    np.testing.assert_array_equal(np.load(folder / "qtable.npz")["q"], np.load(whole.model_path)["q"])
    assert (folder / "curve.csv").read_bytes() == whole.curve_csv.read_bytes()
    assert (
        json.loads((folder / "run.json").read_text())["env_steps"]
        == json.loads((tmp_path / "whole" / "run.json").read_text())["env_steps"]
    )


def test_the_wall_time_of_a_schedule_is_within_four_thirds_of_the_best() -> None:
    rng = np.random.default_rng(0)
    for _ in range(30):
        costs = rng.integers(1, 20, size=int(rng.integers(1, 7))).astype(float).tolist()
        workers = int(rng.integers(1, 4))
        best = min(
            max(sum(c for c, w in zip(costs, assign, strict=True) if w == k) for k in range(workers))
            for assign in itertools.product(range(workers), repeat=len(costs))
        )
        got = wall_time(costs, workers)
        assert best <= got <= best * 4 / 3 - best / (3 * workers) + 1e-9  # Graham's bound of the LPT rule
    assert wall_time([5.0, 1.0, 1.0], 1) == 7.0 and wall_time([5.0, 1.0, 1.0], 64) == 5.0


def test_the_plan_estimates_runs_from_the_measured_ones(tmp_path: Path) -> None:
    out = tmp_path / "out"
    quick = plan("gym4real/elevator-v0", "quick", 2, out)
    paper = plan("gym4real/elevator-v0", "paper", 1, out)
    assert [e.source for e in estimate(quick, out)] == ["budget x recorded step rate"] * 4
    run = train(quick[0].env_id, quick[0].algo, quick[0].preset, quick[0].seed, quick[0].folder)
    found = estimate(quick + paper, out)
    assert (found[0].cpu_s, found[0].source) == (0.0, "finished")
    assert found[1].cpu_s == run.wall_time_s and found[1].source.startswith("mean of 1 run(s)")
    units = budget_units(paper[0].env_id, "qlearning", paper[0].preset)
    assert paper[0].algo == "qlearning" and found[4].cpu_s == pytest.approx(
        units * run.wall_time_s / budget_units(run.env_id, "qlearning", run.preset)
    )
    assert found[5].source == "budget x recorded step rate"  # sarsa was measured nowhere
