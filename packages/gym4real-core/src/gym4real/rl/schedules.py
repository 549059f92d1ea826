"""Learning-rate schedules of the training presets: a number, or a mapping naming its ``schedule``.

``learning_rate: 5.0e-5`` is a constant rate; ``learning_rate: {schedule: cosine, initial: 5.0e-5}`` anneals
it. Each schedule is a validated model (finite, positive, unknown keys refused) and a Stable-Baselines3
schedule: called with the progress remaining (1 at the start of training, 0 at its end), it returns the rate.
:func:`learning_rate_words` is the one way a rate is written in reports (``cosine(5e-05->0)``).

``kl_adaptive`` is skrl's ``KLAdaptiveLR`` (the scheduler of the paper's dam PPO): after each epoch of PPO's
update, the rate is divided by ``factor`` when the epoch's mean KL exceeds ``kl_factor * kl_threshold``,
multiplied by it when the KL is below ``kl_threshold / kl_factor``, and kept within ``[min, max]``. Its rate
depends on the training's history, not on the progress: :class:`KLAdaptiveRate` holds it.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, TypeAdapter, model_validator

PositiveFloat = Annotated[float, Field(gt=0)]

#: Learning rates of Stable-Baselines3's constructors when a preset gives none (checked against SB3 in the tests).
SB3_DEFAULT_LEARNING_RATE = {"ppo": 3e-4, "dqn": 1e-4}


def _number(value: float) -> str:
    return f"{value:g}"


class _Schedule(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    initial: PositiveFloat = Field(description="Rate at the start of training.")

    @abstractmethod
    def __call__(self, progress_remaining: float) -> float:
        """The rate when ``progress_remaining`` of the training is left (1 at the start, 0 at the end)."""

    @abstractmethod
    def describe(self) -> str:
        """The schedule in words, as runs.csv and the results page print it."""


class Constant(_Schedule):
    """The same rate throughout."""

    schedule: Literal["constant"]

    def __call__(self, progress_remaining: float) -> float:
        """The rate when ``progress_remaining`` of the training is left (1 at the start, 0 at the end)."""
        return self.initial

    def describe(self) -> str:
        """``constant(RATE)``."""
        return f"constant({_number(self.initial)})"


class _Annealed(_Schedule):
    final: Annotated[float, Field(ge=0)] = Field(0.0, description="Rate at the end of training.")

    @model_validator(mode="after")
    def _final_not_above_initial(self) -> _Annealed:
        if self.final > self.initial:
            raise ValueError(
                f"`final` ({self.final:g}) is above `initial` ({self.initial:g}); an annealed rate decreases: "
                "swap them or use `schedule: constant`"
            )
        return self

    def describe(self) -> str:
        """``KIND(INITIAL->FINAL)``."""
        return f"{self.schedule}({_number(self.initial)}->{_number(self.final)})"  # type: ignore[attr-defined]


class Linear(_Annealed):
    """From ``initial`` to ``final`` linearly in the training's timesteps."""

    schedule: Literal["linear"]

    def __call__(self, progress_remaining: float) -> float:
        """The rate when ``progress_remaining`` of the training is left (1 at the start, 0 at the end)."""
        return self.final + (self.initial - self.final) * progress_remaining


class Cosine(_Annealed):
    """Cosine annealing from ``initial`` to ``final``: ``final + (initial - final) (1 + cos(pi t)) / 2``.

    ``t`` is the fraction of the training done; with ``final: 0`` this is the reference microgrid script's
    ``initial * 0.5 * (1 + cos(pi * step / total))``.
    """

    schedule: Literal["cosine"]

    def __call__(self, progress_remaining: float) -> float:
        """The rate when ``progress_remaining`` of the training is left (1 at the start, 0 at the end)."""
        done = 1.0 - progress_remaining
        return self.final + (self.initial - self.final) * 0.5 * (1.0 + math.cos(math.pi * done))


