"""Policy strings for the benchmark harness: registered baselines, trained models, your own code, callables.

A policy string is one of:

- a baseline name (``longest_first``);
- a model file, read as data (never unpickled): ``ppo:PATH``, ``ppo-jax:PATH`` (the JAX trainer's
  ``model.npz``), ``dqn:PATH``, ``qlearning:PATH``, ``sarsa:PATH``, or ``sb3:ALGO:PATH`` for a
  Stable-Baselines3 model of any algorithm SB3 ships (and of
  sb3-contrib's CrossQ, QRDQN, TQC, TRPO);
- ``module:attr``, your own code, which is imported and run (trust it as you trust a plugin): a
  function or class is a factory ``factory(env) -> policy`` (``factory(env, seed=S)`` when seeds are
  asked for), any other callable object is the policy itself.

A model file inside a results section's ``models/`` folder must have the bytes its ``models.json`` lists
(:func:`gym4real.bench.published.check_published`), else it is refused. Model files are read by the loaders
:data:`MODEL_LOADERS` names, which the training layer
(:mod:`gym4real.rl`) provides: they are imported when a model is asked for, so measurement never imports
training (the architecture's layers).
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym

from gym4real.bench.agent_errors import factory_failure
from gym4real.bench.published import check_published
from gym4real.core.errors import PolicyError
from gym4real.core.registry import base_env, load_object, registry
from gym4real.core.suggest import did_you_mean
from gym4real.wrappers.multi_objective import MultiObjective

#: Prefix of a ``kind:path`` policy string -> ``"module:loader"``; ``loader(env, path)`` returns a policy.
MODEL_LOADERS: dict[str, str] = {
    "ppo": "gym4real.rl.sb3:load_ppo",
    "ppo-jax": "gym4real.rl.actor_critic:load_ppo_jax",
    "dqn": "gym4real.rl.sb3:load_dqn",
    "qlearning": "gym4real.rl.tabular:load_policy",
    "sarsa": "gym4real.rl.tabular:load_policy",
}
#: ``loader(env, path, algo)`` of ``sb3:ALGO:PATH``.
SB3_LOADER = "gym4real.rl.sb3:load_model"

#: Prefix of ``sb3:ALGO:PATH``, a Stable-Baselines3 model of any algorithm it ships.
SB3_KIND = "sb3"

#: ``module:attr`` of the user's own code (dotted names on both sides; a path has ``/`` or ``\\``).
USER_OBJECT = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")

#: The policy strings, for error messages.
POLICY_FORMS = (
    "a baseline name, `ppo:PATH`, `ppo-jax:PATH`, `dqn:PATH`, `qlearning:PATH`, `sarsa:PATH`, `sb3:ALGO:PATH` "
    "(a Stable-Baselines3 model of A2C, DDPG, DQN, PPO, SAC, TD3, or sb3-contrib's CrossQ, QRDQN, TQC, TRPO) or "
    "`module:attr` (your own factory or policy, imported)"
)


def is_user_object(policy: str) -> bool:
    """Whether a policy string names the user's own code (``module:attr``), not a model file or baseline."""
    kind = policy.partition(":")[0]
    return kind not in MODEL_LOADERS and kind != SB3_KIND and bool(USER_OBJECT.match(policy))


def _accepts_seed(factory: Callable[..., Any]) -> bool:
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):  # a builtin without a signature
        return False
    return "seed" in parameters or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values())


def build_policy(
    obj: Any, env: gym.Env[Any, Any], name: str, seed: int | None = None, weights: Sequence[float] | None = None
) -> Callable[[Any], Any]:
    """The policy that a factory or policy object gives for ``env``.

    Args:
        obj: A function or class (a factory, called ``obj(env)``, ``obj(env, seed=seed)`` when ``seed`` is
            given, ``obj(env, weights=weights[, seed=seed])`` when ``weights`` are), or any other callable object
            (the policy itself).
        env: The environment the policy will act in.
        name: How the user named it, for error messages.
        seed: The training seed of the policy asked for (the unit of replication), or None for one policy.
        weights: The weights of a weight-conditioned factory (one per objective), or None.

    Raises:
        PolicyError: Not callable, a factory that raises (its exception in one line, the cause of the error) or
            returns no policy, or a seed asked of what cannot take one.
    """
    if inspect.isfunction(obj) or inspect.ismethod(obj) or isinstance(obj, type):
        if seed is not None and not _accepts_seed(obj):
            raise PolicyError(
                f"`{name}` takes no `seed`, so every seed would be the same policy: give it a `seed` keyword "
                "argument (`def factory(env, seed)`), or evaluate one seed"
            )
        given: dict[str, Any] = {} if weights is None else {"weights": tuple(weights)}
        if seed is not None:
            given["seed"] = seed
        try:
            built = obj(env, **given)
        except (Exception, SystemExit) as exc:
            called = ", ".join(["env", *(f"{k}={v!r}" for k, v in given.items())])
            raise factory_failure(name, exc, f"factory({called})") from exc
        if not callable(built):
            raise PolicyError(
                f"`{name}` returned {type(built).__name__}, not a policy; fix: a function or class given as a policy "
                "is a factory `factory(env) -> policy` that returns a callable `policy(obs) -> action` (for a plain "
                "`obs -> action` function `act`, pass `lambda env: act`)"
            )
        return built
    if not callable(obj):
        raise PolicyError(
            f"`{name}` is a {type(obj).__name__}, not a policy or a factory of policies; fix: name a factory "
            "`factory(env) -> policy` or a callable `policy(obs) -> action`"
        )
    if seed is not None:
        raise PolicyError(
            f"`{name}` is one policy object, so it cannot be several seeds: give a factory `factory(env, seed)` "
            "instead, or evaluate one seed"
        )
    policy: Callable[[Any], Any] = obj
    return policy


