"""The batched MicrogridVectorEnv against N single MicrogridEnvs, step by step."""

from __future__ import annotations

import importlib.util
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401  (registers the ids)
from gym4real.core.testing import compare_vector_with_sync
from gym4real.microgrid import MicrogridEnv
from gym4real.microgrid.aging import AgingParams
from gym4real.microgrid.rainflow import StreamingRainflow
from gym4real.microgrid.vector import MicrogridVectorEnv, _Rainflow

ENV_ID = "gym4real/microgrid-v0"
COMPONENTS = ("trading", "degradation", "clipping")
NEEDS_NUMBA = pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba (extra fast) not installed")
COMPILED = [pytest.param(True, marks=NEEDS_NUMBA, id="compiled"), pytest.param(False, id="numpy")]

CONFIGS: dict[str, dict[str, Any]] = {
    # random profile, start hour and battery per copy; episodes of 120 h, so each copy resets twice
    "random-starts": {"max_steps": 120, "random_start": True, "random_battery_init": True, "observe_soh": True},
    # profiles in file order, 3 h decisions; a battery near its end of life (at the default EUR per unit
    # of SoH) so that copies end at different times, by end of life or after 100 h, inside a decision
    "end-of-life": {
        "preset": "test",
        "max_steps": 100,
        "decision_interval": 3,
        "battery": {"eol_soh": 0.9998, "replacement_cost": 1.5},
    },
}


@pytest.mark.parametrize("compiled", COMPILED)
@pytest.mark.parametrize("name", list(CONFIGS))
def test_batched_copies_follow_the_single_env_step_by_step(name: str, compiled: bool) -> None:
    """Every copy's observation, reward, flags and info against a single env stepped alongside.

    Compiled (numba): bit for bit. Numpy: within the last bits of ``exp`` and ``pow`` (module docstring).
    """
    kwargs, n, steps = CONFIGS[name], 5, 300
    vec = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", compiled=compiled, **kwargs)
    exact = compiled  # tolerances of the numpy path below, none for the compiled one
    singles = [MicrogridEnv(**kwargs) for _ in range(n)]
    obs, info = vec.reset(seed=30)
    starts = [e.reset(seed=30 + i) for i, e in enumerate(singles)]
    assert list(info["profile"]) == [i["profile"] for _, i in starts]
    assert list(info["start"]) == [i["start"] for _, i in starts]
    single_obs = [o for o, _ in starts]
    rng = np.random.default_rng(4)
    pending = np.zeros(n, dtype=bool)  # copies that ended at the previous step (next-step autoreset)
    ends = {"terminated": 0, "truncated": 0}
    for t in range(steps):
        np.testing.assert_allclose(obs, np.stack(single_obs), rtol=0 if exact else 1e-6, err_msg=f"step {t}")
        actions = rng.uniform(0.0, 1.0, size=(n, 1)).astype(np.float32)
        actions[t % n] = np.float32(1.0 + 5e-7)  # within the tolerance: clipped to 1 by both
        obs, rewards, terminated, truncated, info = vec.step(actions)
        single_obs = []
        for i, env in enumerate(singles):
            if pending[i]:
                single_obs.append(env.reset()[0])
                assert rewards[i] == 0.0 and not terminated[i] and not truncated[i]
                assert all(info["reward_components"][k][i] == 0.0 for k in COMPONENTS)
                continue
            o, r, term, trunc, inf = env.step(actions[i])
            single_obs.append(o)
            assert (terminated[i], truncated[i]) == (term, trunc)
            got = {"reward": rewards[i], "cost": info["cost"][i], "soh": info["soh"][i], "soc": info["soc"][i]}
            want = {"reward": r, "cost": inf["cost"], "soh": inf["soh"], "soc": inf["soc"]}
            got["temperature"], want["temperature"] = info["temperature"][i], inf["temperature"]
            for group in ("reward_components", "pure_components", "energy"):
                got |= {f"{group}.{k}": info[group][k][i] for k in inf[group]}
                want |= {f"{group}.{k}": v for k, v in inf[group].items()}
            if exact:
                assert got == want, f"step {t}, copy {i}"
                continue
            for k, v in want.items():
                assert got[k] == pytest.approx(v, rel=1e-12, abs=1e-9), f"step {t}, copy {i}: {k}"
        ends["terminated"] += int(terminated.sum())
        ends["truncated"] += int(truncated.sum())
        pending = terminated | truncated
    assert ends["truncated"] > 0  # autoresets were crossed
    if name == "end-of-life":
        assert ends["terminated"] > 0


def test_batched_rainflow_counts_as_the_scalar_counter() -> None:
    """N streaming rainflow counters in arrays (stack grown from depth 2) against the scalar one."""
    params, n = AgingParams(), 4
    rng = np.random.default_rng(0)
    batched = _Rainflow(n, params, depth=2)
    scalars = [StreamingRainflow(damage=params.cycle_damage) for _ in range(n)]
    x0, temp0 = rng.uniform(0.2, 1.0, n), rng.uniform(280.0, 310.0, n)
    batched.reset(np.arange(n), x0, temp0)
    for i, rf in enumerate(scalars):
        rf.push(x0[i], temp0[i])
    for _ in range(400):
        x = np.round(rng.uniform(0.2, 1.0, n), 2)  # rounded: flat segments and equal ranges occur
        x[0] = 0.5  # a constant series: no reversal at all
        temp = rng.uniform(280.0, 310.0, n)
        batched.push(x, temp)
        for i, rf in enumerate(scalars):
            rf.push(x[i], temp[i])
        np.testing.assert_array_equal(batched.total, [rf.total_damage for rf in scalars])
    assert batched.depth > 2


