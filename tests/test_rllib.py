"""RLlib registration, and PPO with two env runners on Gym4ReaL envs (where the `ray` extra is installed)."""

from __future__ import annotations

import math
import sys
import types
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import gym4real
from gym4real.core.registry import registry

IDS = [i for i in ("gym4real/dam-v0", "gym4real/wds-v0", "gym4real/elevator-v0") if i in gym4real.list_envs()][:2]


def test_register_all_registers_exactly_the_scalar_reward_ids(monkeypatch: pytest.MonkeyPatch) -> None:
    """RLlib's checker refuses a vector reward: `register_all` hands Ray Tune every other id (Ray stubbed)."""
    from gym4real.integrations.rllib import register_all

    creators: dict[str, Callable[[dict[str, Any]], Any]] = {}
    tune_registry = types.ModuleType("ray.tune.registry")
    tune_registry.register_env = creators.__setitem__  # type: ignore[attr-defined]
    for name in ("ray", "ray.tune"):
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    monkeypatch.setitem(sys.modules, "ray.tune.registry", tune_registry)
    vector_reward = set(registry().multi_objective)
    assert vector_reward, "no vector-reward id is installed: nothing to leave out"
    ids = register_all()
    assert sorted(creators) == ids == sorted(set(gym4real.list_envs()) - vector_reward)
    env = creators["gym4real/dam-v0"]({})
    try:
        env.reset(seed=0)
        reward = env.step(env.action_space.sample())[1]
    finally:
        env.close()
    assert isinstance(reward, float)


def test_a_vector_reward_id_runs_scalarised_as_the_module_docstring_shows() -> None:
    """`LinearReward` over `make_env` of the -mo id: a float reward, the weighted components; unit weights
    give the scalar env's reward."""
    mo = pytest.importorskip("mo_gymnasium.wrappers")
    from gym4real.integrations.rllib import make_env

    def rewards(env: gym.Env[Any, Any]) -> list[Any]:
        env.reset(seed=1)
        env.action_space.seed(1)
        out = [env.step(env.action_space.sample())[1] for _ in range(5)]
        env.close()
        return out

    names = make_env("gym4real/dam-mo-v0").unwrapped.components
    vectors = rewards(make_env("gym4real/dam-mo-v0"))
    weights = np.linspace(0.5, 2.0, len(names))
    weighted = rewards(mo.LinearReward(make_env("gym4real/dam-mo-v0"), weights))
    assert all(isinstance(r, float) for r in weighted)
    np.testing.assert_allclose(weighted, [float(v @ weights) for v in vectors], rtol=1e-12)
    unit = rewards(mo.LinearReward(make_env("gym4real/dam-mo-v0"), np.ones(len(names))))
    np.testing.assert_allclose(unit, rewards(make_env("gym4real/dam-v0")), rtol=1e-12)


def _docstring_recipes() -> list[str]:
    """The code blocks (after ``::``) of ``gym4real.integrations.rllib``'s docstring."""
    import textwrap

    import gym4real.integrations.rllib as module

    doc = module.__doc__ or ""
    blocks = []
    for part in doc.split("::\n\n")[1:]:
        lines = []
        for line in part.splitlines():
            if line and not line.startswith("    "):
                break
            lines.append(line)
        blocks.append(textwrap.dedent("\n".join(lines)))
    return blocks


def _unbound_names(code: str) -> set[str]:
    """Names the code reads that it neither imports nor assigns nor gets from builtins (each a NameError)."""
    import ast
    import builtins

    tree = ast.parse(code)
    bound = set(dir(builtins))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            bound |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            bound.add(node.id)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)} - bound


def test_every_recipe_of_the_rllib_docstring_imports_what_it_uses() -> None:
    blocks = _docstring_recipes()
    assert len(blocks) == 2  # registering the scalar ids; a -mo id through LinearReward
    for code in blocks:
        assert not _unbound_names(code), code


