"""The RoboFeeder planning environment: choose which detected object the picking agent grasps next."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from gym4real.core.actions import DiscreteAction
from gym4real.core.datasets import resolve
from gym4real.core.errors import PolicyError
from gym4real.robofeeder._plugin import PICKING_AGENT
from gym4real.robofeeder.config import PlanningConfig
from gym4real.robofeeder.env import RoboFeederBaseEnv
from gym4real.robofeeder.portable_math import norm
from gym4real.robofeeder.reward import reference_orientation_ok

PickingPolicy = Callable[[np.ndarray], np.ndarray]


class RoboFeederPlanningEnv(RoboFeederBaseEnv):
    """RoboFeeder planning-v0: decide the picking order; a low-level picking agent grasps.

    ## Description

    The cell of the picking environments with ``n_objects`` (3) hinges. The observation holds N crops
    of detected objects; the agent picks one (a low-level picking policy, by default the reference's
    pretrained ONNX agent, chooses the grasp point and angle in that crop) or idles.

    ## Action Space

    ``Discrete(N + 1)``: 0 = idle (ends the episode), k = pick the object of crop k.

    ## Observation Space

    ``Box(0, 1, (N, 50, 50), float32)``: crops of up to N detections in random order (all zero when
    fewer objects are detected), grayscale in [0, 1].

    ## Rewards

    +1 for a successful pick, -1 for a failed one (an empty crop or an unfeasible target too, which
    also sets ``info["cost"] = 1``); idle: minus the number of graspable objects left (corrected: flat,
    reachable and in a yaw the gripper can take; upstream: the reference's slipped-quaternion check).
    ``info["reward_components"]`` = {"picked", "failed", "idle"}.

    ## Starting State

    As the picking environments, with ``n_objects`` = 3.

    ## Episode End

    Terminated by the idle action; truncated after T = 5 steps (picking every object does not end it).

    ## Arguments

    ``config`` / ``preset`` ("default", "test"; formerly "planning", "planning_test") / keyword overrides
    of :class:`PlanningConfig`;
    ``picking_policy``: any callable crop (1, 50, 50) -> (dx, dy, theta~) replacing the pretrained agent;
    ``render_mode="rgb_array"``. The corrected mode (see the picking envs) also runs the pretrained agent
    deterministically (its mean; ``agent_mode``) and clips its actions (``clip_agent_actions``); the
    reference samples inside the ONNX graph from onnxruntime's global generator and does not clip.

    ## Version History

    * v0: Gym4ReaL 1.0 reference (registered there as ``gym4real/robofeeder-planning``), on MuJoCo 4.
    """

    config_class = PlanningConfig
    config: PlanningConfig
    reward_component_names = ("picked", "failed", "idle")

    def __init__(
        self,
        config: PlanningConfig | Mapping[str, Any] | str | Path | None = None,
        *,
        preset: str | None = None,
        render_mode: str | None = None,
        picking_policy: PickingPolicy | None = None,
        **overrides: Any,
    ) -> None:
        super().__init__(config, preset=preset, render_mode=render_mode, **overrides)
        self._init_args = (config, preset, render_mode, {**overrides, "picking_policy": picking_policy})
        cfg = self.config
        self.n_crops = cfg.n_crops
        self.action_space = spaces.Discrete(self.n_crops + 1)
        self._action = DiscreteAction(self.action_space, f"0 (idle) or the crop 1..{self.n_crops} to pick from")
        self.observation_space = spaces.Box(0.0, 1.0, (self.n_crops, self.crop_size, self.crop_size), np.float32)
        self.picking_policy = picking_policy
        self._agent: Any = None
        if picking_policy is None and cfg.picking_agent != "oracle":
            self._agent = self._load_agent()
        self._centres = np.zeros((self.n_crops, 2))
        self._filled = np.zeros(self.n_crops, dtype=bool)
        self._obs = np.zeros(self.observation_space.shape, np.float32)

    def _load_agent(self) -> Any:
        from gym4real.robofeeder.agents import OnnxPickingAgent

        cfg = self.config
        corrected = cfg.fidelity == "corrected"
        mode = cfg.agent_mode or ("mean" if corrected else "sample")
        clip = corrected if cfg.clip_agent_actions is None else cfg.clip_agent_actions
        path = resolve(PICKING_AGENT, cfg.data_dir) if cfg.picking_agent == "pretrained" else Path(cfg.picking_agent)
        return OnnxPickingAgent(path, mode=mode, clip=clip)

    # ------------------------------------------------------------------ observation
    def _observe(self) -> np.ndarray:
        frame = self._observe_frame()
        detections = self.detector.detect(frame)
        if self.config.fidelity == "upstream":  # the reference takes the top N - picked boxes, whatever they are
            detections = detections[: max(self.sim.n - int(self.sim.picked.sum()), 0)]
        crops = np.zeros((self.n_crops, self.crop_size, self.crop_size), np.float32)
        centres = np.zeros((self.n_crops, 2))
        filled = np.zeros(self.n_crops, dtype=bool)
        for k, det in enumerate(detections[: self.n_crops]):
            crops[k], centres[k] = self._crop(frame, det)
            filled[k] = True
        order = self.np_random.permutation(self.n_crops)  # the reference shuffles the slots at every build
        self._obs, self._centres, self._filled = crops[order], centres[order], filled[order]
        return self._obs.copy()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Spawn the objects and observe.

        Args:
            seed: Seeds ``np_random`` (positions, orientations, slot order, sampling agent).
            options: ``placements`` / ``yaws`` as for the picking environments.
        """
        super().reset(seed=seed)
        options = options or {}
        self._frames = []
        placements, yaws = options.get("placements"), options.get("yaws")
        self.sim.reset(
            self.np_random,
            placements=None if placements is None else np.asarray(placements, float),
            yaws=None if yaws is None else np.asarray(yaws, float),
            graspable_only=self.config.fix("graspable_spawn"),
        )
        self._steps = 0
        obs = self._observe()
        return obs, {"objects_left": self.sim.n, "graspable": self.count_graspable()}

    # ------------------------------------------------------------------ step
    def count_graspable(self) -> int:
        """Objects left that the idle action is charged for."""
        if self.config.fix("grasp_angle"):
            return sum(self.graspable(i) for i in range(self.sim.n))
        quats = self.sim.object_quats()
        return sum(bool(not self.sim.picked[i] and reference_orientation_ok(quats[i])) for i in range(self.sim.n))

    def _low_level(self, slot: int) -> np.ndarray:
        crop = self._obs[slot][None]
        if self.picking_policy is not None:
            action = np.asarray(self.picking_policy(crop), dtype=np.float64).reshape(-1)
        elif self._agent is not None:
            action = np.asarray(self._agent(crop, self.np_random), dtype=np.float64).reshape(-1)
        else:
            action = self._oracle_pick(slot)
        if action.shape != (3,) or not np.all(np.isfinite(action)):
            raise PolicyError(f"the picking policy must return 3 finite numbers, got {action.tolist()}")
        return action

    def _oracle_pick(self, slot: int) -> np.ndarray:
        grasp = self.oracle_grasp(self._centres[slot])
        if grasp is None:
            return np.zeros(3)
        pixel, theta = grasp
        offset = (pixel - self._centres[slot]) / (self.crop_size / 2.0)
        return np.clip(np.append(offset, theta / (np.pi / 2.0) - 1.0), -1.0, 1.0)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Idle (0) or let the picking agent grasp the object of crop ``action``."""
        a = self._action(action)
        comps = dict.fromkeys(self.reward_component_names, 0.0)
        info: dict[str, Any] = {
            "success": False,
            "feasible": True,
            "cost": 0.0,
            "target_world": np.zeros(3),
            "target_pixel": np.zeros(2),
            "theta": 0.0,
            "agent_action": np.zeros(3, np.float32),
            "slot": a,
        }
        terminated = False
        if a == 0:
            comps["idle"] = -float(self.count_graspable())
            terminated = True
            obs = self._obs.copy()  # the reference does not refresh the observation
            if self.render_mode == "rgb_array_list":  # the step's one frame: nothing moved
                self._frames.append(self._view())
        else:
            slot = a - 1
            if not self._filled[slot] and self.config.fix("unfeasible_targets"):
                comps["failed"] = -1.0
                info.update(feasible=False, cost=1.0)
            else:
                low = self._low_level(slot)
                pixel = self._centres[slot] + low[:2] * (self.crop_size / 2.0)
                theta = (low[2] + 1.0) * np.pi / 2.0
                outcome = self._pick(self.sim.camera.pixel_to_world(pixel), theta, pixel)
                comps["picked" if outcome.success else "failed"] = 1.0 if outcome.success else -1.0
                info.update(
                    success=outcome.success,
                    feasible=outcome.feasible,
                    cost=0.0 if outcome.feasible else 1.0,
                    target_world=outcome.target.copy(),
                    theta=outcome.theta,
                    target_pixel=pixel,
                    agent_action=low.astype(np.float32),
                )
            obs = self._observe()
        self._steps += 1
        truncated = bool(self._steps >= self.max_steps and not terminated)
        info.update(
            reward_components=comps,
            objects_picked=int(self.sim.picked.sum()),
            objects_left=int((~self.sim.picked).sum()),
            graspable=self.count_graspable(),
        )
        return obs, float(sum(comps.values())), terminated, truncated, info

    # ------------------------------------------------------------------ oracle
    def oracle_action(self) -> int:
        """A crop holding a graspable object (the one nearest its crop centre), else idle."""
        left = [i for i in range(self.sim.n) if self.graspable(i)]
        if not left:
            return 0
        sites = self.sim.site_positions()
        best, best_d = 0, np.inf
        for slot in np.flatnonzero(self._filled):
            centre_xy = self.sim.camera.pixel_to_world(self._centres[slot])
            for i in left:
                d = float(norm(sites[i, :2] - centre_xy))
                if d < best_d:
                    best, best_d = int(slot) + 1, d
        return best
