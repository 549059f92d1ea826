"""The in-memory scene: sizes of the spec, nothing written, bad files rejected, headless renderer lifecycle."""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import gym4real  # noqa: F401
from gym4real.core.errors import DataFileError
from gym4real.robofeeder import scene
from gym4real.robofeeder.config import PickingConfig
from gym4real.robofeeder.simulator import Simulator


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p): (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*") if p.is_file()}


def test_compiled_sizes_match_the_spec() -> None:
    m = scene.build_model(3)
    assert (m.nbody, m.ngeom, m.nmesh, m.nq, m.nv, m.nu) == (18, 43, 27, 30, 27, 9)
    assert m.opt.timestep == pytest.approx(1e-3)
    assert m.opt.noslip_iterations == 3 and m.opt.impratio == pytest.approx(30)
    assert [m.body(f"object{i}").id for i in range(3)] == [1, 2, 3]  # objects first, as the reference's qpos layout


def test_models_are_private_copies() -> None:
    a, b = scene.build_model(1), scene.build_model(1)
    a.geom_rgba[0, 0] = 0.123
    assert b.geom_rgba[0, 0] != 0.123
    assert a.nq == 16  # one free joint (7) + the bin slide + 6 arm joints + 2 fingers


def test_nothing_is_written(tmp_path: Path) -> None:
    package = Path(scene.__file__).parent
    data = Path(os.environ["GYM4REAL_DATA_DIR"]) / "robofeeder"
    before = _tree(package), _tree(data)
    scene._compiled.cache_clear()
    scene.build_model(4)
    assert (_tree(package), _tree(data)) == before
    assert not any(p.name == "object_v2.xml" for p in package.rglob("*"))


def test_generated_objects_xml() -> None:
    xml = scene.objects_xml("<mujoco><worldbody>", 2)
    assert xml.count('<body name="object') == 2 and xml.rstrip().endswith("</mujoco>")
    with pytest.raises(DataFileError, match="worldbody"):
        scene.objects_xml("<mujoco>", 1)


def test_corrupt_data_file_is_rejected(tmp_path: Path) -> None:
    source = Path(os.environ["GYM4REAL_DATA_DIR"])
    bad = tmp_path / "robofeeder" / "model" / "urdf" / "box.xml"
    bad.parent.mkdir(parents=True)
    bad.write_text((source / "robofeeder/model/urdf/box.xml").read_text()[:500])
    with pytest.raises(DataFileError, match="corrupt"):
        scene.build_model(1, data_dir=str(tmp_path))


def test_renderer_is_lazy_and_closed() -> None:
    env = gym.make("gym4real/robofeeder-picking-v1", render_mode="rgb_array")
    renderer = env.unwrapped.sim.renderer
    assert not renderer.is_open
    env.reset(seed=0)
    assert renderer.is_open
    frame = env.render()
    assert frame.shape == (300, 300, 3) and frame.dtype == np.uint8 and frame.std() > 0
    env.close()
    assert not renderer.is_open


def test_side_camera_render() -> None:
    env = gym.make("gym4real/robofeeder-picking-v0", render_mode="rgb_array", render_camera="angled_side_view")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (300, 300, 3) and frame.dtype == np.uint8
    env.close()


def test_top_down_view_does_not_show_the_robot() -> None:
    # hiding the robot, the floor and the transparent plane in observation renders leaves the image unchanged
    sim = Simulator(PickingConfig.build(n_objects=2))
    sim.reset(np.random.default_rng(0))
    fast = sim.render("top_down")
    sim.renderer._top_down_option = sim.renderer._option
    full = sim.render("top_down")
    sim.close()
    np.testing.assert_array_equal(fast, full)


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024
    return 0.0


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc")
def test_100_make_close_cycles_do_not_grow() -> None:
    for _ in range(3):  # warm caches (compiled template, rest pose, GL libraries)
        env = gym.make("gym4real/robofeeder-picking-v1")
        env.unwrapped.sim.render()
        env.close()
    rss, fds = _rss_mb(), len(os.listdir("/proc/self/fd"))
    for _ in range(100):
        env = gym.make("gym4real/robofeeder-picking-v1")
        env.unwrapped.sim.render()
        env.close()
        assert not env.unwrapped.sim.renderer.is_open
    assert len(os.listdir("/proc/self/fd")) <= fds + 2
    assert _rss_mb() - rss < 60.0  # a leaked GL context or model costs tens of MB each
