"""Real-world challenge layers for every environment, with presets ``easy``, ``medium`` and ``hard``.

Action persistence, observation noise and delay, action delay and sensor dropout apply to every env;
exogenous perturbation of the domain's parameters to the envs that declare ``perturbable`` ones.

Each layer draws its randomness from the wrapper's ``np_random``, seeded from ``reset(seed=)``, so a
challenged env stays reproducible. Observation layers act on ``Box`` observations (or the ``Box`` items
of a ``Dict``); discrete parts are left as they are.
"""

from __future__ import annotations

from collections import deque
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces


def _box_items(space: spaces.Space[Any]) -> list[str | None]:
    if isinstance(space, spaces.Box):
        return [None]
    if isinstance(space, spaces.Dict):
        return [k for k, s in space.spaces.items() if isinstance(s, spaces.Box)]
    return []


class _Seeded(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    """A layer with its own generator, re-seeded from ``reset(seed=)`` (offset from the env's stream)."""

    def __init__(self, env: gym.Env[Any, Any], **kwargs: Any) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, **kwargs)
        gym.Wrapper.__init__(self, env)
        self.rng = np.random.default_rng()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if seed is not None:
            self.rng = np.random.default_rng([seed, 7919])
        return self.env.reset(seed=seed, options=options)


class ActionPersistence(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    """Hold each action for ``k`` steps (frequency adaptation); rewards and components are summed."""

    def __init__(self, env: gym.Env[Any, Any], k: int) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, k=k)
        gym.Wrapper.__init__(self, env)
        if k < 1:
            raise ValueError(f"`k` must be at least 1, not {k}")
        self.k = k

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Apply ``action`` for up to ``k`` steps."""
        total, cost = 0.0, 0.0
        comps: dict[str, float] = {}
        for _ in range(self.k):
            obs, reward, terminated, truncated, info = self.env.step(action)
            total += float(reward)
            for name, value in info.get("reward_components", {}).items():
                comps[name] = comps.get(name, 0.0) + value
            cost += float(info.get("cost", 0.0))
            if terminated or truncated:
                break
        info = {**info, "reward_components": comps, "cost": cost}
        return obs, total, terminated, truncated, info


class ObservationNoise(_Seeded):
    """Gaussian noise on ``Box`` observations, ``std = scale * (high - low)`` (or ``scale`` where unbounded)."""

    def __init__(self, env: gym.Env[Any, Any], scale: float) -> None:
        super().__init__(env, scale=scale)
        self.scale = scale
        self.items = _box_items(env.observation_space)

    def _noisy(self, obs: Any) -> Any:
        if not self.scale:
            return obs
        out = dict(obs) if isinstance(obs, dict) else obs
        for key in self.items:
            space: Any = self.observation_space if key is None else self.observation_space[key]  # type: ignore[index]
            span = np.where(np.isfinite(space.high - space.low), space.high - space.low, 1.0)
            value: Any = out if key is None else out[key]
            noisy = value + self.rng.normal(0.0, self.scale * span, size=np.shape(value))
            noisy = np.clip(noisy, space.low, space.high).astype(space.dtype)  # stay in the declared space
            if key is None:
                out = noisy
            else:
                out[key] = noisy
        return out

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset; the first observation is noisy too."""
        obs, info = super().reset(seed=seed, options=options)
        return self._noisy(obs), info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step; the observation is noisy."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._noisy(obs), reward, terminated, truncated, info


class ObservationDelay(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    """The agent sees the observation of ``d`` steps ago (the first observation until then)."""

    def __init__(self, env: gym.Env[Any, Any], d: int) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, d=d)
        gym.Wrapper.__init__(self, env)
        self.d = d
        self._buffer: deque[Any] = deque(maxlen=d + 1)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset and fill the delay line with the first observation."""
        obs, info = self.env.reset(seed=seed, options=options)
        self._buffer.clear()
        self._buffer.extend([obs] * (self.d + 1))
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step; return the observation of ``d`` steps ago."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._buffer.append(obs)
        return self._buffer[0], reward, terminated, truncated, info


class ActionDelay(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    """The env applies the action chosen ``d`` steps ago; until then, the first action of the episode."""

    def __init__(self, env: gym.Env[Any, Any], d: int) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, d=d)
        gym.Wrapper.__init__(self, env)
        self.d = d
        self._pending: deque[Any] = deque()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset and empty the action queue."""
        self._pending.clear()
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Queue ``action``; apply the one chosen ``d`` steps ago."""
        if not self._pending:
            self._pending.extend([action] * self.d)
        self._pending.append(action)
        return self.env.step(self._pending.popleft())


class SensorDropout(_Seeded):
    """Each ``Box`` observation entry is lost with probability ``p``: NaN, or its last delivered value."""

    def __init__(self, env: gym.Env[Any, Any], p: float, mode: str = "last") -> None:
        super().__init__(env, p=p, mode=mode)
        if mode not in ("nan", "last"):
            raise ValueError(f"`mode` must be 'nan' or 'last', not {mode!r}")
        self.p, self.mode = p, mode
        self.items = _box_items(env.observation_space)
        self._last: dict[str | None, np.ndarray] = {}
        if mode == "nan":  # NaN is outside every Box: declare the space unbounded where entries may drop
            self.observation_space = _unbounded(env.observation_space, self.items)

    def _drop(self, obs: Any, first: bool) -> Any:
        out = dict(obs) if isinstance(obs, dict) else obs
        for key in self.items:
            value = np.array(out if key is None else out[key], dtype=float if self.mode == "nan" else None)
            if not first and self.p:
                lost = self.rng.random(value.shape) < self.p
                value[lost] = np.nan if self.mode == "nan" else self._last[key][lost]
            self._last[key] = value.copy()
            if key is None:
                out = value
            else:
                out[key] = value
        return out

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Reset; the first observation is complete."""
        obs, info = super().reset(seed=seed, options=options)
        return self._drop(obs, first=True), info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step; some entries are lost."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._drop(obs, first=False), reward, terminated, truncated, info


