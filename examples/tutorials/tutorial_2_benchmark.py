"""# Benchmark the baselines and read the figures

`gym4real.benchmark` runs policies on an environment's evaluation protocol (the paper's test episodes)
or on seeded episodes, and returns their returns, reward components and a summary table; with `out=`
it also writes CSV/JSON and two figures. `gym4real bench ID` on the command line does the same.
"""

# %%
# ## Run the protocol
# The dam's protocol is the 13 test years, one one-year episode each, scored by the paper's objective
# (deficit + overflow + starving). Each policy is a registered rule-based baseline.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import gym4real

out = Path(tempfile.mkdtemp()) / "dam"
result = gym4real.benchmark("gym4real/dam-v0", ["ead", "max", "random"], episodes="test", out=out)
print(result.table())

# %%
# The summary is a pandas DataFrame, one row per policy: mean, std, interquartile mean (IQM) and a
# 95 % bootstrap interval of the mean return, and the mean objective.
summary = result.summary()
print(summary[["mean", "iqm", "ci95_low", "ci95_high", "objective_mean"]])

# %%
# ## Read the figures
# `cumulative_reward.png`: the mean cumulative reward over the year, with a 95 % band across the test
# years: where a policy loses reward shows as a steeper descent. `returns_boxplot.png`: the spread of the
# returns over the test years.
for name in ("cumulative_reward.png", "returns_boxplot.png"):
    plt.figure(figsize=(9, 5))
    plt.imshow(plt.imread(out / name))
    plt.axis("off")
plt.show()
