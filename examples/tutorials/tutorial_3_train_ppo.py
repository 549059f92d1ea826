"""# Train PPO on the dam and compare it with the baselines

Stable-Baselines3 trains on any gym4real environment as on any Gymnasium one (extra `rl`). This is a
small budget, to show the steps; the paper's run is `gym4real train gym4real/dam-v0 --algo ppo
--preset paper` (200k steps, the appendix's hyperparameters), and `gym4real reproduce` tests it.
"""

# %%
# ## Train
# Training uses the `train` years; the actions are learnt on [-1, 1] and rescaled to the release range.
import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO

import gym4real

# float32 bounds, the dtype of the dam's action space
env = gym.wrappers.RescaleAction(gym.make("gym4real/dam-v0", preset="train"), np.float32(-1.0), np.float32(1.0))
model = PPO("MlpPolicy", env, n_steps=1024, batch_size=64, seed=0, verbose=0).learn(total_timesteps=10240)


# %%
# ## Compare on the test protocol
# `benchmark` takes any callable `obs -> action` beside the baseline names. The model acts on [-1, 1]:
# the policy maps its action back to the release range.
release = env.unwrapped.action_space


def ppo(obs):
    """The model's deterministic action, rescaled from [-1, 1] to the dam's release range."""
    action, _ = model.predict(obs, deterministic=True)
    return release.low + (action + 1.0) * (release.high - release.low) / 2.0


result = gym4real.benchmark("gym4real/dam-v0", ["ead", "max", ppo], episodes="test")
print(result.table())

# %%
# The table ranks by the paper's score, the objective (deficit + overflow + starving, higher is better;
# `objective_iqm` with its interval); `return_mean` is the training reward, which adds the penalties on
# wasted water and on releases outside the feasible range. 10k steps are 28 years of daily decisions, a
# twentieth of the paper's budget: the
# [reproduced results](../results/index.md) test PPO at that budget over five seeds.