class ExogenousPerturbation(_Seeded):
    """Domain parameters drawn anew each episode: ``scale = 1 + strength * U(-1, 1)`` per parameter.

    The parameters are those the env lists in ``perturbable`` (dam lake surface and inflow, microgrid
    battery capacity, prices, demand and PV, wds pump curves and demand, trading price shocks and fees);
    the env applies them through its ``perturb(scales)`` before the reset, as multiples of the nominal
    values. ``info["perturbation"]`` holds the scales.
    """

    def __init__(self, env: gym.Env[Any, Any], strength: float) -> None:
        super().__init__(env, strength=strength)
        names = getattr(env.unwrapped, "perturbable", ())
        if not names:
            raise ValueError(f"{env.unwrapped.__class__.__name__} declares no `perturbable` parameters")
        if not 0 <= strength < 1:
            raise ValueError(f"`strength` must be in [0, 1), not {strength}")
        self.names, self.strength = tuple(names), strength

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Draw and apply this episode's parameters, then reset."""
        if seed is not None:
            self.rng = np.random.default_rng([seed, 7919])
        scales = {n: float(1 + self.strength * self.rng.uniform(-1, 1)) for n in self.names}
        self.env.unwrapped.perturb(scales)  # type: ignore[attr-defined]
        obs, info = self.env.reset(seed=seed, options=options)
        return obs, {**info, "perturbation": scales}


def _unbounded(space: spaces.Space[Any], items: list[str | None]) -> spaces.Space[Any]:
    def box(s: spaces.Box) -> spaces.Box:
        return spaces.Box(-np.inf, np.inf, shape=s.shape, dtype=np.float64)

    if isinstance(space, spaces.Box):
        return box(space)
    assert isinstance(space, spaces.Dict)
    return spaces.Dict({k: box(s) if k in items else s for k, s in space.spaces.items()})  # type: ignore[arg-type]


#: Preset strengths of the challenge layers.
LEVELS: dict[str, dict[str, float]] = {
    "easy": {"persistence": 1, "noise": 0.01, "obs_delay": 0, "action_delay": 0, "dropout": 0.0, "perturbation": 0.02},
    "medium": {
        "persistence": 2,
        "noise": 0.03,
        "obs_delay": 1,
        "action_delay": 0,
        "dropout": 0.01,
        "perturbation": 0.05,
    },
    "hard": {"persistence": 4, "noise": 0.1, "obs_delay": 2, "action_delay": 1, "dropout": 0.05, "perturbation": 0.1},
}


def challenge(env: gym.Env[Any, Any], level: str = "medium", **overrides: float) -> gym.Env[Any, Any]:
    """Wrap ``env`` with every challenge layer at a preset strength (``easy``, ``medium``, ``hard``).

    Args:
        env: Any Gym4ReaL environment.
        level: Preset name.
        **overrides: Replace preset values (``persistence``, ``noise``, ``obs_delay``, ``action_delay``,
            ``dropout``, ``perturbation``; the last applies to envs that declare ``perturbable`` parameters).
    """
    if level not in LEVELS:
        raise ValueError(f"unknown challenge level `{level}`; expected one of {sorted(LEVELS)}")
    unknown = set(overrides) - set(LEVELS[level])
    if unknown:
        raise ValueError(f"unknown challenge settings {sorted(unknown)}; expected {sorted(LEVELS[level])}")
    cfg = {**LEVELS[level], **overrides}
    perturbable: tuple[str, ...] = tuple(getattr(env.unwrapped, "perturbable", ()))
    if cfg["perturbation"] and perturbable:
        env = ExogenousPerturbation(env, float(cfg["perturbation"]))
    if cfg["action_delay"]:
        env = ActionDelay(env, int(cfg["action_delay"]))
    if cfg["persistence"] > 1:
        env = ActionPersistence(env, int(cfg["persistence"]))
    if cfg["noise"]:
        env = ObservationNoise(env, float(cfg["noise"]))
    if cfg["dropout"]:
        env = SensorDropout(env, float(cfg["dropout"]), mode="last")
    if cfg["obs_delay"]:
        env = ObservationDelay(env, int(cfg["obs_delay"]))
    return env
