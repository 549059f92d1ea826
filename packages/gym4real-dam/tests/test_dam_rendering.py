"""The rgb_array frame shows the lake's state: the gauge at the level in the threshold's colour, the traces."""

from __future__ import annotations

import numpy as np
import pytest

from gym4real.core.canvas import BLUE, GREEN, INK, LIGHT, ORANGE, RED, WATER, Canvas
from gym4real.dam.env import DamEnv
from gym4real.dam.rendering import FLOWS, GAUGE, LABEL_AT, LEVELS


def _y(value: float, span: tuple[float, float], box: tuple[float, float, float, float]) -> float:
    return box[3] - (value - span[0]) / (span[1] - span[0]) * (box[3] - box[1])


@pytest.mark.parametrize(("level", "colour"), [(-0.6, ORANGE), (0.35, WATER), (1.5, RED)])
def test_gauge_fills_to_the_level_in_the_colour_of_the_threshold_crossed(level: float, colour: tuple) -> None:
    env = DamEnv(render_mode="rgb_array", preset="test")
    env.reset(options={"init_level": level})
    frame = env.render()
    span = (env.config.starving_level - 0.35, env.config.flood_level + 0.6)
    top = _y(level, span, GAUGE)
    x = int((GAUGE[0] + GAUGE[2]) / 2)
    assert tuple(frame[round(top) + 2, x]) == colour
    assert tuple(frame[round(top) - 2, x]) == LIGHT


def _near(frame: np.ndarray, x: float, y: float, colour: tuple) -> bool:
    patch = frame[round(y) - 1 : round(y) + 2, round(x) - 1 : round(x) + 2]
    return bool((patch == colour).all(axis=-1).any())


def test_traces_hold_the_level_and_the_release_of_each_day_so_far() -> None:
    env = DamEnv(render_mode="rgb_array", preset="test")
    env.reset()
    releases, levels = [], []
    for a in [0.0, 50.0, 400.0, 120.0] * 10:
        *_, info = env.step(np.array([a], dtype=np.float32))
        releases.append(info["release"])
        levels.append(info["level"])
    frame = env.render()
    h = env.config.sim_horizon
    span = (env.config.starving_level - 0.35, env.config.flood_level + 0.6)
    width = LEVELS[2] - LEVELS[0]
    q_max = 1.05 * max(max(env.episode.inflow), max(env.episode.demand), max(releases))
    for day in range(1, len(releases) + 1):
        x = LEVELS[0] + day / h * width
        assert _near(frame, x, _y(levels[day - 1], span, LEVELS), BLUE), day
        assert _near(frame, x, _y(releases[day - 1], (0.0, q_max), FLOWS), GREEN), day
    future = frame[int(LEVELS[1]) + 2 : int(LEVELS[3]) - 1, round(LEVELS[0] + 42 / h * width) :]
    assert not (future == BLUE).all(-1).any()  # no trace beyond today


def _label_pixels(text: str) -> np.ndarray:
    """The label band of a frame showing ``text`` at the label's place."""
    canvas = Canvas(480, 320)
    canvas.text(LABEL_AT, text, INK)
    return canvas.array()[10:22, 185:370]


def test_each_frame_names_the_day_the_lake_is_at_and_the_last_is_the_years_last_day() -> None:
    """A 365-day year: day 1 at its start, then the end of each day just simulated, up to day 365 (not day 1)."""
    env = DamEnv(render_mode="rgb_array", preset="test")
    ansi = DamEnv(render_mode="ansi", preset="test")
    env.reset()
    ansi.reset()
    h = env.config.sim_horizon
    assert h == 365 and env.episode.year == 1950  # not a leap year: step t ends day t

    def shows(frame: np.ndarray, text: str) -> bool:
        return bool((frame[10:22, 185:370] == _label_pixels(text)).all())

    assert shows(env.render(), f"day   1 start  (step 0/{h})")
    assert ansi.render().startswith("1950 day   1 start: ")
    for t in range(1, h + 1):
        env.step(np.array([100.0], dtype=np.float32))
        ansi.step(np.array([100.0], dtype=np.float32))
        if t in (1, 2, 200, h):
            assert shows(env.render(), f"day {t:3d} end  (step {t}/{h})"), t
            assert ansi.render().startswith(f"1950 day {t:3d} end: "), t
