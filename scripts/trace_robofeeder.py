"""Trace RoboFeeder test episodes component by component, to find where two machines (or settings) diverge.

Each test episode of the protocol (``preset="test"``, the protocol's seeds) is run with one baseline, and
every call into a component whose result could depend on the CPU is recorded, in the order it happens:

* ``reset`` / ``pick``: the physics state (``qpos``, ``qvel``, ``time``) after the simulator's reset and
  after each pick's controller ran (MuJoCo's physics);
* ``plan``: the inverse-kinematics plan of a pick (numpy, LAPACK);
* ``render``: the SHA-256 of every rendered frame with the physics state it was rendered from (the
  OpenGL rasteriser: Mesa's llvmpipe on a CPU-only machine);
* ``detect``: the detector's boxes and centres (OpenCV, or onnxruntime for an ONNX detector);
* ``step``: the action, the observation's hash, the reward and its components.

Usage (from the repository root; ``MUJOCO_GL=egl OMP_NUM_THREADS=1 GYM4REAL_DATA_DIR=...`` as for the tests)::

    python scripts/trace_robofeeder.py trace --env picking-v0 --policy random --episodes 5 --out a.jsonl
    NPY_DISABLE_CPU_FEATURES="AVX512F AVX512CD AVX512_SKX" python scripts/trace_robofeeder.py trace ... --out b.jsonl
    python scripts/trace_robofeeder.py diff a.jsonl b.jsonl
    python scripts/trace_robofeeder.py kernels   # BLAS vs portable_math products; rerun under OPENBLAS_CORETYPE=...

The first line of a trace records the machine (CPU model and flags, the OpenGL renderer, numpy's and
OpenCV's dispatched instruction sets, library versions); ``diff`` prints where two traces first differ, in
which component, and how many episodes' returns differ.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import platform
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ENVS = {
    "picking-v0": "gym4real/robofeeder-picking-v0",
    "picking-v1": "gym4real/robofeeder-picking-v1",
    "planning-v0": "gym4real/robofeeder-planning-v0",
}


def digest(array: Any) -> str:
    """Short SHA-256 of an array's bytes (dtype and shape included)."""
    a = np.ascontiguousarray(array)
    h = hashlib.sha256(f"{a.dtype}{a.shape}".encode())
    h.update(a.tobytes())
    return h.hexdigest()[:16]


def physics(sim: Any) -> dict[str, Any]:
    """The simulator's state: exact hashes and the values (``repr`` round-trips a float exactly)."""
    d = sim.data
    return {
        "time": float(d.time),
        "qpos_hash": digest(d.qpos),
        "qvel_hash": digest(d.qvel),
        "qpos": [float(x) for x in d.qpos],
        "qvel": [float(x) for x in d.qvel],
    }


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def openblas_core() -> str:
    """The kernel set numpy's OpenBLAS chose for this CPU (``OPENBLAS_CORETYPE`` overrides it)."""
    import ctypes

    libs = Path(np.__file__).parent.parent / "numpy.libs"
    for lib in sorted(libs.glob("libscipy_openblas*.so*")):
        handle = ctypes.CDLL(str(lib))
        for name in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename"):
            if hasattr(handle, name):
                getter = getattr(handle, name)
                getter.restype = ctypes.c_char_p
                return str(getter().decode())
    return "unknown"


#: Environment variables that change a component's dispatch, recorded when set.
DISPATCH_VARIABLES = (
    "MUJOCO_GL",
    "OMP_NUM_THREADS",
    "NPY_DISABLE_CPU_FEATURES",
    "OPENCV_CPU_DISABLE",
    "OPENBLAS_CORETYPE",
    "LP_NATIVE_VECTOR_WIDTH",
    "LP_NUM_THREADS",
    "GALLIUM_OVERRIDE_CPU_CAPS",
    "GALLIUM_NOSSE",
)


def machine() -> dict[str, Any]:
    """What the run depends on: CPU, dispatch settings, GL renderer, library versions."""
    import cv2
    import mujoco

    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__ as dispatch
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:  # numpy < 2
        from numpy.core._multiarray_umath import __cpu_dispatch__ as dispatch  # type: ignore[no-redef]
        from numpy.core._multiarray_umath import __cpu_features__ as features  # type: ignore[no-redef]
    flags = ""
    with contextlib.suppress(OSError, StopIteration):
        flags = next(x for x in Path("/proc/cpuinfo").read_text().splitlines() if x.startswith("flags"))
    versions = {"numpy": np.__version__, "mujoco": mujoco.__version__, "opencv": cv2.__version__}
    try:
        import onnxruntime

        versions["onnxruntime"] = onnxruntime.__version__
    except ImportError:
        pass
    return {
        "cpu": _cpu_model(),
        "avx512f": " avx512f" in flags,
        "avx2": " avx2" in flags,
        "cores": os.cpu_count(),
        "numpy_dispatch": sorted(k for k in dispatch if features.get(k)),
        "openblas_core": openblas_core(),
        "opencv_optimized": bool(cv2.useOptimized()),
        "env_vars": {k: os.environ[k] for k in DISPATCH_VARIABLES if k in os.environ},
        "versions": versions,
        "python": sys.version.split()[0],
    }


