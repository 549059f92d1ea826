"""# A multi-objective id with MO-Gymnasium's wrappers

The `-mo` ids (`gym4real/dam-mo-v0`, `gym4real/microgrid-mo-v0`, `gym4real/wds-mo-v0`) return a vector
reward, one entry per reward component of the env they wrap, and declare its `reward_space` as
MO-Gymnasium's environments do; its wrappers apply unchanged (extra `mo`).
"""

# %%
# ## The vector reward
import gymnasium as gym
import mo_gymnasium as mo_gym
import numpy as np

import gym4real  # noqa: F401  (registers the ids)

env = gym.make("gym4real/dam-mo-v0")
components = env.unwrapped.components
print(components)
print(env.unwrapped.reward_space)
obs, info = env.reset(seed=0)
obs, vector, terminated, truncated, info = env.step(env.action_space.sample())
print({name: round(float(value), 2) for name, value in zip(components, vector, strict=True)})
print("sum of the entries:", vector.sum(), "scalar reward of dam-v0:", info["scalar_reward"])

# %%
# ## Scalarise with weights
# `LinearReward` turns the vector into a weighted sum: unit weights give back the scalar reward of
# `gym4real/dam-v0`; here the overflow term counts ten times.
weights = np.array([10.0 if c == "overflow" else 1.0 for c in components])
scalar = mo_gym.wrappers.LinearReward(gym.make("gym4real/dam-mo-v0"), weight=weights)
obs, info = scalar.reset(seed=0)
obs, reward, terminated, truncated, info = scalar.step(scalar.action_space.sample())
print("weighted reward:", reward, "vector:", info["vector_reward"])

# %%
# ## Episode statistics per objective
# `MORecordEpisodeStatistics` reports the vector return of each finished episode (one year of the dam),
# here for the `ead` baseline, which releases an exponential average of the past demands.
from gym4real.bench.policies import make_policy  # noqa: E402

env = mo_gym.wrappers.MORecordEpisodeStatistics(gym.make("gym4real/dam-mo-v0"), gamma=1.0)
policy = make_policy("gym4real/dam-mo-v0", "ead", env)
obs, info = env.reset(seed=0)
done = False
while not done:
    obs, vector, terminated, truncated, info = env.step(policy(obs))
    done = terminated or truncated
for name, value in zip(components, info["episode"]["r"], strict=True):
    print(f"{name:>14}: {value:12.1f}")
