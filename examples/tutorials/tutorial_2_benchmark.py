"""# Benchmark the baselines and read the figures

`gym4real.benchmark` runs policies on an environment's evaluation protocol (the paper's test episodes)
or on seeded episodes, and returns their scores, returns, reward components and a summary table; with
`out=` it also writes CSV/JSON and two figures. The score is the protocol's objective (higher is better),
the number `gym4real evaluate` and the results page rank by; the return (the training reward) is shown
beside it only where it differs. `gym4real bench ID` on the command line does the same.
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
# The table opens with the protocol it ran. The summary is a pandas DataFrame, one row per policy, best
# first: the interquartile mean (IQM) of the objective with its 95 % bootstrap interval, its mean and
# standard deviation, and the mean return (training reward), which here ranks the policies otherwise:
# the dam's reward adds penalties that are not the paper's objective.
summary = result.summary()
print(summary[["objective_iqm", "objective_low", "objective_high", "return_mean"]].round(0).to_string())

# %%
# ## Read the figures
# `cumulative_reward.png`: the mean cumulative objective over the year, with a 95 % band across the test
# years: where a policy loses shows as a steeper descent. `returns_boxplot.png`: the spread of the
# per-year objective. Both draw the policies best first.
for name in ("cumulative_reward.png", "returns_boxplot.png"):
    plt.figure(figsize=(9, 5))
    plt.imshow(plt.imread(out / name))
    plt.axis("off")
plt.show()