def _gl_renderer() -> str:
    """The OpenGL renderer string of the current context (read after the first frame)."""
    try:
        import ctypes

        from OpenGL import GL  # type: ignore[import-untyped]

        value = GL.glGetString(GL.GL_RENDERER)
        return ctypes.string_at(value).decode() if isinstance(value, int) else value.decode()
    except Exception as exc:  # reporting only: any failure of PyOpenGL is named
        return f"unknown ({type(exc).__name__})"


def instrument(env: Any, record: Callable[[dict[str, Any]], None]) -> None:
    """Wrap the simulator's and detector's calls of ``env`` so that each records what it produced."""
    sim = env.unwrapped.sim
    reset, plan, controller, render = sim.reset, sim.plan, sim._run_controller, sim.render

    def traced_reset(*args: Any, **kwargs: Any) -> Any:
        out = reset(*args, **kwargs)
        record({"event": "reset", **physics(sim)})
        return out

    def traced_plan(*args: Any, **kwargs: Any) -> Any:
        out = plan(*args, **kwargs)
        waypoints, ik_error, gripper_yaw, ok = out
        record(
            {
                "event": "plan",
                "plan_hash": digest(waypoints),
                "ik_error": float(ik_error),
                "ok": bool(ok),
                "gripper_yaw": float(gripper_yaw),
            }
        )
        return out

    def traced_controller(*args: Any, **kwargs: Any) -> Any:
        out = controller(*args, **kwargs)
        record({"event": "pick", "final_hash": digest(out), **physics(sim)})
        return out

    def traced_render(*args: Any, **kwargs: Any) -> Any:
        frame = render(*args, **kwargs)
        record(
            {
                "event": "render",
                "camera": args[0] if args else kwargs.get("camera", "top_down"),
                "frame_hash": digest(frame),
                "state_hash": digest(np.append(sim.data.qpos, sim.data.time)),
                "frame_sum": int(np.asarray(frame, dtype=np.int64).sum()),
            }
        )
        if not machine_gl:
            machine_gl.append(_gl_renderer())
        return frame

    sim.reset, sim.plan, sim._run_controller, sim.render = traced_reset, traced_plan, traced_controller, traced_render
    detector = getattr(env.unwrapped, "detector", None)
    if detector is not None:
        detect = detector.detect

        def traced_detect(rgb: np.ndarray) -> Any:
            found = detect(rgb)
            record(
                {
                    "event": "detect",
                    "input_hash": digest(rgb),
                    "detections": [
                        [float(x) for x in np.ravel(d.box)] + [float(x) for x in np.ravel(d.centre)] for d in found
                    ],
                }
            )
            return found

        detector.detect = traced_detect


machine_gl: list[str] = []


def trace(env_name: str, policy_name: str, episodes: int, first: int, out: Path) -> None:
    """Run ``episodes`` test episodes (from the ``first``-th) of ``policy_name`` and write the trace."""
    import gymnasium as gym

    import gym4real  # noqa: F401  (registers the ids)
    from gym4real.bench.benchmark import protocol, run_episode
    from gym4real.bench.policies import make_policy
    from gym4real.core.registry import load_object

    env_id = ENVS[env_name]
    spec = protocol(env_id)
    env = gym.make(env_id, **spec.env_kwargs)
    policy = make_policy(env_id, policy_name, env)
    plan = load_object(spec.protocol)(dict(spec.env_kwargs))[first : first + episodes]
    lines: list[dict[str, Any]] = []
    where = {"episode": -1, "step": 0}

    def record(item: dict[str, Any]) -> None:
        lines.append({**where, **item})

    instrument(env, record)

    def step_policy(obs: Any) -> Any:
        action = np.asarray(policy(obs))
        record({"event": "act", "obs_hash": digest(obs), "action": [float(x) for x in np.ravel(action)]})
        where["step"] += 1
        return action

    if hasattr(policy, "reset"):
        step_policy.reset = policy.reset  # type: ignore[attr-defined]
    try:
        for k, episode in enumerate(plan):
            where.update(episode=first + k, step=0)
            result = run_episode(env, step_policy, episode["seed"], episode["options"])
            record(
                {
                    "event": "episode",
                    "seed": episode["seed"],
                    "return": float(result["rewards"].sum()),
                    "rewards": [float(r) for r in result["rewards"]],
                    "components": {k2: float(v) for k2, v in sorted(result["components"].items())},
                }
            )
    finally:
        env.close()
    head = {"event": "machine", "env": env_id, "policy": policy_name, **machine(), "gl_renderer": machine_gl[:1]}
    with out.open("w") as f:
        for item in [head, *lines]:
            f.write(json.dumps(item) + "\n")
    returns = [x["return"] for x in lines if x["event"] == "episode"]
    print(f"{out}: {len(lines)} events, returns {returns}")