def test_the_rllib_docstrings_mo_recipe_runs_and_its_env_creator_makes_the_weighted_env(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The recipe as written, with Ray stubbed (its env creator and config are what reach RLlib's runners)."""
    pytest.importorskip("mo_gymnasium.wrappers")
    creators: dict[str, Callable[[dict[str, Any]], Any]] = {}
    built: list[str] = []

    class PPOConfig:
        def environment(self, name: str, **_: Any) -> PPOConfig:
            built.append(name)
            return self

        def build_algo(self) -> str:
            return "algo"

    modules = {name: types.ModuleType(name) for name in ("ray", "ray.tune", "ray.rllib", "ray.rllib.algorithms")}
    modules["ray.tune.registry"] = types.ModuleType("ray.tune.registry")
    modules["ray.tune.registry"].register_env = creators.__setitem__  # type: ignore[attr-defined]
    modules["ray.rllib.algorithms.ppo"] = types.ModuleType("ray.rllib.algorithms.ppo")
    modules["ray.rllib.algorithms.ppo"].PPOConfig = PPOConfig  # type: ignore[attr-defined]
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    namespace: dict[str, Any] = {}
    exec(_docstring_recipes()[1], namespace)  # our own docstring, run as a user would
    assert namespace["algo"] == "algo" and built == ["dam-weighted"]
    env = creators["dam-weighted"]({})  # what each env runner calls
    scalar = gym4real.make("gym4real/dam-v0")
    try:
        env.reset(seed=0)
        scalar.reset(seed=0)
        action = scalar.action_space.sample()
        _, reward, *_ = env.step(action)
        _, _, *_, scalar_info = scalar.step(action)
    finally:
        env.close()
        scalar.close()
    terms = scalar_info["reward_components"]
    expected = sum(w * terms[c] for w, c in zip(namespace["weights"], env.unwrapped.components, strict=True))
    assert isinstance(reward, float) and reward == pytest.approx(expected, rel=1e-12)


@pytest.fixture(scope="module")
def local_ray():
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


@pytest.mark.ray
@pytest.mark.parametrize("env_id", IDS)
def test_ppo_two_iterations_with_two_env_runners(env_id: str, local_ray: None) -> None:
    from ray.rllib.algorithms.ppo import PPOConfig

    from gym4real.integrations.rllib import register_all

    assert env_id in register_all(flatten=env_id == "gym4real/elevator-v0")
    config = (
        PPOConfig()
        .environment(env_id, env_config={"duration": 200} if env_id == "gym4real/elevator-v0" else {})
        .env_runners(num_env_runners=2, num_cpus_per_env_runner=0.5)
        .training(train_batch_size_per_learner=800, minibatch_size=200, num_epochs=1)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    try:
        results = [algo.train() for _ in range(2)]
    finally:
        algo.stop()
    returns = results[-1]["env_runners"]["episode_return_mean"]
    assert isinstance(returns, float) and math.isfinite(returns)
    assert results[-1]["env_runners"]["num_episodes_lifetime"] >= 1


@pytest.mark.ray
@pytest.mark.parametrize(
    "env_id", [i for i in ("gym4real/dam-v0", "gym4real/elevator-v0") if i in gym4real.list_envs()]
)
def test_ppo_on_the_native_vector_env(env_id: str, local_ray: None) -> None:
    """`gym_env_vectorize_mode="vector_entry_point"`: RLlib steps the env's batched VectorEnv."""
    from ray.rllib.algorithms.ppo import PPOConfig

    from gym4real.integrations.rllib import register_all

    flatten = env_id == "gym4real/elevator-v0"
    register_all(flatten=flatten)
    config = (
        PPOConfig()
        .environment(env_id, env_config={"duration": 100} if flatten else {"max_episode_steps": 50})
        .env_runners(num_env_runners=0, num_envs_per_env_runner=4, gym_env_vectorize_mode="vector_entry_point")
        .training(train_batch_size_per_learner=400, minibatch_size=200, num_epochs=1)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    try:
        env = algo.env_runner.env.unwrapped
        assert type(env).__name__.endswith("VectorEnv") and env.num_envs == 4
        result = algo.train()
    finally:
        algo.stop()
    assert result["env_runners"]["num_episodes_lifetime"] >= 4
    assert math.isfinite(result["env_runners"]["episode_return_mean"])
