"""The distributions a process actually imported, with their versions (for a run's manifest)."""

from __future__ import annotations

import sys
from importlib import metadata


def imported_distributions() -> dict[str, str]:
    """Every installed distribution that provides a module imported so far in this process, with its version.

    Read from ``sys.modules`` at the time of the call (the end of a training run or of a test phase), each
    top-level module mapped to its distributions by :func:`importlib.metadata.packages_distributions`; the
    standard library and modules of no installed distribution are left out. A portion ``gym4real.X`` of the
    namespace package counts as the distribution ``gym4real-X`` (an editable install lists no files).
    """
    owners = dict(metadata.packages_distributions())
    names = list(sys.modules)
    for name in names:  # gym4real's namespace portions (editable installs list no files): gym4real.X <- gym4real-X
        if name.count(".") == 1 and name.startswith("gym4real."):
            owners.setdefault(name, []).append(f"gym4real-{name.split('.')[1]}")
    found: dict[str, str] = {}
    for top in {name.split(".", 1)[0] for name in names} | {n for n in names if n in owners and "." in n}:
        for dist in owners.get(top, ()):
            if dist in found:
                continue
            try:
                found[dist] = metadata.version(dist)
            except metadata.PackageNotFoundError:
                continue
    return dict(sorted(found.items(), key=lambda item: item[0].lower()))


def union(*records: dict[str, str]) -> dict[str, str]:
    """Several processes' imports as one record; a distribution seen at two versions lists both (``a | b``)."""
    found: dict[str, set[str]] = {}
    for record in records:
        for dist, version in record.items():
            found.setdefault(dist, set()).add(version)
    return {dist: " | ".join(sorted(versions)) for dist, versions in sorted(found.items(), key=lambda i: i[0].lower())}
