"""# Collect a Minari dataset and load it

Offline RL and imitation learning start from recorded episodes. `gym4real dataset collect` (or
`gym4real.offline.collect`) runs a policy for seeded episodes and writes them as a
[Minari](https://minari.farama.org) dataset (extra `offline`).
"""

# %%
# ## Collect
# Two episodes of the elevator's `longest_first` baseline, which serves the floor with the longest
# queue first; the dataset goes in a folder of its own (Minari's `MINARI_DATASETS_PATH`).
import os
import tempfile
import warnings
from pathlib import Path

import minari

from gym4real.offline import collect, dataset_id

out = tempfile.mkdtemp()
with warnings.catch_warnings():  # Minari asks a published dataset for a code link and a contact: not this one
    warnings.filterwarnings("ignore", message="`(code_permalink|author_email)` is set to None")
    folder = collect("gym4real/elevator-v0", "longest_first", episodes=2, out=out)
name = dataset_id("gym4real/elevator-v0", "longest_first")
print(name, "written to", Path("$MINARI_DATASETS_PATH") / folder.relative_to(Path(out).resolve()))

# %%
# ## Load
# Minari finds the dataset by id in `MINARI_DATASETS_PATH`. Each episode holds the observations
# (one more than the actions: the last one is the final state), actions, rewards and ends.
os.environ["MINARI_DATASETS_PATH"] = out
dataset = minari.load_dataset(name)
print(dataset.total_episodes, "episodes,", dataset.total_steps, "steps")
for episode in dataset.iterate_episodes():
    print(
        f"episode {episode.id}: {len(episode.actions)} actions, return {episode.rewards.sum():.0f},"
        f" queues at the end {episode.observations['floor_queues'][-1]}"
    )

# %%
# ## Replay the environment
# The dataset stores the env's spec, so the environment it came from can be made again.
env = dataset.recover_environment()
print(env.spec.id)