def _problem(message: str) -> str:
    """What an action error says is wrong (between the action space and what was expected)."""
    return message.split("float32): ", 1)[1].split("; expected")[0]


def _single_env_problem(action: np.ndarray) -> str:
    env = MicrogridEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not in the action space") as exc:
        env.step(action)
    return _problem(str(exc.value))


@pytest.mark.parametrize("bad", [np.nan, 1.5, -0.25])
def test_bad_actions_raise_the_single_env_error(bad: float) -> None:
    vec = MicrogridVectorEnv(3)
    vec.reset(seed=0)
    actions = np.full((3, 1), 0.5, np.float32)
    actions[1] = bad
    with pytest.raises(ValueError, match="not in the action space") as exc:
        vec.step(actions)
    assert _problem(str(exc.value)) == _single_env_problem(np.array([bad], np.float32))
    assert "(copies [1])" in str(exc.value)
    with pytest.raises(ValueError, match=r"shape \(3, 2\), not \(3, 1\)"):
        vec.step(np.full((3, 2), 0.5, np.float32))


def test_settings_it_does_not_batch_are_refused() -> None:
    with pytest.raises(ValueError, match='fidelity="corrected" only'):
        MicrogridVectorEnv(2, fidelity="upstream")
    with pytest.raises(ValueError, match=r"\['capacity_fade'\] are off"):
        MicrogridVectorEnv(2, fixes={"capacity_fade": False})


def _made_with(compiled: bool, monkeypatch: pytest.MonkeyPatch, depth: int | None = None) -> list[MicrogridVectorEnv]:
    """The MicrogridVectorEnvs made from now on, with ``compiled`` (and rainflow stacks of ``depth`` points)."""
    made: list[MicrogridVectorEnv] = []
    original = MicrogridVectorEnv.__init__

    def init(self: MicrogridVectorEnv, *args: Any, **kw: Any) -> None:
        original(self, *args, compiled=compiled, **kw)
        if depth is not None:
            self.twin.rainflow = _Rainflow(self.num_envs, self.twin.aging, depth=depth)
        made.append(self)

    monkeypatch.setattr(MicrogridVectorEnv, "__init__", init)
    return made


@pytest.mark.parametrize(
    ("kwargs", "num_envs", "steps"),
    [
        ({"max_steps": 90, "random_start": True, "random_battery_init": True}, 3, 200),
        ({"max_steps": 90, "random_start": True, "decision_interval": 4, "max_episode_steps": 7}, 3, 60),
    ],
)
@pytest.mark.parametrize("compiled", COMPILED)
def test_native_vector_env_is_a_drop_in_for_sync_vector_env(
    kwargs: dict[str, Any], num_envs: int, steps: int, compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Same seeds and actions give the trajectories of ``SyncVectorEnv`` of the single env, across autoresets,
    with the compiled decision (numba) and with the numpy one (what runs without numba).

    Both bit for bit: the numpy step calls the C library's ``exp`` and ``pow`` as the single env does (NumPy's
    vectorised ones differ from them in the last bit for some arguments).
    """
    made = _made_with(compiled, monkeypatch)
    result = compare_vector_with_sync("gym4real/microgrid-v0", num_envs, steps, seed=3, rtol=0.0, **kwargs)
    assert (result.episode_ends >= 2).all()
    assert [vec._kernel is not None for vec in made] == [compiled]


@pytest.mark.parametrize("compiled", COMPILED)
def test_rainflow_stacks_grow_while_stepping(compiled: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Stacks of one point grow as reversals pile up, inside the compiled loop too, trajectories unchanged."""
    made = _made_with(compiled, monkeypatch, depth=1)
    kwargs = {"max_steps": 60, "random_start": True, "random_battery_init": True, "decision_interval": 3}
    compare_vector_with_sync("gym4real/microgrid-v0", 3, 50, seed=5, rtol=0.0, **kwargs)
    assert made[0].twin.rainflow.depth > 3  # grown from 1 (several reversals on a stack)


@pytest.mark.parametrize("compiled", COMPILED)
@pytest.mark.parametrize("name", list(CONFIGS))
def test_step_arrays_is_step_without_its_info(name: str, compiled: bool) -> None:
    """Two envs reset alike, one stepped with ``step`` and one through ``core.vector.step_arrays`` (the env's
    ``step_arrays``), give the same observations, rewards and flags bit for bit, across autoresets."""
    from gym4real.core.vector import step_arrays

    envs = [MicrogridVectorEnv(3, compiled=compiled, **CONFIGS[name]) for _ in range(2)]
    for env in envs:
        env.reset(seed=5)
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(130):
        actions = rng.uniform(0.0, 1.0, (3, 1)).astype(np.float32)
        full = envs[0].step(actions)[:4]
        bare = step_arrays(envs[1], actions)
        for a, b in zip(full, bare, strict=True):
            assert a.tobytes() == b.tobytes()
        ends += int((full[2] | full[3]).sum())
    assert ends >= 3
