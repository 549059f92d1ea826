"""Lookup tables of the equivalent circuit: R0, R1, C and OCV against temperature (°C) and SoC.

The four tables share one rectilinear grid, so a step computes the cell and the weights once and
reads the four parameters from one precomputed tuple per cell (plain Python floats: no numpy, pandas
or scipy call in the simulation step).
"""

from __future__ import annotations

import csv
import math
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gym4real.core.errors import DataFileError

#: Order of the parameters in every lookup result.
PARAMETERS = ("r0", "r1", "c", "ocv")
#: Range of the temperature axis (°C): a table in kelvin (273.15 higher) falls outside it.
TEMP_RANGE_C = (-60.0, 100.0)


def read_table(path: Path, inputs: tuple[str, str], output: str) -> dict[tuple[float, float], float]:
    """Read a ``<temp>,<soc>,<value>`` CSV into ``{(temp, soc): value}``.

    Raises:
        DataFileError: The file is unreadable or not UTF-8, lacks a column, holds a non-numeric or
            non-finite value, a temperature outside :data:`TEMP_RANGE_C` (°C), a SoC outside [0, 1] or a
            parameter that is not positive, or repeats a grid point.
    """
    expected = [*inputs, output]
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except OSError as exc:
        msg = f"cannot read lookup table `{path}`: {exc}"
        raise DataFileError(msg) from exc
    except UnicodeDecodeError as exc:
        msg = f"lookup table `{path}` is not UTF-8 text ({exc.reason} at byte {exc.start}); save it as a UTF-8 CSV"
        raise DataFileError(msg) from None
    if not rows:
        msg = f"lookup table `{path}` is empty; expected a header with columns {expected}"
        raise DataFileError(msg)
    header = [h.strip() for h in rows[0]]
    missing = [c for c in expected if c not in header]
    if missing:
        msg = f"lookup table `{path}` lacks column(s) {missing}: expected columns {expected}, found {header}"
        raise DataFileError(msg)
    cols = [header.index(c) for c in expected]
    table: dict[tuple[float, float], float] = {}
    for n, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        try:
            t, s, v = (float(row[c]) for c in cols)
        except (IndexError, ValueError):
            msg = f"lookup table `{path}` line {n}: expected numbers in columns {expected}, got {row}"
            raise DataFileError(msg) from None
        if not all(map(math.isfinite, (t, s, v))):
            msg = f"lookup table `{path}` line {n}: non-finite value in {row}"
            raise DataFileError(msg)
        lo, hi = TEMP_RANGE_C
        for column, value, ok, wanted in (
            (inputs[0], t, lo <= t <= hi, f"a temperature in °C within [{lo:g}, {hi:g}] (not kelvin)"),
            (inputs[1], s, 0.0 <= s <= 1.0, "a state of charge in [0, 1] (not percent)"),
            (output, v, v > 0.0, "a positive parameter (ohm, F or V)"),
        ):
            if not ok:
                msg = f"lookup table `{path}` line {n}: column `{column}` holds {value:g}; expected {wanted}"
                raise DataFileError(msg)
        if (t, s) in table:
            msg = f"lookup table `{path}` line {n}: grid point ({t}, {s}) appears twice"
            raise DataFileError(msg)
        table[(t, s)] = v
    return table


def _axis(values: Sequence[float], what: str, source: str) -> tuple[float, ...]:
    axis = tuple(sorted(set(values)))
    if len(axis) < 2:
        msg = f"lookup table {source}: the `{what}` axis needs at least two values, found {list(axis)}"
        raise DataFileError(msg)
    return axis


