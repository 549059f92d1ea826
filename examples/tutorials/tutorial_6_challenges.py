"""# The real-world challenges

`gym4real.wrappers.challenge(env, level)` adds what a deployed controller meets: action persistence,
observation noise and delay, action delay, sensor dropout and, where the domain declares them,
per-episode perturbations of its physical parameters (the dam's lake surface and inflow). Each layer
draws from the seed given to `reset`, so a challenged run is reproducible.
"""

# %%
# ## The levels
import gymnasium as gym
import numpy as np

import gym4real  # noqa: F401  (registers the ids)
from gym4real.bench.benchmark import run_episode
from gym4real.bench.policies import make_policy
from gym4real.wrappers import LEVELS, challenge

for level, settings in LEVELS.items():
    print(level, settings)

# %%
# ## A baseline under each level
# The dam's `ead` baseline reads the observation (the lake level and the demand), so noise, delay and
# dropout change its decisions; the perturbations change the lake itself. Three seeded years per level.
print(challenge(gym.make("gym4real/dam-v0"), "hard"))  # the layers, outermost first
for level in ("none", "easy", "medium", "hard"):
    env = gym.make("gym4real/dam-v0")
    if level != "none":
        env = challenge(env, level)
    policy = make_policy("gym4real/dam-v0", "ead", env)
    returns = [run_episode(env, policy, seed, None)["rewards"].sum() for seed in range(3)]
    print(f"{level:>6}: mean return {np.mean(returns):10.1f}")
    env.close()

# %%
# ## One layer at a time
# The levels are presets; `challenge(env, "medium", noise=0.0)` overrides one setting, and each layer is
# a wrapper of its own (`ObservationNoise`, `ActionDelay`, ...) to compose by hand.
from gym4real.wrappers import ObservationDelay  # noqa: E402

env = ObservationDelay(gym.make("gym4real/dam-v0"), 3)
obs, info = env.reset(seed=0)
for day in range(4):
    obs, reward, terminated, truncated, info = env.step(env.action_space.high)
    print(f"day {day + 1}: the agent sees the level {obs[0]:.3f} m")
