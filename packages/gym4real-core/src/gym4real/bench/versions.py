"""Which code measured a result: the commit of this checkout and the versions of what it depends on."""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

#: The code version of a copy that is not a git checkout (wheels built from a commit and installed on a
#: remote worker), as its launcher states it; a git checkout's own ``git describe`` always wins.
CODE_VERSION_ENV = "GYM4REAL_CODE_VERSION"


def git_version() -> str | None:
    """The commit of the code: ``git describe --always --dirty`` of its checkout, else None.

    A copy that is not a git checkout says ``GYM4REAL_CODE_VERSION`` (suffixed ``(stated)``) instead, if set.
    """
    try:
        git = subprocess.run(
            ["git", "-C", str(Path(__file__).parent), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            check=False,
        )
    except OSError:  # no git
        git = None
    if git is not None and git.returncode == 0:
        return git.stdout.strip()
    if os.environ.get(CODE_VERSION_ENV):
        return f"{os.environ[CODE_VERSION_ENV]} (stated)"
    return None


#: Third-party distributions whose versions a result depends on (besides every gym4real distribution).
DEPENDENCIES = (
    "gymnasium",
    "numpy",
    "scipy",
    "pandas",
    "torch",
    "stable-baselines3",
    "numba",
    "mujoco",
    "onnxruntime",
    "opencv-python-headless",
    "owa-epanet",
)


def code_version() -> str:
    """``git describe --always --dirty`` of the checkout holding this code, else gym4real-core's version."""
    return git_version() or f"gym4real-core {metadata.version('gym4real-core')} (installed, not a git checkout)"


def versions() -> dict[str, str]:
    """Versions of every gym4real distribution, of :data:`DEPENDENCIES` (``not installed``), and of Python."""
    found = {
        dist.metadata["Name"]: dist.version
        for dist in metadata.distributions()
        if (dist.metadata["Name"] or "").lower().startswith("gym4real")
    }
    for name in DEPENDENCIES:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    found["python"] = platform.python_version()
    return dict(sorted(found.items()))


#: Said of what a machine or a file does not record.
NOT_RECORDED = "not recorded"


def available_cpus() -> int:
    """The cores this process may run on (``--jobs auto``; the JAX trainer's evaluations beside training)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def cpu_model() -> str:
    """The CPU model of this machine: ``model name`` in ``/proc/cpuinfo`` (Linux), else the platform's processor.

    :data:`NOT_RECORDED` when neither names one.
    """
    try:
        text = Path("/proc/cpuinfo").read_text(errors="replace")
    except OSError:
        text = ""
    for line in text.splitlines():
        key, sep, value = line.partition(":")
        if sep and key.strip() == "model name" and value.strip():
            return " ".join(value.split())
    return platform.processor() or NOT_RECORDED
