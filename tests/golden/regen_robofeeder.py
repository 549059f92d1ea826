"""Regenerate ``tests/golden/robofeeder.json`` by running the reference RoboFeeder (not run in CI).

Usage (in a throwaway venv with the reference's imports: mujoco 4.x, ikpy, scipy, numpy, opencv, pyyaml,
gymnasium, imageio; ``MUJOCO_GL=egl`` or ``osmesa``)::

    python tests/golden/regen_robofeeder.py /path/to/gym4ReaL-checkout [--out tests/golden/robofeeder.json]

The checkout is the reference at commit 774d5ce, already on disk; this script only imports and runs it
(its simulator, ikpy planner and picking-v1 env). Note that the reference's simulator rewrites
``object_v2.xml`` inside the checkout (reference defect 3).

What it records, for ``tests/golden/test_golden_robofeeder.py``:

* ``grasp_grid``: one object placed at each of a few image points and yaws, settled as the reference's
  ``reset`` does (900 steps, then the one step of ``get_state``); then grasps commanded around the object's
  grasp site at the reference's grasp angle (its 2.35-offset formula) and off it. Per grasp: success, the
  physics steps of the pick and the planned joints 1-5 at the pick pose. The picking-v0/planning envs cannot
  be built (the detector file is missing in the reference), so the simulator is driven directly.
* ``fixed_baseline``: picking-v1 episodes of the reference's picking baseline (action (0, 0, 0)), spawns
  drawn by the reference under ``np.random.seed(s)`` and ``random.seed(s)`` (the reference never seeds
  ``random``); the spawn draw is recorded so that our upstream env can replay it through reset options
  (our env draws from its own generator, so a seed alone cannot reproduce the reference's draw).
* ``trajectory``: the first steps of one such seeded picking-v1 episode under a fixed action sequence:
  rewards, flags, the object's position and a summary of the observation.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np

COMMIT = "774d5ceb1c218e09e5c6458ead7d4b0b10e2d8ac"
#: Normalised image placements (x, y) of the single object and the two quaternion values (qw, qz) of the
#: reference's orientation grid it is given: inside the spawn area, and two in the lower band of the image.
SCENES = (
    ((-0.6, -0.6), (1.0, 0.0)),
    ((0.0, -0.6), (0.6, 0.8)),
    ((0.6, -0.6), (-0.4, 1.0)),
    ((-0.6, 0.0), (0.8, -0.6)),
    ((0.0, -0.2), (1.0, 0.4)),
    ((0.6, 0.0), (0.2, -1.0)),
    ((0.0, 0.1), (-0.8, -0.6)),
    ((-0.3, 0.6), (1.0, 0.0)),
    ((0.3, 0.8), (0.6, 0.8)),
)
#: Grasps per scene: offset (m) along the object's x axis from its grasp site, and offset of the angle (rad).
GRASPS = ((0.0, 0.0), (0.0, 0.5), (0.0, -0.5), (0.006, 0.0), (-0.006, 0.0), (0.0, np.pi / 2))
SETTLE_STEPS = 900
FIXED_EPISODES = 12
TRAJECTORY_SEED = 7


def reference_grasp_angle(quat: np.ndarray) -> float:
    """The reference reward's object angle: scipy reads MuJoCo's (w, x, y, z) as (x, y, z, w), offset 2.35."""
    from scipy.spatial.transform import Rotation

    angle = 2.35 + Rotation.from_quat(quat).as_euler("xyz")[0]
    return float(angle - np.pi if angle > np.pi else angle + np.pi if angle < 0 else angle)


def write_config(folder: Path, checkout: Path) -> Path:
    """The reference configuration with one object (the paper's picking setting)."""
    text = (checkout / "gym4real/envs/robofeeder/configuration.yaml").read_text()
    text = text.replace("NUMBER_OF_OBJECTS: 3", "NUMBER_OF_OBJECTS: 1")
    assert "NUMBER_OF_OBJECTS: 1" in text
    path = folder / "configuration.yaml"
    path.write_text(text)
    return path


def place(sim, xy: tuple[float, float], quat_grid: tuple[float, float]) -> None:
    """The reference's reset with a given spawn instead of a random one (as its heat-map notebook does)."""
    import mujoco

    sim.objPicked = [0]
    mujoco.mj_resetDataKeyframe(sim.model, sim.data, 0)
    sim.last_pos = [0.0] * 6
    pixel = (np.asarray(xy) + 1.0) * sim.configs["OBSERVATION_IMAGE_DIM"] / 2
    world = sim.pixel2World(pixel)
    sim.data.qpos[0:3] = [world[0], world[1], 0.21]
    sim.data.qpos[3], sim.data.qpos[6] = quat_grid
    mujoco.mj_step(sim.model, sim.data, SETTLE_STEPS)
    sim.get_state()


def grasp_grid(sim) -> list[dict]:
    """Pick outcomes of the grasps of GRASPS around the object of each scene of SCENES."""
    scenes = []
    for xy, quat_grid in SCENES:
        world = sim.pixel2World((np.asarray(xy) + 1.0) * sim.configs["OBSERVATION_IMAGE_DIM"] / 2).tolist()
        place(sim, xy, quat_grid)
        settled = sim.data.qpos[0:7].tolist()
        grasps = []
        for offset, dtheta in GRASPS:
            place(sim, xy, quat_grid)
            quat = sim.data.qpos[3:7].copy()
            w, x, y, z = quat
            yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
            target = sim.data.site(1).xpos[:2] + offset * np.array([np.cos(yaw), np.sin(yaw)])
            theta = reference_grasp_angle(quat) + dtheta
            plan, _ = sim.planner.planFunction(initial_joint_position=list(sim.last_pos), obj_position=[*target, 0.11])
            start = sim.data.time
            _, result = sim.simulate_pick(np.append(target, 0.11), theta)
            grasps.append(
                {
                    "xy": target.tolist(),
                    "theta": float(theta),
                    "success": bool(result == 1),
                    "steps": round((sim.data.time - start) / sim.model.opt.timestep),
                    "pick_q": plan[9][1:6].tolist(),
                }
            )
        scenes.append(
            {
                "placement": list(xy),
                "quat_grid": list(quat_grid),
                "world": world,
                "settled_qpos": settled,
                "grasps": grasps,
            }
        )
    return scenes


def seeded_spawn(seed: int, grid: np.ndarray) -> tuple[list[float], list[float]]:
    """The reference's spawn draw of one object under np.random.seed(seed) and random.seed(seed)."""
    np.random.seed(seed)
    random.seed(seed)
    x = np.random.uniform(-0.8, 0.8, 1)
    y = np.random.uniform(-0.75, 0.1, 1)
    values = random.choices(grid, k=4)
    return [float(x[0]), float(y[0])], [float(values[0]), float(values[1])]


def seeded_reset(env, seed: int) -> tuple[np.ndarray, dict]:
    """Reset the reference env under both global seeds; returns the observation and the recorded spawn."""
    sim = env.simulator
    placement, quat_grid = seeded_spawn(seed, sim.possibleOrietnation)
    np.random.seed(seed)
    random.seed(seed)
    obs, _ = env.reset()
    expected = sim.pixel2World((np.asarray(placement) + 1.0) * sim.configs["OBSERVATION_IMAGE_DIM"] / 2)
    assert np.linalg.norm(sim.data.qpos[0:2] - expected) < 0.03, "the replayed spawn draw is not the env's"
    return obs, {"seed": seed, "placement": placement, "quat_grid": quat_grid}


def summary(obs: np.ndarray) -> dict:
    """Mean gray level and the centroid (u, v) of the bright pixels (> 0.6) of an observation (1, H, W)."""
    img = np.asarray(obs, dtype=np.float64)[0]
    vs, us = np.nonzero(img > 0.6)
    centroid = [float(us.mean()), float(vs.mean())] if len(us) else None
    return {"mean": float(img.mean()), "bright_centroid": centroid, "bright_pixels": len(us)}


def fixed_baseline(env) -> list[dict]:
    """Episodes of the reference's picking baseline (the middle of the action box) on picking-v1."""
    episodes = []
    for seed in range(FIXED_EPISODES):
        _, record = seeded_reset(env, seed)
        rewards, done = [], False
        while not done:
            _, reward, done, _, _ = env.step(np.zeros(3))
            rewards.append(float(reward))
        episodes.append({**record, "rewards": rewards, "return": float(sum(rewards))})
    return episodes


def trajectory(env) -> dict:
    """The first steps of a seeded picking-v1 episode: the baseline action, then a grasp at the object."""
    obs, record = seeded_reset(env, TRAJECTORY_SEED)
    sim = env.simulator
    steps = [{"observation": summary(obs), "object_position": sim.data.qpos[0:3].tolist()}]
    inv = np.array(sim.inv_camera_matrix)
    depth = 0.42078046  # the reference's fixed depth of pixel2World
    pixel_of = np.linalg.inv(-depth * inv[:2, :2])
    origin = -depth * inv[:2, 2] + inv[:2, 3]
    for k in range(env.max_episode_steps):
        if k == 0:
            action = np.zeros(3)
        else:  # at the object's grasp site, at the reference's grasp angle
            pixel = pixel_of @ (sim.data.site(1).xpos[:2] - origin)
            theta = reference_grasp_angle(sim.data.qpos[3:7].copy())
            action = np.array([*(pixel / 150.0 - 1.0), theta / (np.pi / 2) - 1.0])
        commanded = action.copy()
        obs, reward, terminated, truncated, _ = env.step(action)  # the reference mutates the action
        steps.append(
            {
                "action": commanded.tolist(),
                "reward": float(reward),
                "terminated": bool(terminated),
                "truncated": bool(truncated),
                "observation": summary(obs),
                "object_position": sim.data.qpos[0:3].tolist(),
            }
        )
        if terminated:
            break
    return {**record, "steps": steps}


def rounded(value: object) -> object:
    """``value`` with its floats to 10 significant digits."""
    if isinstance(value, float):
        return float(f"{value:.10g}")
    if isinstance(value, dict):
        return {k: rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [rounded(v) for v in value]
    return value


def dump(value: object, indent: int = 0, width: int = 250) -> str:
    """JSON with every list or object that fits in ``width`` characters on one line (a fixture of a few KB)."""
    line = json.dumps(value)
    if len(line) <= width or not isinstance(value, dict | list):
        return line
    pad = " " * (indent + 1)
    if isinstance(value, dict):
        items = [f"{pad}{json.dumps(k)}: {dump(v, indent + 1, width)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    items = [pad + dump(v, indent + 1, width) for v in value]
    return "[\n" + ",\n".join(items) + "\n" + " " * indent + "]"


def main() -> None:
    """Run the reference and write the fixture."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkout", type=Path, help="the reference repository checked out at commit 774d5ce")
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("robofeeder.json"))
    args = parser.parse_args()
    sys.path.insert(0, str(args.checkout.resolve()))
    import mujoco

    from gym4real.envs.robofeeder.rf_picking_v1 import robotEnv
    from gym4real.envs.robofeeder.src.robot_simulator import robot_simulator

    with tempfile.TemporaryDirectory() as tmp:
        config = write_config(Path(tmp), args.checkout)
        sim = robot_simulator(str(config))
        grid = grasp_grid(sim)
        sim.close()
        mujoco.set_mjcb_control(None)  # the reference's callback stays registered (defect 4) and would now fail
        env = robotEnv(str(config))
        baseline = fixed_baseline(env)
        traj = trajectory(env)
        env.simulator.close()
    versions = {name: metadata.version(name) for name in ("mujoco", "ikpy", "scipy", "numpy")}
    fixture = {
        "reference": {"repository": "Daveonwave/gym4ReaL", "commit": COMMIT, "versions": versions},
        "n_objects": 1,
        "settle_steps": SETTLE_STEPS,
        "grasp_grid": grid,
        "fixed_baseline": baseline,
        "trajectory": traj,
    }
    args.out.write_text(dump(rounded(fixture)) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
