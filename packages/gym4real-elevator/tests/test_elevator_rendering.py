"""The rgb_array frame shows the building's state: cabin height and load, queue at each floor, deliveries."""

from __future__ import annotations

import numpy as np
import pytest

from gym4real.core.canvas import BLUE, ORANGE
from gym4real.elevator import ElevatorEnv
from gym4real.elevator.rendering import SHAFT, ElevatorRenderer


def _runs(row: np.ndarray, colour: tuple, longer_than: int) -> int:
    """Runs of ``colour`` in a pixel row longer than ``longer_than`` pixels (discs, not outlines)."""
    hit = np.concatenate([[False], (row == colour).all(-1), [False]])
    edges = np.flatnonzero(np.diff(hit.astype(int)))
    return int(np.sum(edges[1::2] - edges[::2] > longer_than))


@pytest.mark.parametrize("seed", [0, 1])
def test_frame_shows_cabin_height_load_and_every_queue(seed: int) -> None:
    env = ElevatorEnv(render_mode="rgb_array", floors={"lambda_min": 0.2, "lambda_max": 0.4}, duration=300)
    layout = ElevatorRenderer(5, 2, 0, 0, 4, 300)  # the env's building: 5 floors, 2 positions per floor
    r = layout.radius
    x0, _, x1, _ = SHAFT
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    seen_loads, seen_queues = set(), set()
    for _ in range(120):
        obs, *_ = env.step(int(rng.choice(3, p=[0.3, 0.4, 0.3])))
        frame = env.render()
        y = layout.floor_y(obs["current_position"])
        assert tuple(frame[round(y), round((x0 + x1) / 2)]) == BLUE  # the cabin's floor
        assert tuple(frame[round(y - layout.cabin_h), round((x0 + x1) / 2)]) == BLUE  # its roof
        inside = slice(round(x0) + 3, round(x1) - 2)
        riders = sum(_runs(frame[round(y - 3 - r - k * (2 * r + 2)), inside], BLUE, 3) for k in range(2))
        assert riders == obs["n_passengers"]
        for floor in range(1, 5):
            row = frame[round(layout.floor_y(2 * floor) - r - 1), round(x1) + 8 :]
            assert _runs(row, ORANGE, 3) == obs["floor_queues"][floor - 1], floor
        seen_loads.add(int(obs["n_passengers"]))
        seen_queues.add(int(obs["floor_queues"].sum()))
    assert len(seen_loads) > 2 and len(seen_queues) > 3  # the checks saw varied states


def test_deliveries_so_far_are_kept_per_second() -> None:
    env = ElevatorEnv(render_mode="rgb_array", floors={"lambda_min": 0.2, "lambda_max": 0.4}, duration=200)
    env.reset(seed=3)
    rng = np.random.default_rng(3)
    delivered = []
    for _ in range(200):
        *_, info = env.step(int(rng.integers(3)))
        delivered.append(info["delivered"])
    assert env._renderer.delivered == delivered and delivered[-1] > 0
