from __future__ import annotations

import numpy as np

import gym4real
from gym4real.elevator import ElevatorEnv
from gym4real.elevator.baselines import longest_first, shortest_first
from gym4real.elevator.env import DOWN, OPEN, UP

ENV_ID = "gym4real/elevator-v0"


def obs(position: int, load: int, queues: list[int]) -> dict[str, object]:
    return {
        "current_position": position,
        "n_passengers": load,
        "floor_queues": np.array(queues),
        "arrivals": np.zeros(4, dtype=np.int64),
    }


def test_rules_follow_the_spec() -> None:
    env = ElevatorEnv()
    lf, sf = longest_first(env), shortest_first(env)
    assert lf(obs(4, 2, [0, 0, 0, 0])) == DOWN  # riders go straight down
    assert lf(obs(0, 2, [3, 0, 0, 0])) == OPEN  # at the ground floor: unload
    assert lf(obs(0, 0, [0, 0, 0, 0])) == OPEN  # nothing to do: wait
    assert lf(obs(0, 0, [1, 3, 3, 0])) == UP  # longest queue, tie -> highest floor (3 -> position 6)
    assert lf(obs(6, 0, [1, 3, 3, 0])) == OPEN
    assert lf(obs(8, 0, [1, 3, 3, 0])) == DOWN
    assert sf(obs(8, 0, [0, 2, 1, 1])) == DOWN  # shortest non-empty, tie -> lowest floor (3)
    assert sf(obs(6, 0, [0, 2, 1, 1])) == OPEN


def test_paper_ranking_rule_based_policies_beat_random() -> None:
    result = gym4real.benchmark(ENV_ID, ["random", "longest_first", "shortest_first"], episodes=3, seed=1234)
    means = {k: np.mean(v) for k, v in result.returns.items()}
    assert means["longest_first"] > means["random"]
    assert means["shortest_first"] > means["random"]
    for name in means:
        comps = result.components[name]
        np.testing.assert_allclose(np.add(comps["delivery"], comps["waiting"]), result.returns[name])