def _user_object(policy: str) -> Any:
    """Import ``module:attr`` (the user's own code: it runs) and return what it names.

    Raises:
        PolicyError: The module or attribute cannot be imported.
    """
    try:
        return load_object(policy)
    except ImportError as exc:
        kind = policy.partition(":")[0]  # `ppp:model.zip`: a mistyped kind of model file, more likely than a module
        hint = did_you_mean(kind, [*MODEL_LOADERS, SB3_KIND]) if getattr(exc, "name", None) == kind else ""
        raise PolicyError(
            f"cannot import `{policy}`: {exc}; `module:attr` names your own code, whose module must be importable "
            f"(installed, on PYTHONPATH or in the working folder).{hint} Policy strings: {POLICY_FORMS}"
        ) from exc
    except AttributeError as exc:
        raise PolicyError(f"cannot find `{policy}`: {exc}") from exc


def user_policy(policy: str, env: gym.Env[Any, Any], seed: int | None = None) -> Callable[[Any], Any]:
    """Import ``module:attr`` (the user's own code: it runs) and build its policy for ``env``.

    Raises:
        PolicyError: The module or attribute cannot be imported, or what it names is no policy (see
            :func:`build_policy`).
    """
    return build_policy(_user_object(policy), env, policy, seed)


def _model_file(policy: str) -> tuple[str, str, str | None]:
    """``(loader, path, algo)`` of a model file ``kind:path`` (``algo`` for ``sb3:ALGO:PATH``, else None).

    Raises:
        PolicyError: An unknown kind (the nearest named), ``sb3:`` without ``ALGO:PATH``, or a missing file.
    """
    kind, _, path = policy.partition(":")
    algo = None
    if kind == SB3_KIND:
        algo, _, path = path.partition(":")
        if not path:
            raise PolicyError(f"`{policy}` must be `sb3:ALGO:PATH` (`sb3:a2c:runs/model.zip`)")
    elif kind not in MODEL_LOADERS:
        hint = did_you_mean(kind, [*MODEL_LOADERS, SB3_KIND])
        raise PolicyError(f"unknown policy kind `{kind}` in `{policy}`.{hint} Expected {POLICY_FORMS}")
    if not Path(path).is_file():
        raise PolicyError(f"policy file `{path}` (from `{policy}`) does not exist")
    return (SB3_LOADER if algo is not None else MODEL_LOADERS[kind]), path, algo


def _baseline(env_id: str, policy: str) -> str:
    """The entry point of the baseline ``policy`` of ``env_id`` (a vector-reward variant: its env's).

    Raises:
        PolicyError: No such baseline (the nearest names suggested).
    """
    baselines = registry().baselines.get(base_env(env_id), {})
    if policy not in baselines:
        raise PolicyError(
            f"unknown policy `{policy}` for `{env_id}`.{did_you_mean(policy, baselines)} Baselines: "
            f"{', '.join(sorted(baselines)) or 'none'}; or {POLICY_FORMS}"
        )
    return baselines[policy].entry_point


def check_policy(env_id: str, policy: str | Callable[..., Any]) -> None:
    """Refuse, before any episode runs, a policy string that names no policy of ``env_id``.

    A baseline must be registered (the nearest names are suggested), a model file must exist, and a
    ``module:attr`` must import (its module runs); a callable is accepted as it is.

    Raises:
        PolicyError: The policy string and what is wrong with it.
    """
    if callable(policy):
        return
    if is_user_object(policy):
        _user_object(policy)
    elif ":" in policy:
        _model_file(policy)
    else:
        _baseline(env_id, policy)


def make_policy(env_id: str, policy: str | Callable[[Any], Any], env: gym.Env[Any, Any]) -> Callable[[Any], Any]:
    """Turn a policy reference into a callable policy.

    Args:
        env_id: The environment's id (baselines are looked up under it; a vector-reward variant such as
            ``gym4real/dam-mo-v0`` uses the baselines of the env it wraps).
        policy: A baseline name (``longest_first``), a trained model as ``kind:path``
            (``ppo:runs/dam/model.zip``, ``qlearning:runs/elevator/qtable.npz``, ``sb3:a2c:model.zip``), your
            own ``module:attr`` (imported: see the module's docstring), or a callable.
        env: The environment the policy will act in.

    Raises:
        PolicyError: An unknown name or kind, a model file that does not fit the environment, or a
            ``module:attr`` that cannot be imported or gives no policy.
    """
    if callable(policy):
        return policy
    if isinstance(env.unwrapped, MultiObjective):  # same spaces; a baseline may read the env it acts in
        env = env.unwrapped.env
    if is_user_object(policy):
        return user_policy(policy, env)
    if ":" in policy:
        loader, path, algo = _model_file(policy)
        check_published(path)  # a published model of a results folder: its bytes must be the listed ones
        from_file: Callable[[Any], Any] = (
            load_object(loader)(env, path) if algo is None else load_object(loader)(env, path, algo.lower())
        )
        return from_file
    built: Callable[[Any], Any] = load_object(_baseline(env_id, policy))(env)
    return built
