"""Training presets, validated by :class:`SB3Preset` or :class:`TabularPreset`.

A preset is a YAML file beside a domain, registered as a ``TrainingSpec`` record, or a user's own file.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from gym4real.bench.seeds import Seeds, preset_source
from gym4real.core.config import describe_validation_error, read_yaml
from gym4real.core.errors import ConfigError
from gym4real.core.registry import env_spec
from gym4real.rl.schedules import SB3_DEFAULT_LEARNING_RATE, LearningRate

ALGOS = ("ppo", "dqn", "qlearning", "sarsa")

Positive = Annotated[int, Field(gt=0)]
Fraction = Annotated[float, Field(ge=0, le=1)]


def _non_finite(value: Any, where: str) -> str | None:
    """The first NaN or infinity in a YAML value (nested lists and mappings), as ``where.key[i]``, or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return where
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        found = _non_finite(item, f"{where}[{key}]" if isinstance(key, int) else f"{where}.{key}")
        if found:
            return found
    return None


class _Preset(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    env_kwargs: dict[str, Any] = Field(default_factory=dict, description="Arguments of the training env.")
    eval_env_kwargs: dict[str, Any] | None = Field(
        None, description="Arguments of the validation env (default: `env_kwargs`)."
    )
    eval_episodes: Positive = Field(5, description="Episodes of each evaluation (consecutive seeds).")
    seeds: Seeds = Field(
        default_factory=list, description="The paper's training seeds: the default seeds of `gym4real reproduce`."
    )
    eval_seed: Annotated[int, Field(ge=0)] = Field(
        10_000,
        description="Seed of the first validation episode (model selection); the block `eval_seed, eval_seed + 1, "
        "...` must be disjoint from the test protocol's seeds.",
    )

    @model_validator(mode="after")
    def _eval_env_defaults_to_training_env(self) -> _Preset:
        if self.eval_env_kwargs is None:
            self.eval_env_kwargs = dict(self.env_kwargs)
        return self


class Hyperparams(BaseModel):
    """Arguments of the SB3 algorithm's constructor; ``learning_rate`` is a number or a schedule.

    Other keys go to the constructor as they are (the trainer checks their names against it).
    """

    model_config = ConfigDict(extra="allow", allow_inf_nan=False)

    learning_rate: LearningRate | None = Field(
        None,
        description="A positive number, or a schedule: `{schedule: constant|linear|cosine|kl_adaptive, initial: ...}` "
        "(see `gym4real.rl.schedules`); default: the algorithm's SB3 default.",
    )


class SB3Preset(_Preset):
    """PPO or DQN from Stable-Baselines3; ``hyperparams`` go to the algorithm's constructor."""

    algo: Literal["ppo", "dqn"]
    total_timesteps: Positive
    n_envs: Positive = 1
    vec_env: Literal["dummy", "subproc"] = Field("dummy", description="SB3 vector env of the `n_envs` copies.")
    normalize_obs: bool = False
    normalize_reward: bool = False
    clip_obs: Annotated[float, Field(gt=0)] = Field(
        10.0, description="VecNormalize clips normalised observations to [-clip_obs, clip_obs] (SB3's default 10)."
    )
    value_scaler: bool = Field(
        False,
        description="PPO only: the value network predicts standardised values, its targets standardised with "
        "running statistics (skrl's RunningStandardScaler as `value_preprocessor`).",
    )
    policy: str = "MlpPolicy"
    policy_kwargs: dict[str, Any] | None = None
    hyperparams: Hyperparams = Field(default_factory=Hyperparams)
    eval_freq: Positive = Field(
        10_000,
        description="Timesteps between evaluations (all envs together: SB3's callbacks count calls of `n_envs` "
        "steps, so a reference `eval_freq` of N calls is N * n_envs timesteps here).",
    )

    @model_validator(mode="after")
    def _finite_algorithm_settings(self) -> SB3Preset:
        for name in ("hyperparams", "policy_kwargs"):
            value = getattr(self, name)
            where = _non_finite(value.model_extra if isinstance(value, Hyperparams) else value, name)
            if where:
                raise ValueError(f"`{where}` is not finite (NaN or infinity); give a finite number")
        return self

    @model_validator(mode="after")
    def _settings_fit_the_algorithm(self) -> SB3Preset:
        if self.value_scaler and self.algo != "ppo":
            algo = self.algo.upper()
            raise ValueError(f"`value_scaler` standardises PPO's value targets; {algo} has none: remove it")
        rate = self.hyperparams.learning_rate
        if rate is None:
            self.hyperparams.learning_rate = SB3_DEFAULT_LEARNING_RATE[self.algo]
        elif self.algo != "ppo" and getattr(rate, "schedule", None) == "kl_adaptive":
            raise ValueError(
                "`hyperparams.learning_rate`: `kl_adaptive` adapts PPO's rate after each epoch of its update, and "
                f"{self.algo.upper()} has no epochs; give a number or a constant, linear or cosine schedule"
            )
        return self


class Epsilon(BaseModel):
    """Epsilon-greedy exploration: ``start``, multiplied by ``decay`` after each episode, floored at ``min``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    start: Fraction
    decay: Annotated[float, Field(gt=0, le=1)]
    min: Fraction


class TabularPreset(_Preset):
    """Q-learning or SARSA on the env's discrete observation grid."""

    algo: Literal["qlearning", "sarsa"]
    episodes: Positive
    alpha: Annotated[float, Field(gt=0, le=1)]
    gamma: Fraction
    epsilon: Epsilon
    eval_every: Positive = Field(description="Episodes between evaluations.")
    patience: Positive = Field(description="Evaluations without an improvement before stopping.")
    min_improvement: Annotated[float, Field(ge=0)] = 0.0


def load_preset(env_id: str, algo: str, preset: str) -> dict[str, Any]:
    """Return the validated settings of a training preset, every field filled in.

    Args:
        env_id: A registered id.
        algo: ``ppo``, ``dqn``, ``qlearning`` or ``sarsa``.
        preset: A registered preset name (``paper``, ``smoke``) or the path of a YAML file with the
            fields of :class:`SB3Preset` or :class:`TabularPreset`.

    Raises:
        ConfigError: No such preset (the message lists the registered ones), an unreadable file, or a
            field that is unknown or out of range (named in the message).
    """
    env_spec(env_id)
    if algo not in ALGOS:
        raise ConfigError(f"algo `{algo}` is not one of {list(ALGOS)}")
    source = preset_source(env_id, algo, preset)
    data = read_yaml(source, "training preset")
    if data.setdefault("algo", algo) != algo:
        raise ConfigError(f"training preset `{source}` says algo `{data['algo']}`, but `{algo}` was asked for")
    schema = SB3Preset if algo in ("ppo", "dqn") else TabularPreset
    try:
        return schema.model_validate(data).model_dump()
    except ValidationError as exc:
        raise ConfigError(
            f"training preset `{source}`: {describe_validation_error(exc, schema.__name__, schema)}"
        ) from None