class KLAdaptive(_Schedule):
    """skrl's ``KLAdaptiveLR`` (defaults are skrl 1.4.3's): PPO only, adapted after each epoch of an update."""

    schedule: Literal["kl_adaptive"]
    kl_threshold: PositiveFloat = Field(0.008, description="KL divergence the rate is adapted around.")
    kl_factor: Annotated[float, Field(gt=1)] = Field(
        2.0, description="Band around the threshold: adapt above `kl_threshold * kl_factor` or below `/ kl_factor`."
    )
    factor: Annotated[float, Field(gt=1)] = Field(1.5, description="The rate is multiplied or divided by it.")
    min: PositiveFloat = Field(1e-6, description="Lowest rate.")
    max: PositiveFloat = Field(1e-2, description="Highest rate.")

    @model_validator(mode="after")
    def _initial_within_bounds(self) -> KLAdaptive:
        if not self.min <= self.initial <= self.max:
            raise ValueError(
                f"`initial` ({self.initial:g}) is outside [`min`, `max`] = [{self.min:g}, {self.max:g}]; "
                "widen the bounds or change the rate"
            )
        return self

    def __call__(self, progress_remaining: float) -> float:
        """The starting rate: the running rate lives in :class:`KLAdaptiveRate`."""
        return self.initial

    def next_rate(self, rate: float, kl: float) -> float:
        """The rate after an epoch whose mean KL divergence was ``kl`` (skrl's ``KLAdaptiveLR.step``)."""
        if kl > self.kl_threshold * self.kl_factor:
            return max(rate / self.factor, self.min)
        if kl < self.kl_threshold / self.kl_factor:
            return min(rate * self.factor, self.max)
        return rate

    def describe(self) -> str:
        """``kl_adaptive(INITIAL, kl_threshold=T)``, with the other settings where they differ from skrl's."""
        words = [_number(self.initial), f"kl_threshold={_number(self.kl_threshold)}"]
        defaults = KLAdaptive.model_fields
        for name in ("kl_factor", "factor", "min", "max"):
            if getattr(self, name) != defaults[name].default:
                words.append(f"{name}={_number(getattr(self, name))}")
        return f"kl_adaptive({', '.join(words)})"


class KLAdaptiveRate:
    """The running rate of a ``kl_adaptive`` schedule, as SB3 calls a schedule (the progress is ignored)."""

    def __init__(self, spec: KLAdaptive, rate: float | None = None) -> None:
        """Start at ``rate`` (a resumed run's saved rate), else at the schedule's initial rate."""
        self.spec = spec
        self.rate = spec.initial if rate is None else float(rate)

    def __call__(self, progress_remaining: float) -> float:
        """The current rate."""
        return self.rate

    def update(self, kl: float) -> float:
        """Adapt the rate to an epoch's mean KL divergence; return the new rate."""
        self.rate = self.spec.next_rate(self.rate, kl)
        return self.rate


Schedule = Constant | Linear | Cosine | KLAdaptive

_SCHEDULES = {"constant", "linear", "cosine", "kl_adaptive"}


def _kind(value: Any) -> str | None:
    if isinstance(value, dict):
        kind = value.get("schedule")
        return kind if kind in _SCHEDULES else None
    if isinstance(value, _Schedule):
        return value.schedule  # type: ignore[attr-defined,no-any-return]
    return None if isinstance(value, bool) else "number" if isinstance(value, (int, float)) else None


#: A preset's ``learning_rate``: a positive number (constant) or a schedule's mapping.
LearningRate = Annotated[
    Annotated[PositiveFloat, Tag("number")]
    | Annotated[Constant, Tag("constant")]
    | Annotated[Linear, Tag("linear")]
    | Annotated[Cosine, Tag("cosine")]
    | Annotated[KLAdaptive, Tag("kl_adaptive")],
    Discriminator(
        _kind,
        custom_error_type="learning_rate",
        custom_error_message="expected a positive number or a mapping with `schedule` one of "
        "constant, linear, cosine, kl_adaptive",
    ),
]


_LEARNING_RATE: TypeAdapter[float | Schedule] = TypeAdapter(LearningRate)


def schedule(value: float | dict[str, Any]) -> Schedule:
    """The schedule of a ``learning_rate`` (a number is a constant rate).

    Raises:
        pydantic.ValidationError: Not a positive number nor a valid schedule mapping.
    """
    parsed = _LEARNING_RATE.validate_python(value)
    return parsed if isinstance(parsed, _Schedule) else Constant(schedule="constant", initial=parsed)


def learning_rate_words(hp: dict[str, Any]) -> str:
    """A resolved preset's learning rate in words: ``constant(0.001)``, ``cosine(5e-05->0)``, ...

    The rate of a tabular preset is its ``alpha``.
    """
    if "alpha" in hp:
        return schedule(float(hp["alpha"])).describe()
    return schedule(hp["hyperparams"]["learning_rate"]).describe()
