"""Checks of a network file's text that EPANET does not make: it opens a file cut short, or a pump without a curve.

EPANET reads an ``.inp`` file section by section up to ``[END]`` or the end of the file, and gives every
section it did not see its defaults: a copy cut before ``[OPTIONS]`` opens and is simulated in GPM with
other pressure limits. A pump with neither a ``HEAD`` curve nor a ``POWER`` opens too, and fails only when
the hydraulics are solved (``Error 110: cannot solve network hydraulic equations``). These checks refuse
both when the network is opened, naming the file and what is missing.
"""

from __future__ import annotations

import re
from pathlib import Path

from gym4real.core.errors import DataFileError

#: Sections a network file of WDSEnv must hold: its options (flow units, headloss formula, demand model),
#: and ``[END]``, which every complete file written by EPANET (or WNTR) ends with.
REQUIRED_SECTIONS = ("OPTIONS", "END")
_HEADER = re.compile(r"^\s*\[([A-Za-z_]+)\]")


def sections(text: str) -> dict[str, list[str]]:
    """The lines of each section (upper-case name, without brackets), comments and blank lines dropped."""
    found: dict[str, list[str]] = {}
    current: list[str] | None = None
    for raw in text.splitlines():
        header = _HEADER.match(raw)
        if header:
            current = found.setdefault(header.group(1).upper(), [])
            continue
        line = raw.split(";", 1)[0].strip()
        if line and current is not None:
            current.append(line)
    return found


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def pumps_without_curve(pump_lines: list[str]) -> list[str]:
    """The ids of the pumps of ``[PUMPS]`` lines with neither a ``HEAD`` curve nor a ``POWER``.

    A line is ``ID NODE1 NODE2 [KEYWORD VALUE ...]``; a number in place of the first keyword is the
    EPANET 1.x form of a curve, which EPANET 2 still reads.
    """
    missing = []
    for line in pump_lines:
        tokens = line.split()
        params = tokens[3:]
        if params and _is_number(params[0]):
            continue
        keywords = {t.upper() for t in params[0::2]}
        if not keywords & {"HEAD", "POWER"}:
            missing.append(tokens[0])
    return missing


def check_network_text(path: Path, text: str) -> None:
    """Refuse a network file missing a required section, or holding a pump EPANET cannot solve.

    Raises:
        DataFileError: Naming the file and the missing sections (a copy cut short), or the pumps with
            neither a ``HEAD`` curve nor a ``POWER``.
    """
    found = sections(text)
    absent = [name for name in REQUIRED_SECTIONS if name not in found]
    if absent:
        listed = ", ".join(f"[{name}]" for name in absent)
        msg = (
            f"network file `{path}` has no {listed} section; a copy cut short, or a file missing its options, "
            "is simulated with EPANET's defaults (GPM units, other pressure limits): use the complete file, "
            "as EPANET or WNTR writes it (ending with [END])"
        )
        raise DataFileError(msg)
    bad = pumps_without_curve(found.get("PUMPS", []))
    if bad:
        msg = (
            f"network file `{path}`: pump(s) {', '.join(f'`{p}`' for p in bad)} in [PUMPS] have neither a HEAD "
            "curve nor a POWER, so EPANET cannot solve the hydraulics: give each `HEAD <curve id>` (a curve of "
            "[CURVES]) or `POWER <kW or hp>`"
        )
        raise DataFileError(msg)
