"""# Evaluate a multi-objective agent: front, hypervolume and expected utility

`gym4real evaluate --mo` scores a multi-objective agent on a vector-reward id against what its domain
ships: the objectives, a fixed reference point and the reference fronts of the rule-based baselines'
parameter sweeps. Here the agent is a set of three PPO policies on `gym4real/wds-mo-v0`, each trained on
the vector reward scalarised with its own weights through MO-Gymnasium's `LinearReward` (extra `mo`).
The budgets are tiny, to show the steps; the evaluation runs the full test protocol (20 weeks per
policy). The whole script takes about 25 s of CPU (23 s measured; 2 min of wall time on a 2-core machine
shared with other jobs). `gym4real evaluate --mo` and `gym4real.evaluate_mo` need the `mo` extra:
`pip install "gym4real-core[mo,rl]"` (`rl` for the PPO trained here).
"""

# %%
# ## The objectives and the reference point
# The domain declares the objectives, each a sum of reward components over a test episode, maximised;
# the reference point and the fronts come with the domain (`gym4real info gym4real/wds-mo-v0` shows them).
import tempfile
import textwrap
from pathlib import Path

import gymnasium as gym
import mo_gymnasium as mo_gym
import numpy as np
from stable_baselines3 import PPO

import gym4real  # registers the ids
from gym4real.bench.mo_reference import summary
from gym4real.core.mo_spec import mo_spec

ENV_ID = "gym4real/wds-mo-v0"
spec = mo_spec(ENV_ID)
evaluation = summary(ENV_ID)
for objective in spec.objectives:
    print(f"{objective.name}: {' + '.join(objective.components)}")
print("reference point:", evaluation["reference_point"])
print(textwrap.fill(f"rule: {evaluation['reference_point_rule']}", width=100))

# %%
# ## Train one PPO per weight
# `reward_weights` maps weights over the objectives onto the vector reward's entries; `LinearReward`
# scalarises it. Training uses the `train` preset's demand profiles, never the test ones.
runs = Path(tempfile.mkdtemp()) / "wds-mo"
policies = []
for w in ([1.0, 0.0], [0.5, 0.5], [0.0, 1.0]):
    env = gym.make(ENV_ID, preset="train")
    weights = spec.reward_weights(w, env.unwrapped.components)
    scalar = mo_gym.wrappers.LinearReward(env, weight=weights.astype(np.float32))
    model = PPO("MlpPolicy", scalar, n_steps=128, batch_size=64, n_epochs=2, seed=0, device="cpu", verbose=0)
    model.learn(total_timesteps=256)
    path = runs / f"w{w[0]:g}-{w[1]:g}" / "model.zip"
    path.parent.mkdir(parents=True)
    model.save(path)
    policies.append(f"sb3:ppo:{path}")
    scalar.close()
print([p.replace(str(runs), "runs") for p in policies])

# %%
# ## Evaluate the set
# On the command line: `gym4real evaluate --mo --envs gym4real/wds-mo-v0 ppo=sb3:ppo:runs/wds-mo/w1-0/model.zip
# ppo=...` (the policies named alike form one agent's set). From Python, `evaluate_mo` takes the same
# agents; a weight-conditioned factory `factory(env, weights=w, seed=S)` is run at each of the EUM's 50
# weights instead (`examples/my_agent.py:make_weighted_policy` is one). Hypervolume and EUM are on the
# normalised scale (reference point 0, random's best test episode 1), with 95 % bootstrap intervals over
# test episodes (and training seeds, with `seeds=`).
result = gym4real.evaluate_mo({"ppo": policies}, [ENV_ID], out=runs / "evaluation")
print(result.table())

# %%
# The gap to each reference front is the front's value minus the agent's (positive: the front is
# ahead); `score.json`'s `"mo"` section holds the same numbers with the agent's front.
record = result.score()[ENV_ID]["agents"]["ppo"]
for point in record["front"]:
    label = point["label"].replace(str(runs), "runs")
    print(label, np.round(point["mean"], 2), "non-dominated" if point["nondominated"] else "dominated")

# %%
# ## The Pareto plot
# The agent's points and front beside the reference fronts and the reference point.
import matplotlib.pyplot as plt  # noqa: E402

image = plt.imread(runs / "evaluation" / "pareto-wds-mo-v0.png")
plt.figure(figsize=(6.4, 4.8))
plt.imshow(image)
plt.axis("off")
plt.show()
