"""What the environment needs to know about a network: its junctions, tanks and pumps, read once.

Also the tank-level pump rule of the network's ``[CONTROLS]`` section (the paper's *Default* policy):
lines such as ``LINK P78 OPEN IF NODE T41 BELOW 5`` are parsed whether they are commented out (as in
Anytown, so that EPANET does not apply them) or not.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gym4real.core.errors import DataFileError
from gym4real.wds import engine as en


@dataclass(frozen=True)
class PumpRule:
    """Hysteresis rule of one pump: open it when ``tank`` is below ``low``, close it above ``high``."""

    pump: str
    tank: str
    low: float
    high: float


@dataclass(frozen=True)
class Network:
    """Indices (1-based EPANET indices and 0-based positions in bulk node arrays) and static data."""

    path: Path
    n_nodes: int
    junction_ids: tuple[str, ...]
    junction_pos: np.ndarray  # 0-based node positions
    junction_elevation: np.ndarray
    base_demand: np.ndarray  # total base demand per junction (all categories)
    tank_ids: tuple[str, ...]
    tank_pos: np.ndarray
    tank_elevation: np.ndarray
    tank_min_level: np.ndarray
    tank_max_level: np.ndarray
    tank_initial_level: np.ndarray
    tank_min_volume: np.ndarray
    tank_diameter: np.ndarray
    pump_ids: tuple[str, ...]
    pump_index: tuple[int, ...]  # 1-based link indices
    pump_initial_status: tuple[int, ...]
    flow_units: int
    head_low: float  # heads every node can physically reach (for observation bounds)
    head_high: float
    rules_from_file: tuple[PumpRule, ...]

    @property
    def flow_to_m3h(self) -> float:
        """Factor from the network's flow units to m³/h."""
        return en.FLOW_TO_M3H[self.flow_units]

    @property
    def flow_to_volume_per_second(self) -> float:
        """Factor from the network's flow units to its volume units (m³ or ft³) per second."""
        if self.flow_units in en.SI_FLOW_UNITS:
            return en.FLOW_TO_M3H[self.flow_units] / 3600.0
        return en.FLOW_TO_M3H[self.flow_units] / en.FLOW_TO_M3H[0]


_CONTROL = re.compile(
    r"^\s*;*\s*LINK\s+(\S+)\s+(OPEN|CLOSED)\s+IF\s+NODE\s+(\S+)\s+(BELOW|ABOVE)\s+([-+0-9.eE]+)\s*(;.*)?$",
    re.IGNORECASE,
)


def parse_controls(text: str) -> list[tuple[str, str, str, str, float]]:
    """The tank-level controls of a ``[CONTROLS]`` section, commented out or not.

    Returns:
        ``(link, "OPEN"|"CLOSED", node, "BELOW"|"ABOVE", level)`` per matching line, in file order.
    """
    out = []
    section = ""
    for raw in text.splitlines():
        line = raw.strip()
        if line.startswith("[") and "]" in line:
            section = line[: line.index("]") + 1].upper()
            continue
        if section != "[CONTROLS]":
            continue
        m = _CONTROL.match(line)
        if m:
            link, status, node, where, level = m.groups()[:5]
            out.append((link, status.upper(), node, where.upper(), float(level)))
    return out


def rules_from_controls(
    controls: list[tuple[str, str, str, str, float]], pumps: tuple[str, ...], tanks: tuple[str, ...]
) -> tuple[PumpRule, ...]:
    """Pair each pump's ``OPEN ... BELOW low`` and ``CLOSED ... ABOVE high`` lines on the same tank."""
    low: dict[tuple[str, str], float] = {}
    high: dict[tuple[str, str], float] = {}
    for link, status, node, where, level in controls:
        if link not in pumps or node not in tanks:
            continue
        if status == "OPEN" and where == "BELOW":
            low[(link, node)] = level
        elif status == "CLOSED" and where == "ABOVE":
            high[(link, node)] = level
    rules = [PumpRule(p, t, low[(p, t)], high[(p, t)]) for (p, t) in low if (p, t) in high]
    return tuple(sorted(rules, key=lambda r: pumps.index(r.pump)))


def _pump_shutoff_head(tk: object, ph: object, link: int) -> float:
    """Largest head of a pump's head curve (its shutoff head), inf for a constant-power pump."""
    if tk.getpumptype(ph, link) == en.CONST_HP:  # type: ignore[attr-defined]
        return math.inf
    curve = tk.getheadcurveindex(ph, link)  # type: ignore[attr-defined]
    if curve <= 0:
        return math.inf
    n = tk.getcurvelen(ph, curve)  # type: ignore[attr-defined]
    return max(tk.getcurvevalue(ph, curve, k)[1] for k in range(1, n + 1))  # type: ignore[attr-defined]


