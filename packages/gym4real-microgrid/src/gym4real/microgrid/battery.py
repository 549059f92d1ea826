"""Battery digital twin: a lithium-ion pack as a Thevenin circuit, a lumped thermal model and Bolun aging.

Usable without the environment::

    from gym4real.microgrid.battery import BatteryTwin, load_battery

    twin = BatteryTwin(load_battery())          # the pack of the Gym4ReaL configuration
    twin.reset(soc=0.5, temperature=298.15)
    applied = twin.step(power=2000.0, dt=3600.0, t_amb=298.15)   # charge at 2 kW for an hour
    twin.soc, twin.voltage, twin.current, twin.heat, twin.soh

**Sign convention (passive):** power and current are positive when the battery charges (energy flows
into it) and negative when it discharges. ``twin.voltage`` is the terminal voltage (V), ``twin.heat``
the heat generated in the step (W), temperatures are in kelvin (the lookup tables are in °C).

Model, per step of ``dt`` seconds from the state at the start of the step:

1. *Parameters*: R0, R1, C and OCV from the lookup tables at (temperature, SoC).
2. *Limits*: the SoC window ``[soc_min, soc_max]`` over one step bounds the current; the pack's
   current and power bounds bound it too. The requested power is clipped to the feasible range and the
   clipped part is reported (:attr:`BatteryTwin.clipped_power`), with the SoC-window violation the
   request would have caused (:attr:`BatteryTwin.soc_violation`).
3. *Electrical*: ``V = OCV + R0 I + v_rc`` with the RC voltage by backward Euler
   ``v_rc' = (v_rc / dt - I / C) / (1 / dt + 1 / (R1 C))`` (active-convention internal current);
   given ``P``, the current solves ``V(I) I = P`` so the terminal energy equals ``P dt`` exactly.
4. *SoC*: coulomb counting ``SoC' = SoC + I dt / (3600 C_max)`` against the current capacity
   ``C_max = SoH * C_nominal``.
5. *Thermal*: heat ``q = R0 I² + R1 I_R1²``; lumped core node
   ``C_th (T' - T) / dt = q + I T' dV/dT(SoC) + (T_amb - T') / (R_cond + R_conv)``;
   surface ``T_s = T' + R_cond (T_amb - T') / (R_cond + R_conv)``.
6. *Aging*: :mod:`gym4real.microgrid.aging`; ``SoH = SoH_0 - deg``, end of life at ``eol_soh``.

:class:`TwinOptions` switches each correction off to reproduce the reference (``fidelity="upstream"``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from gym4real.core.config import read_yaml
from gym4real.core.errors import ConfigError, DataFileError
from gym4real.microgrid.aging import CALENDAR_FACTORS, CYCLIC_FACTORS, AgingParams, BolunAging
from gym4real.microgrid.tables import ParameterGrid, read_table

KELVIN = 273.15


@dataclass(frozen=True)
class BatteryParams:
    """Every constant of the twin (pack, thermal and aging YAML, lookup tables).

    Units: capacity Ah, voltage V, current A, power W, temperature K, thermal capacity J/K,
    thermal resistances K/W, ``dvdt`` in V/K against SoC.
    """

    grid: ParameterGrid
    nominal_capacity: float = 60.0
    nominal_voltage: float = 350.4
    v_min: float = 288.0
    v_max: float = 398.4
    soc_min: float = 0.2
    soc_max: float = 1.0
    current_min: float = -180.0
    current_max: float = 60.0
    power_min: float = -71712.0
    power_max: float = 23904.0
    temp_min: float = 273.15
    temp_max: float = 323.15
    soh_min: float = 0.6
    soh_max: float = 1.0
    init_voltage: float = 310.8
    init_soc: float = 0.2
    init_soh: float = 1.0
    init_temperature: float = 293.15
    c_thermal: float = 138240.0
    r_cond: float = 0.0061
    r_conv: float = 0.1994
    dvdt_socs: tuple[float, ...] = (0.0, 1.0)
    dvdt_values: tuple[float, ...] = (0.0, 0.0)
    aging: AgingParams = field(default_factory=AgingParams)
    nominal_cost: float = 3000.0

    def bounds(self) -> dict[str, tuple[float, float]]:
        """The pack's ``bounds`` block (the ranges of the reference's random initialisation)."""
        return {
            "voltage": (self.v_min, self.v_max),
            "current": (self.current_min, self.current_max),
            "power": (self.power_min, self.power_max),
            "temperature": (self.temp_min, self.temp_max),
            "temp_ambient": (self.temp_min, self.temp_max),
            "soc": (self.soc_min, self.soc_max),
            "soh": (self.soh_min, self.soh_max),
        }

    def dvdt(self, soc: float) -> float:
        """Entropic coefficient dOCV/dT (V/K) at ``soc``: piecewise linear, extrapolated at the ends."""
        xs, ys = self.dvdt_socs, self.dvdt_values
        j = 0
        while j < len(xs) - 2 and soc > xs[j + 1]:
            j += 1
        return ys[j] + (ys[j + 1] - ys[j]) * (soc - xs[j]) / (xs[j + 1] - xs[j])


# -- reading the configuration files -----------------------------------------------------------------


def _yaml(path: Path) -> dict[str, Any]:
    return read_yaml(path, "battery configuration", DataFileError)


def _get(data: Mapping[str, Any], keys: str, path: Path, kind: type = float) -> Any:
    node: Any = data
    for key in keys.split("."):
        if not isinstance(node, Mapping) or key not in node:
            msg = f"battery configuration `{path}` lacks `{keys}` (expected a {kind.__name__})"
            raise DataFileError(msg)
        node = node[key]
    if kind is float:
        if isinstance(node, bool) or not isinstance(node, (int, float)) or not math.isfinite(node):
            msg = f"battery configuration `{path}`: `{keys}` must be a finite number, not {node!r}"
            raise DataFileError(msg)
        return float(node)
    if not isinstance(node, kind):
        msg = f"battery configuration `{path}`: `{keys}` must be a {kind.__name__}, not {node!r}"
        raise DataFileError(msg)
    return node


def _component(model: Mapping[str, Any], name: str, path: Path) -> Mapping[str, Any]:
    comp = _get(model, f"components.{name}", path, dict)
    kind = comp.get("selected_type")
    if kind not in ("lookup", "scalar"):
        msg = f"battery configuration `{path}`: `components.{name}.selected_type` must be `lookup` or `scalar`"
        raise DataFileError(msg)
    return comp


def _electrical_grid(model: Mapping[str, Any], path: Path, table_path: Any) -> ParameterGrid:
    """Read the four ECM components (lookup tables or scalars) onto one grid."""
    names = ("r0", "r1", "c", "v_ocv")
    tables: list[dict[tuple[float, float], float] | float] = []
    sources: list[str] = []
    for name in names:
        comp = _component(model, name, path)
        if comp["selected_type"] == "scalar":
            tables.append(_get(comp, "scalar", path))
            sources.append(f"{path} (scalar `{name}`)")
            continue
        lookup = _get(comp, "lookup", path, dict)
        file = _get(lookup, "table", path, str)
        inputs = lookup.get("inputs")
        labels = {i.get("var"): i.get("label") for i in inputs} if isinstance(inputs, list) else {}
        if not all(isinstance(i, dict) for i in inputs or []) or set(labels) != {"temperature", "soc"}:
            msg = (
                f"battery configuration `{path}`: `components.{name}.lookup.inputs` must list the variables "
                f"`temperature` and `soc` with their column labels"
            )
            raise DataFileError(msg)
        output = _get(lookup, "output.label", path, str)
        source = table_path(file)
        tables.append(read_table(source, (labels["temperature"], labels["soc"]), output))
        sources.append(str(source))
    looked_up = [t for t in tables if isinstance(t, dict)]
    if not looked_up:
        return ParameterGrid.constant(*(float(t) for t in tables))  # type: ignore[arg-type]
    first = looked_up[0]
    full = [t if isinstance(t, dict) else dict.fromkeys(first, t) for t in tables]
    return ParameterGrid.from_tables(full, sources)


def _aging(model: Mapping[str, Any], path: Path) -> AgingParams:
    factors = _get(model, "components.stress_factors", path, dict)
    calendar = tuple(factors.get("calendar") or ())
    cyclic = tuple(factors.get("cyclic") or ())
    for kind, got, allowed in (("calendar", calendar, CALENDAR_FACTORS), ("cyclic", cyclic, CYCLIC_FACTORS)):
        unknown = [f for f in got if f not in allowed]
        if unknown:
            msg = f"battery configuration `{path}`: unsupported {kind} stress factor(s) {unknown}; use {allowed}"
            raise DataFileError(msg)
    s = "stress_models"
    return AgingParams(
        alpha_sei=_get(model, "components.SEI.alpha_sei", path),
        beta_sei=_get(model, "components.SEI.beta_sei", path),
        calendar=calendar,
        cyclic=cyclic,
        k_t=_get(model, f"{s}.time.k_t", path),
        k_soc=_get(model, f"{s}.soc.k_soc", path),
        soc_ref=_get(model, f"{s}.soc.soc_ref", path),
        k_temp=_get(model, f"{s}.temperature.k_temp", path),
        temp_ref=_get(model, f"{s}.temperature.temp_ref", path),
        k_delta1=_get(model, f"{s}.dod_bolun.k_delta1", path),
        k_delta2=_get(model, f"{s}.dod_bolun.k_delta2", path),
        k_delta3=_get(model, f"{s}.dod_bolun.k_delta3", path),
    )


def _dvdt(model: Mapping[str, Any], path: Path) -> tuple[tuple[float, ...], tuple[float, ...]]:
    comp = _component(model, "dv_dT", path)
    if comp["selected_type"] == "scalar":
        v = _get(comp, "scalar", path)
        return (0.0, 1.0), (v, v)
    socs = _get(comp, "lookup.inputs.soc", path, list)
    values = _get(comp, "lookup.output", path, list)
    if len(socs) != len(values) or len(socs) < 2:
        msg = f"battery configuration `{path}`: `components.dv_dT` needs as many outputs as SoC inputs (>= 2)"
        raise DataFileError(msg)
    pairs = sorted((float(s), float(v)) for s, v in zip(socs, values, strict=True))
    return tuple(p[0] for p in pairs), tuple(p[1] for p in pairs)


def read_battery(pack: Path, electrical: Path, thermal: Path, aging: Path, table_path: Any) -> BatteryParams:
    """Read the pack, model YAML files and lookup tables into :class:`BatteryParams`.

    Args:
        pack: ``battery_pack.yaml``.
        electrical: ``models/electrical.yaml`` (Thevenin components).
        thermal: ``models/thermal.yaml`` (R2C).
        aging: ``models/aging.yaml`` (Bolun).
        table_path: ``callable(file_name) -> Path`` locating a lookup table named in ``electrical``.

    Raises:
        DataFileError: A file is unreadable or lacks a key or column; the message names both.
    """
    data = _yaml(pack)
    b = "battery"
    sign = _get(data, f"{b}.sign_convention", pack, str)
    if sign != "passive":
        msg = f"battery configuration `{pack}`: `battery.sign_convention` must be `passive`, not `{sign}`"
        raise DataFileError(msg)
    el, th, ag = _yaml(electrical), _yaml(thermal), _yaml(aging)
    for model, path, kind in ((el, electrical, "electrical"), (th, thermal, "thermal"), (ag, aging, "aging")):
        if model.get("type") != kind:
            msg = f"battery configuration `{path}` must declare `type: {kind}`, found {model.get('type')!r}"
            raise DataFileError(msg)
    dvdt_socs, dvdt_values = _dvdt(th, thermal)
    params = BatteryParams(
        grid=_electrical_grid(el, electrical, table_path),
        nominal_capacity=_get(data, f"{b}.params.nominal_capacity", pack),
        nominal_voltage=_get(data, f"{b}.params.nominal_voltage", pack),
        v_min=_get(data, f"{b}.params.v_min", pack),
        v_max=_get(data, f"{b}.params.v_max", pack),
        soc_min=_get(data, f"{b}.bounds.soc.low", pack),
        soc_max=_get(data, f"{b}.bounds.soc.high", pack),
        current_min=_get(data, f"{b}.bounds.current.low", pack),
        current_max=_get(data, f"{b}.bounds.current.high", pack),
        power_min=_get(data, f"{b}.bounds.power.low", pack),
        power_max=_get(data, f"{b}.bounds.power.high", pack),
        temp_min=_get(data, f"{b}.bounds.temperature.low", pack),
        temp_max=_get(data, f"{b}.bounds.temperature.high", pack),
        soh_min=_get(data, f"{b}.bounds.soh.low", pack),
        soh_max=_get(data, f"{b}.bounds.soh.high", pack),
        init_voltage=_get(data, f"{b}.init.voltage", pack),
        init_soc=_get(data, f"{b}.init.soc", pack),
        init_soh=_get(data, f"{b}.init.soh", pack),
        init_temperature=_get(data, f"{b}.init.temperature", pack),
        c_thermal=_get(th, "components.c_term.scalar", thermal),
        r_cond=_get(th, "components.r_cond.scalar", thermal),
        r_conv=_get(th, "components.r_conv.scalar", thermal),
        dvdt_socs=dvdt_socs,
        dvdt_values=dvdt_values,
        aging=_aging(ag, aging),
        nominal_cost=float(data[b]["params"].get("nominal_cost", 3000.0)),
    )
    _check_params(params, pack)
    return params


def _check_params(p: BatteryParams, pack: Path) -> None:
    problems = []
    if p.nominal_capacity <= 0:
        problems.append("`params.nominal_capacity` must be positive")
    if not 0.0 <= p.soc_min < p.soc_max <= 1.0:
        problems.append("`bounds.soc` must satisfy 0 <= low < high <= 1")
    if not p.soc_min <= p.init_soc <= p.soc_max:
        problems.append("`init.soc` must lie within `bounds.soc`")
    if not (p.current_min <= 0 <= p.current_max and p.power_min <= 0 <= p.power_max):
        problems.append("`bounds.current` and `bounds.power` must contain 0")
    if min(p.c_thermal, p.r_cond + p.r_conv) <= 0:
        problems.append("the thermal capacity and resistances must be positive")
    if problems:
        msg = f"battery configuration `{pack}`: " + "; ".join(problems)
        raise DataFileError(msg)


DATASETS = {
    "pack": "microgrid/battery/pack",
    "electrical": "microgrid/battery/electrical",
    "thermal": "microgrid/battery/thermal",
    "aging": "microgrid/battery/aging",
}


def load_battery(
    data_dir: str | Path | None = None,
    *,
    pack: str | Path | None = None,
    electrical: str | Path | None = None,
    thermal: str | Path | None = None,
    aging: str | Path | None = None,
    tables_dir: str | Path | None = None,
) -> BatteryParams:
    """Load the battery of the Gym4ReaL configuration, or user files in place of any of its parts.

    Args:
        data_dir: Folder searched first for the registered files (before ``GYM4REAL_DATA_DIR``).
        pack: A pack YAML file instead of the registered ``battery_pack.yaml``.
        electrical: An electrical model YAML instead of ``models/electrical.yaml``.
        thermal: A thermal model YAML instead of ``models/thermal.yaml``.
        aging: An aging model YAML instead of ``models/aging.yaml``.
        tables_dir: Folder holding the lookup tables named in the electrical YAML (instead of the
            registered ``params/*.csv``).
    """
    from gym4real.core.datasets import resolve
    from gym4real.core.registry import registry

    def path_of(given: str | Path | None, key: str) -> Path:
        return Path(given).expanduser() if given is not None else resolve(DATASETS[key], data_dir)

    def table_path(file: str) -> Path:
        if tables_dir is not None:
            return Path(tables_dir).expanduser() / file
        for spec in registry().datasets.values():
            if spec.name.startswith("microgrid/battery/") and spec.path.endswith(f"/params/{file}"):
                return resolve(spec.name, data_dir)
        msg = (
            f"lookup table `{file}` named in the electrical model is not a registered file; "
            "pass `tables_dir` (config `battery.tables_dir`) with the folder that holds it"
        )
        raise DataFileError(msg)

    return read_battery(
        path_of(pack, "pack"),
        path_of(electrical, "electrical"),
        path_of(thermal, "thermal"),
        path_of(aging, "aging"),
        table_path,
    )


# -- the twin ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TwinOptions:
    """Which corrections of the reference the twin applies (all True = the corrected default).

    Attributes:
        celsius_lookup: Convert kelvin to °C and interpolate the tables bilinearly; False: the
            reference's nearest grid point of the raw kelvin value (the 40 °C column).
        capacity_fade: Coulomb counting against ``SoH * C_nominal``; False: always the nominal capacity.
        power_limits: Bound the current and power by the pack's bounds as well as by the SoC window.
        consistent_current: Solve ``V(I) I = P`` with the new terminal voltage (energy conserved) and
            start from the open-circuit voltage; False: ``I = P / V_previous`` from the configured
            initial voltage.
        calendar_time: Integrate the calendar stress with the current time step; False: the reference's
            ``k_t * t_previous * S(mean SoC) * S(mean T)`` (time lagged by one step, -1 s at the start).
        standard_rainflow: Streaming ASTM rainflow keeping the residue's damage, SoH monotone; False:
            the reference's Dropflow (dropped half cycles, non-monotone SoH).
        thermal_core_state: Keep the core temperature as the thermal state (surface reported apart) and
            take dV/dT at the new SoC; False: the surface temperature is fed back as the state.
    """

    celsius_lookup: bool = True
    capacity_fade: bool = True
    power_limits: bool = True
    consistent_current: bool = True
    calendar_time: bool = True
    standard_rainflow: bool = True
    thermal_core_state: bool = True

    @classmethod
    def for_fidelity(cls, fidelity: str, **overrides: bool | None) -> TwinOptions:
        """Defaults of a fidelity (``corrected``: every fix; ``upstream``: none), then overrides (None skipped)."""
        if fidelity not in ("corrected", "upstream"):
            msg = f'`fidelity` must be "corrected" or "upstream", not {fidelity!r}'
            raise ConfigError(msg)
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(overrides) - names)
        if unknown:
            msg = f"unknown twin option(s) {unknown}; expected some of {sorted(names)}"
            raise ConfigError(msg)
        base = fidelity == "corrected"
        return cls(**{n: base if overrides.get(n) is None else bool(overrides[n]) for n in names})


class BatteryTwin:
    """The battery digital twin (see the module docstring for the model and the sign convention).

    Args:
        params: The battery constants (:func:`load_battery`).
        options: Corrections to apply (default: all).
        eol_soh: State of health at end of life.

    After each :meth:`step` the attributes hold the state at the end of the step: ``soc``, ``soh``,
    ``temperature`` (core, K), ``surface_temperature`` (K), ``voltage`` (V), ``current`` (A),
    ``power`` (W, the applied power), ``heat`` (W), ``capacity`` (Ah), ``ocv``, ``r0``, ``r1``, ``c``,
    ``v_rc``, ``clipped_power`` (requested minus applied, W), ``soc_violation`` (how far beyond the SoC
    window the request would have driven the SoC), ``calendar_aging``, ``cyclic_aging``, ``degradation``.
    """

    def __init__(self, params: BatteryParams, options: TwinOptions | None = None, eol_soh: float = 0.6) -> None:
        self.params = params
        self.options = o = options or TwinOptions()
        self.eol_soh = eol_soh
        self._aging = BolunAging(params.aging, calendar_time=o.calendar_time, standard_rainflow=o.standard_rainflow)
        self._r_tot = params.r_cond + params.r_conv
        self._lookup = params.grid.bilinear if o.celsius_lookup else params.grid.nearest
        self.reset()

    # -- state ---------------------------------------------------------------------------------------

    def reset(
        self,
        soc: float | None = None,
        temperature: float | None = None,
        soh: float | None = None,
        voltage: float | None = None,
    ) -> None:
        """Put the battery at rest in a given state (defaults: the pack's ``init`` block).

        Args:
            soc: State of charge.
            temperature: Battery temperature (K); the core and the surface start equal.
            soh: State of health (the reference of the degradation: ``SoH = soh - deg``).
            voltage: Terminal voltage before the first step; default the open-circuit voltage
                (``consistent_current``) or the pack's ``init.voltage`` (the reference).
        """
        p, o = self.params, self.options
        self.soc = p.init_soc if soc is None else float(soc)
        self.soh0 = self.soh = p.init_soh if soh is None else float(soh)
        self.temperature = self.surface_temperature = p.init_temperature if temperature is None else float(temperature)
        self.capacity = p.nominal_capacity * (self.soh if o.capacity_fade else 1.0)
        self.k = 0
        self.elapsed = 0.0
        self.v_rc = 0.0
        self.r0, self.r1, self.c, self.ocv = self._params_now()
        if voltage is not None:
            self.voltage = float(voltage)
        else:
            self.voltage = self.ocv if o.consistent_current else p.init_voltage
        self.current = self.power = self.heat = 0.0
        self.clipped_power = self.soc_violation = 0.0
        self.degradation = self.calendar_aging = self.cyclic_aging = 0.0
        self._aging.reset(self.soc, self.temperature)

    def _params_now(self) -> tuple[float, float, float, float]:
        if self.options.celsius_lookup:
            return self.params.grid.bilinear(self.temperature - KELVIN, self.soc)
        return self.params.grid.nearest(self.temperature, self.soc)

    @property
    def eol(self) -> bool:
        """True once the state of health is at or below the end-of-life threshold."""
        return self.soh <= self.eol_soh

    # -- limits --------------------------------------------------------------------------------------

    def _circuit(self, dt: float) -> tuple[float, float, float, float, float, float, float]:
        """Parameters at the current state and the affine terminal voltage ``V(I) = a + b I``."""
        r0, r1, c, ocv = self._params_now()
        den = 1.0 / dt + 1.0 / (r1 * c)
        a = ocv - self.v_rc / dt / den
        b = r0 + 1.0 / c / den
        return r0, r1, c, ocv, den, a, b

    def power_limits(self, dt: float) -> tuple[float, float]:
        """Feasible power range (W) over a step of ``dt`` s (passive convention)."""
        *_, a, b = self._circuit(dt)
        return self._limits(self.capacity * 3600.0 / dt, a, b)

    def _limits(self, charge: float, a: float, b: float) -> tuple[float, float]:
        """Power range from the current range (``charge``: A per unit of SoC; ``V(I) = a + b I``)."""
        p, o = self.params, self.options
        lo_i = (p.soc_min - self.soc) * charge
        hi_i = (p.soc_max - self.soc) * charge
        if o.power_limits:
            lo_i = max(lo_i, p.current_min)
            hi_i = min(hi_i, p.current_max)
        lo_i, hi_i = min(lo_i, 0.0), max(hi_i, 0.0)
        if o.consistent_current:
            lo_i = max(lo_i, -a / (2.0 * b))  # past this current the deliverable power falls again
            lo, hi = (a + b * lo_i) * lo_i, (a + b * hi_i) * hi_i
        else:
            lo, hi = self.voltage * lo_i, self.voltage * hi_i
        if o.power_limits:
            lo, hi = max(lo, p.power_min), min(hi, p.power_max)
        return lo, hi

    # -- dynamics ------------------------------------------------------------------------------------

    def step(self, power: float, dt: float, t_amb: float) -> float:
        """Apply ``power`` W (clipped to the feasible range) for ``dt`` s at ambient ``t_amb`` K.

        Returns:
            The applied power (W); ``clipped_power`` holds the rest of the request.
        """
        p, o = self.params, self.options
        soc0, temp0 = self.soc, self.temperature
        cap = self.capacity
        charge = cap * 3600.0 / dt
        # 1. parameters at the state at the start of the step
        if o.celsius_lookup:
            r0, r1, c, ocv = p.grid.bilinear(temp0 - KELVIN, soc0)
        else:
            r0, r1, c, ocv = p.grid.nearest(temp0, soc0)
        den = 1.0 / dt + 1.0 / (r1 * c)
        a = ocv - self.v_rc / dt / den
        b = r0 + 1.0 / c / den
        # 2. feasible range: SoC window (and the pack's current and power bounds)
        lo_p, hi_p = self._limits(charge, a, b)
        applied = lo_p if power < lo_p else hi_p if power > hi_p else power
        self.clipped_power = power - applied
        violation = 0.0
        if applied != power:
            if o.consistent_current:
                disc = a * a + 4.0 * b * power
                i_req = 2.0 * power / (a + math.sqrt(disc)) if disc > 0.0 else -a / (2.0 * b)
            else:
                i_req = power / self.voltage
            soc_req = soc0 + i_req / charge
            violation = max(soc_req - p.soc_max, p.soc_min - soc_req, 0.0)
        self.soc_violation = violation
        # 3. electrical (passive current I; the circuit equations use the active i = -I)
        if o.consistent_current:
            # the power bounds keep the discriminant >= 0; max() absorbs rounding at the discharge bound
            current = 2.0 * applied / (a + math.sqrt(max(a * a + 4.0 * b * applied, 0.0))) if applied else 0.0
        else:
            current = applied / self.voltage
        v_rc = (self.v_rc / dt - current / c) / den
        voltage = ocv + r0 * current - v_rc
        i_r1 = v_rc / r1
        # 4. state of charge (coulomb counting)
        soc = soc0 + current / charge
        if soc < 0.0:
            soc = 0.0
        elif soc > 1.0:
            soc = 1.0
        # 5. thermal
        heat = r0 * current * current + r1 * i_r1 * i_r1
        dvdt_soc = soc if o.thermal_core_state else soc0
        xs, ys = p.dvdt_socs, p.dvdt_values
        j = 0
        last = len(xs) - 2
        while j < last and dvdt_soc > xs[j + 1]:
            j += 1
        dvdt = ys[j] + (ys[j + 1] - ys[j]) * (dvdt_soc - xs[j]) / (xs[j + 1] - xs[j])
        cth = p.c_thermal / dt
        r_tot = self._r_tot
        core = (cth * temp0 + t_amb / r_tot + heat) / (cth + 1.0 / r_tot - dvdt * current)
        surface = core + p.r_cond * (t_amb - core) / r_tot
        # 6. aging
        aging = self._aging
        temp1 = core if o.thermal_core_state else surface
        deg = aging.step(soc0, soc, temp0, temp1, dt, self.elapsed)
        self.soh = self.soh0 - deg
        if o.capacity_fade:
            self.capacity = p.nominal_capacity * self.soh
        self.soc = soc
        self.temperature = temp1
        self.surface_temperature = surface
        self.voltage, self.current, self.power, self.heat, self.v_rc = voltage, current, applied, heat, v_rc
        self.r0, self.r1, self.c, self.ocv = r0, r1, c, ocv
        self.degradation = deg
        self.calendar_aging, self.cyclic_aging = aging.calendar, aging.cyclic
        self.k += 1
        self.elapsed += dt
        return applied

    def step_current(self, current: float, dt: float, t_amb: float) -> float:
        """Drive the battery with a constant ``current`` A for ``dt`` s (convenience for tests and studies).

        The power that produces this current at the new terminal voltage is applied through :meth:`step`
        (with the same limits). Returns the applied power (W).
        """
        return self.step(self.power_for_current(current, dt), dt, t_amb)

    def power_for_current(self, current: float, dt: float) -> float:
        """The terminal power (W) that drives ``current`` A over a step of ``dt`` s from the present state.

        With ``consistent_current`` it is ``V(I) I`` at the step's new terminal voltage (what :meth:`step`
        inverts); otherwise the reference's ``V_previous I``. The power is not clipped to the limits.
        """
        if not self.options.consistent_current:
            return self.voltage * current
        *_, a, b = self._circuit(dt)
        return (a + b * current) * current

    def snapshot(self) -> dict[str, float]:
        """The state as a dict of floats (for ``info``)."""
        return {
            "soc": self.soc,
            "soh": self.soh,
            "capacity": self.capacity,
            "temperature": self.temperature,
            "surface_temperature": self.surface_temperature,
            "voltage": self.voltage,
            "current": self.current,
            "power": self.power,
            "heat": self.heat,
            "ocv": self.ocv,
            "r0": self.r0,
            "r1": self.r1,
            "c": self.c,
            "v_rc": self.v_rc,
            "clipped_power": self.clipped_power,
            "calendar_aging": self.calendar_aging,
            "cyclic_aging": self.cyclic_aging,
            "degradation": self.degradation,
        }
