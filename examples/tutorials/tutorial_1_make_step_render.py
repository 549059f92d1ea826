"""# Make an environment, step it, render a frame

Every gym4real environment is a Gymnasium environment: `import gym4real` registers them all, then
`gymnasium.make` builds one from its id.
"""

# %%
# ## Make and reset
# The keyword arguments of `make` are validated config fields (a mistyped one is named, with the
# nearest field); `preset` picks a data split (`train`, `validation`, `test` where the env has them).
import gymnasium as gym
import matplotlib.pyplot as plt

import gym4real

print(gym4real.list_envs())
env = gym.make("gym4real/dam-v0", render_mode="rgb_array")
obs, info = env.reset(seed=0)
print(env.observation_space)
print(env.action_space)
print(obs)

# %%
# ## Step
# The action is the water released from Lake Como (m³/s). The reward is the sum of its terms, each
# reported in `info["reward_components"]`; `info["cost"]` is the safe-RL cost.
total = 0.0
for _ in range(30):
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    total += float(reward)
print(f"return over 30 days: {total:.1f}")
print(info["reward_components"], "cost:", info["cost"])

# %%
# ## Render a frame
# `render_mode="rgb_array"` returns an image (height, width, 3) of the current state.
frame = env.render()
print(frame.shape, frame.dtype)
plt.figure(figsize=(8, 5))
plt.imshow(frame)
plt.axis("off")
plt.show()
env.close()