def describe(engine: en.Engine) -> Network:
    """Read the junctions, tanks and pumps of an opened network.

    Raises:
        DataFileError: The network has no tank or no pump (nothing for an agent to control or watch).
    """
    tk, ph = engine.tk, engine.ph
    n_nodes = tk.getcount(ph, en.NODECOUNT)
    n_links = tk.getcount(ph, en.LINKCOUNT)
    junctions, tanks, fixed_heads = [], [], []
    for i in range(1, n_nodes + 1):
        kind = tk.getnodetype(ph, i)
        if kind == en.JUNCTION:
            junctions.append(i)
        elif kind == en.TANK:
            tanks.append(i)
        else:
            fixed_heads.append(tk.getnodevalue(ph, i, en.ELEVATION))
    pumps = [i for i in range(1, n_links + 1) if tk.getlinktype(ph, i) == en.PUMP]
    if not tanks or not pumps:
        msg = (
            f"network `{engine.path}` has {len(tanks)} tank(s) and {len(pumps)} pump(s); WDSEnv needs at least one "
            "of each (the agent switches pumps and watches tank levels)"
        )
        raise DataFileError(msg)

    def node_arr(idx: list[int], prop: int) -> np.ndarray:
        return np.array([tk.getnodevalue(ph, i, prop) for i in idx], dtype=np.float64)

    base = np.array(
        [sum(tk.getbasedemand(ph, j, d) for d in range(1, tk.getnumdemands(ph, j) + 1)) for j in junctions],
        dtype=np.float64,
    )
    elev = node_arr(junctions, en.ELEVATION)
    t_elev = node_arr(tanks, en.ELEVATION)
    t_min, t_max = node_arr(tanks, en.MINLEVEL), node_arr(tanks, en.MAXLEVEL)
    # Heads are bounded by the sources and the elevations (pipes and valves only lose head), raised by
    # at most every pump's shutoff head; the low end is the lowest source or node elevation.
    sources_low = [*fixed_heads, *(t_elev + t_min)]
    sources_high = [*fixed_heads, *(t_elev + t_max)]
    lift = sum(_pump_shutoff_head(tk, ph, k) for k in pumps)
    pump_ids = tuple(tk.getlinkid(ph, k) for k in pumps)
    tank_ids = tuple(tk.getnodeid(ph, i) for i in tanks)
    text = engine.path.read_text(errors="replace")
    return Network(
        path=engine.path,
        n_nodes=n_nodes,
        junction_ids=tuple(tk.getnodeid(ph, i) for i in junctions),
        junction_pos=np.array(junctions, dtype=np.intp) - 1,
        junction_elevation=elev,
        base_demand=base,
        tank_ids=tank_ids,
        tank_pos=np.array(tanks, dtype=np.intp) - 1,
        tank_elevation=t_elev,
        tank_min_level=t_min,
        tank_max_level=t_max,
        tank_initial_level=node_arr(tanks, en.TANKLEVEL),
        tank_min_volume=node_arr(tanks, en.MINVOLUME),
        tank_diameter=node_arr(tanks, en.TANKDIAM),
        pump_ids=pump_ids,
        pump_index=tuple(pumps),
        pump_initial_status=tuple(int(tk.getlinkvalue(ph, k, en.INITSTATUS) > 0) for k in pumps),
        flow_units=int(tk.getflowunits(ph)),
        head_low=float(min([*sources_low, *elev.tolist()])),
        head_high=float(max(sources_high) + lift),
        rules_from_file=rules_from_controls(parse_controls(text), pump_ids, tank_ids),
    )


def pump_controls(engine: en.Engine, net: Network) -> tuple[list[int], list[int]]:
    """The 1-based indices of the simple controls and of the rules that act on a pump."""
    tk, ph = engine.tk, engine.ph
    pumps = set(net.pump_index)
    controls = [i for i in range(1, tk.getcount(ph, en.CONTROLCOUNT) + 1) if int(tk.getcontrol(ph, i)[1]) in pumps]
    rules = []
    for r in range(1, tk.getcount(ph, en.RULECOUNT) + 1):
        _, n_then, n_else, _ = tk.getrule(ph, r)
        links = [tk.getthenaction(ph, r, k)[0] for k in range(1, int(n_then) + 1)]
        links += [tk.getelseaction(ph, r, k)[0] for k in range(1, int(n_else) + 1)]
        if pumps.intersection(int(x) for x in links):
            rules.append(r)
    return controls, rules


def disable_pump_controls(engine: en.Engine, net: Network) -> int:
    """Disable every simple control and rule that acts on a pump, so that only the agent switches pumps.

    Returns:
        The number of controls and rules disabled.
    """
    tk, ph = engine.tk, engine.ph
    controls, rules = pump_controls(engine, net)
    for i in controls:
        tk.setcontrolenabled(ph, i, 0)
    for r in rules:
        tk.setruleenabled(ph, r, 0)
    return len(controls) + len(rules)


def add_pump_controls(engine: en.Engine, net: Network, rules: tuple[PumpRule, ...]) -> int:
    """Give EPANET the tank-level rules as simple controls (``OPEN IF ... BELOW low``, ``CLOSED IF ... ABOVE high``).

    Returns:
        The number of controls added.
    """
    tk, ph = engine.tk, engine.ph
    for r in rules:
        link = net.pump_index[net.pump_ids.index(r.pump)]
        node = int(net.tank_pos[net.tank_ids.index(r.tank)]) + 1
        tk.addcontrol(ph, en.LOWLEVEL, link, 1.0, node, r.low)
        tk.addcontrol(ph, en.HILEVEL, link, 0.0, node, r.high)
    return 2 * len(rules)