def _differences(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    keys = sorted(set(a) | set(b))
    out = []
    for k in keys:
        if a.get(k) != b.get(k):
            va, vb = a.get(k), b.get(k)
            if (
                isinstance(va, list)
                and isinstance(vb, list)
                and len(va) == len(vb)
                and all(isinstance(x, float) for x in va + vb)
            ):
                gap = max(abs(x - y) for x, y in zip(va, vb, strict=True))
                out.append(f"{k}: max |difference| {gap:.3g}")
            else:
                out.append(f"{k}: {str(va)[:80]} != {str(vb)[:80]}")
    return out


def diff(path_a: Path, path_b: Path) -> int:
    """Print where two traces first differ; return 1 when they differ, 0 when equal."""
    a = [json.loads(x) for x in path_a.read_text().splitlines()]
    b = [json.loads(x) for x in path_b.read_text().splitlines()]
    for name, head in (("a", a[0]), ("b", b[0])):
        print(f"{name}: {head['cpu']} avx512f={head['avx512f']} openblas={head.get('openblas_core')}")
        print(f"   env={head['env_vars']} gl={head['gl_renderer']}")
    status = 0
    first_by_episode: dict[int, list[str]] = {}
    for x, y in zip(a[1:], b[1:], strict=False):
        if x == y:
            continue
        status = 1
        seen = first_by_episode.setdefault(x["episode"], [])
        if x["event"] not in {t.split()[2] for t in seen}:  # the first difference of each kind of event
            what = "; ".join(_differences(x, y))
            seen.append(f"step {x['step']} {x['event']} ({y['event']}): {what}")
    if len(a) != len(b):
        print(f"traces differ in length: {len(a)} vs {len(b)} lines")
        status = 1
    episodes_a = {x["episode"]: x["return"] for x in a if x["event"] == "episode"}
    episodes_b = {x["episode"]: x["return"] for x in b if x["event"] == "episode"}
    changed = [e for e in episodes_a if episodes_a[e] != episodes_b.get(e)]
    print(f"episodes compared: {len(episodes_a)}; differing: {len(first_by_episode)}; returns differ: {len(changed)}")
    for episode, texts in sorted(first_by_episode.items()):
        print(f"  episode {episode}:")
        for text in texts:
            print(f"    {text}")
    return status


def kernels() -> None:
    """Hash the kinds of product the simulation path uses, through BLAS and without it (run under two settings)."""
    from gym4real.robofeeder.portable_math import dot, norm, solve

    rng = np.random.default_rng(1)
    proj, points = rng.normal(size=(4, 4)), rng.normal(size=(300, 4))
    jac, err = rng.normal(size=(5, 6)), rng.normal(size=5)
    image = rng.integers(0, 256, (300, 300, 3)).astype(np.float32)
    weights = np.array([0.2989, 0.5870, 0.1140], np.float32)
    damped = jac @ jac.T + 0.01 * np.eye(5)
    blas = {
        "points @ proj.T": points @ proj.T,
        "image @ weights": image @ weights,
        "norm (1-D)": np.array([np.linalg.norm(v) for v in points]),
        "jac.T @ solve": jac.T @ np.linalg.solve(damped, err),
    }
    free = {  # gym4real.robofeeder.portable_math, which the simulation path uses
        "points @ proj.T": dot(points, proj.T),
        "image @ weights": dot(image, weights),
        "norm (1-D)": norm(points),
        "jac.T @ solve": dot(jac.T, solve(dot(jac, jac.T) + 0.01 * np.eye(5), err)),
    }
    print(f"openblas core {openblas_core()}")
    for name in blas:
        print(f"  {name:16s} BLAS {digest(blas[name])}  portable_math {digest(free[name])}")


def main() -> int:
    """Command line: ``trace`` or ``diff``."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("trace", help="run test episodes and record every component's output")
    t.add_argument("--env", choices=sorted(ENVS), default="picking-v0")
    t.add_argument("--policy", default="random", help="a baseline name (random, fixed, oracle)")
    t.add_argument("--episodes", type=int, default=5)
    t.add_argument("--first", type=int, default=0, help="index of the first test episode")
    t.add_argument("--out", type=Path, required=True)
    t.add_argument("--opencv-unoptimized", action="store_true", help="cv2.setUseOptimized(False) first")
    sub.add_parser("kernels", help="hash BLAS and portable_math products (compare under two dispatch settings)")
    d = sub.add_parser("diff", help="where two traces first differ")
    d.add_argument("a", type=Path)
    d.add_argument("b", type=Path)
    args = parser.parse_args()
    if args.command == "trace":
        if args.opencv_unoptimized:
            import cv2

            cv2.setUseOptimized(False)
        trace(args.env, args.policy, args.episodes, args.first, args.out)
        return 0
    if args.command == "kernels":
        kernels()
        return 0
    return diff(args.a, args.b)


if __name__ == "__main__":
    raise SystemExit(main())