@dataclass(frozen=True)
class ParameterGrid:
    """R0 (ohm), R1 (ohm), C (F) and OCV (V) on a rectilinear (temperature °C, SoC) grid.

    Attributes:
        temps: Temperature axis in °C, ascending.
        socs: SoC axis, ascending.
        values: ``values[p][i][j]`` is parameter ``PARAMETERS[p]`` at ``(temps[i], socs[j])``.
    """

    temps: tuple[float, ...]
    socs: tuple[float, ...]
    values: tuple[tuple[tuple[float, ...], ...], ...]
    _cells: list[list[tuple[float, ...]]] = field(init=False, repr=False, compare=False)
    _temps32: list[float] = field(init=False, repr=False, compare=False)
    _socs32: list[float] = field(init=False, repr=False, compare=False)
    _values32: list[list[tuple[float, float, float, float]]] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        nt, ns = len(self.temps), len(self.socs)
        cells = []
        for i in range(nt - 1):
            row = []
            for j in range(ns - 1):
                cell: list[float] = []
                for table in self.values:
                    cell += [table[i][j], table[i][j + 1], table[i + 1][j], table[i + 1][j + 1]]
                row.append(tuple(cell))
            cells.append(row)
        object.__setattr__(self, "_cells", cells)
        # The reference interpolates over float32 grid points: its nearest-neighbour fallback compares
        # distances to these rounded coordinates.
        object.__setattr__(self, "_temps32", [float(np.float32(t)) for t in self.temps])
        object.__setattr__(self, "_socs32", [float(np.float32(s)) for s in self.socs])
        values32 = np.asarray(self.values, dtype=np.float32).astype(np.float64)  # [parameter, temp, soc]
        object.__setattr__(self, "_values32", [[tuple(v) for v in row] for row in values32.transpose(1, 2, 0).tolist()])

    @classmethod
    def from_tables(cls, tables: Sequence[dict[tuple[float, float], float]], sources: Sequence[str]) -> ParameterGrid:
        """Build the grid from the four tables (R0, R1, C, OCV) read by :func:`read_table`.

        Raises:
            DataFileError: A table does not cover the full grid, or the tables' grids differ.
        """
        temps = _axis([t for t, _ in tables[0]], "temp", f"`{sources[0]}`")
        socs = _axis([s for _, s in tables[0]], "soc", f"`{sources[0]}`")
        values = []
        for table, source in zip(tables, sources, strict=True):
            if {t for t, _ in table} != set(temps) or {s for _, s in table} != set(socs):
                msg = (
                    f"lookup table `{source}` is on a different (temp, soc) grid than `{sources[0]}`; "
                    "the four tables must share one grid"
                )
                raise DataFileError(msg)
            try:
                values.append(tuple(tuple(table[(t, s)] for s in socs) for t in temps))
            except KeyError as exc:
                msg = f"lookup table `{source}` lacks grid point (temp, soc) = {exc.args[0]}; every pair is needed"
                raise DataFileError(msg) from None
        return cls(temps, socs, tuple(values))

    @classmethod
    def constant(cls, r0: float, r1: float, c: float, ocv: float) -> ParameterGrid:
        """A grid whose parameters do not depend on temperature or SoC."""
        return cls((0.0, 40.0), (0.0, 1.0), tuple(((v, v), (v, v)) for v in (r0, r1, c, ocv)))

    def table(self, name: str) -> np.ndarray:
        """Return one parameter's table as an array ``[temperature, soc]``."""
        return np.array(self.values[PARAMETERS.index(name)])

    def bilinear(self, temp_c: float, soc: float) -> tuple[float, float, float, float]:
        """Bilinear interpolation at ``(temp_c, soc)``, clamped to the grid's edges.

        Args:
            temp_c: Temperature in °C (the tables' unit).
            soc: State of charge.

        Returns:
            ``(r0, r1, c, ocv)``.
        """
        ts, ss = self.temps, self.socs
        if temp_c <= ts[0]:
            i, wt = 0, 0.0
        elif temp_c >= ts[-1]:
            i, wt = len(ts) - 2, 1.0
        else:
            i = bisect_right(ts, temp_c) - 1
            wt = (temp_c - ts[i]) / (ts[i + 1] - ts[i])
        if soc <= ss[0]:
            j, ws = 0, 0.0
        elif soc >= ss[-1]:
            j, ws = len(ss) - 2, 1.0
        else:
            j = bisect_right(ss, soc) - 1
            ws = (soc - ss[j]) / (ss[j + 1] - ss[j])
        (a0, a1, a2, a3, b0, b1, b2, b3, c0, c1, c2, c3, d0, d1, d2, d3) = self._cells[i][j]
        w11 = wt * ws
        w10 = wt - w11
        w01 = ws - w11
        w00 = 1.0 - wt - w01
        return (
            w00 * a0 + w01 * a1 + w10 * a2 + w11 * a3,
            w00 * b0 + w01 * b1 + w10 * b2 + w11 * b3,
            w00 * c0 + w01 * c1 + w10 * c2 + w11 * c3,
            w00 * d0 + w01 * d1 + w10 * d2 + w11 * d3,
        )

    def nearest(self, temp: float, soc: float) -> tuple[float, float, float, float]:
        """The reference's lookup: the grid point nearest to ``(temp, soc)`` in raw units.

        The reference passes Kelvin to these °C tables, so its linear interpolation is always outside
        the grid and its nearest-neighbour fallback returns the hottest column (40 °C) at the nearest
        SoC grid point. On a rectilinear grid the nearest point is the nearest value on each axis. The
        values are rounded to float32, as the reference's interpolators hold them.
        """
        i = _nearest_index(self._temps32, temp)
        j = _nearest_index(self._socs32, soc)
        return self._values32[i][j]


def _nearest_index(axis: list[float], x: float) -> int:
    k = bisect_right(axis, x)
    if k == 0:
        return 0
    if k == len(axis):
        return k - 1
    return k if axis[k] - x < x - axis[k - 1] else k - 1
