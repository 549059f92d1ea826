"""The exceptions raised by Gym4ReaL. Every message says what went wrong and how to fix it."""

from __future__ import annotations


class Gym4RealError(Exception):
    """Base class of every error raised by Gym4ReaL.

    ``exit_status`` is the exit status of the ``gym4real`` command that stops on the error: 2, unless a
    subclass documents its own (``gym4real reproduce --check``'s outcomes).
    """

    exit_status = 2


class ConfigError(Gym4RealError, ValueError):
    """A configuration value, preset name or keyword override is invalid."""


class ActionError(Gym4RealError, ValueError):
    """An action passed to ``step`` is not in the environment's action space."""


class DataFileError(Gym4RealError, FileNotFoundError):
    """A data file is missing, corrupt or malformed."""


class DataUnreachableError(DataFileError):
    """A data file is missing here and its upstream host cannot be reached (name resolution or connection).

    Args:
        message: What is missing, where it was searched and the fix.
        host: The host that could not be reached.
        cause: Why, in one word (``NameResolutionError``, ``NewConnectionError``...).
    """

    def __init__(self, message: str, host: str, cause: str) -> None:
        super().__init__(message)
        self.host = host
        self.cause = cause


class PluginLoadError(Gym4RealError, ImportError):
    """One or more ``gym4real.plugins`` entry points failed to load or to register."""


class MissingDependencyError(Gym4RealError, ImportError):
    """A library that an installed distribution needs is not installed; the message names the ``pip install``."""


class EnvUnavailableError(Gym4RealError, LookupError):
    """An environment id is unknown, or its plugin is not installed or failed to load."""


class PolicyError(Gym4RealError, ValueError):
    """A policy name, model file or policy output is invalid for the environment."""


class ReferenceMismatchError(Gym4RealError, ValueError):
    """A domain's reference runs were measured on another protocol than the installed environment's."""
