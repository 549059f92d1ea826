from __future__ import annotations

import csv
import os
import shutil
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gym4real.core.errors import DataFileError
from gym4real.microgrid.battery import BatteryParams, BatteryTwin, TwinOptions, load_battery
from gym4real.microgrid.tables import ParameterGrid

BATTERY_DIR = Path(os.environ["GYM4REAL_DATA_DIR"]) / "microgrid" / "battery"


def table_value(name: str, label: str, temp: float, soc: float) -> float:
    with (BATTERY_DIR / "params" / f"{name}_pack.csv").open() as f:
        for row in csv.DictReader(f):
            if float(row["temp"]) == temp and abs(float(row["soc"]) - soc) < 1e-9:
                return float(row[label])
    raise KeyError((name, temp, soc))


@pytest.fixture(scope="module")
def params() -> BatteryParams:
    return load_battery()


def test_pack_configuration(params: BatteryParams) -> None:
    assert params.nominal_capacity == 60.0
    assert (params.v_min, params.v_max) == (288.0, 398.4)
    assert (params.soc_min, params.soc_max) == (0.2, 1.0)
    assert (params.current_min, params.current_max) == (-180.0, 60.0)
    assert params.grid.temps == (0.0, 10.0, 20.0, 30.0, 40.0)
    assert len(params.grid.socs) == 21
    assert params.c_thermal == 138240.0


def test_lookup_is_bilinear_in_celsius(params: BatteryParams) -> None:
    grid = params.grid
    assert grid.bilinear(20.0, 0.5)[3] == table_value("voc", "voc", 20, 0.5)
    corners = [table_value("r0", "r0", t, s) for t in (20, 30) for s in (0.5, 0.55)]
    assert grid.bilinear(25.0, 0.525)[0] == pytest.approx(sum(corners) / 4, rel=1e-12)
    # outside the grid the value is clamped to the edge
    assert grid.bilinear(-5.0, 0.5) == grid.bilinear(0.0, 0.5)


def test_upstream_lookup_is_the_40c_column_at_the_nearest_soc(params: BatteryParams) -> None:
    # The spec's reference values of defect 1, at SoC 0.2 and any kelvin temperature.
    r0, r1, c, ocv = params.grid.nearest(278.4, 0.21)
    assert r0 == pytest.approx(0.06122, abs=1e-5)
    assert r1 == pytest.approx(0.07194, abs=1e-5)
    assert c == pytest.approx(669.27, abs=1e-2)
    assert ocv == pytest.approx(342.33, abs=1e-2)
    assert params.grid.nearest(300.0, 0.22)[3] == params.grid.nearest(275.0, 0.2)[3]


def test_constant_current_charge_against_hand_computation_from_the_tables(params: BatteryParams) -> None:
    twin = BatteryTwin(params)
    twin.reset(soc=0.5, temperature=298.15)
    current, dt, t_amb = 10.0, 3600.0, 298.15
    twin.step_current(current, dt, t_amb)

    def at25(name: str, label: str) -> float:  # 25 °C is the middle of the 20 and 30 °C columns
        return 0.5 * (table_value(name, label, 20, 0.5) + table_value(name, label, 30, 0.5))

    r0, r1, c, ocv = at25("r0", "r0"), at25("r1", "r1"), at25("c", "c"), at25("voc", "voc")
    rc_fraction = 1.0 - 1.0 / (1.0 + dt / (r1 * c))  # backward Euler charge of the RC branch
    voltage = ocv + current * r0 + current * r1 * rc_fraction
    heat = r0 * current**2 + r1 * (current * rc_fraction) ** 2
    soc = 0.5 + current * dt / 3600.0 / 60.0
    dvdt = 1e-4 + (5e-5 - 1e-4) * (soc - 0.6) / 0.1  # thermal.yaml: 1e-4 at SoC 0.6, 5e-5 at 0.7
    r_tot = 0.0061 + 0.1994
    temp = (138240.0 / dt * 298.15 + t_amb / r_tot + heat) / (138240.0 / dt + 1 / r_tot - dvdt * current)

    assert twin.current == pytest.approx(current, rel=1e-12)
    assert twin.soc == pytest.approx(soc, rel=1e-12)
    assert twin.voltage == pytest.approx(voltage, rel=1e-9)
    assert twin.voltage - ocv > 0  # the terminal voltage rises above the OCV while charging
    assert twin.heat == pytest.approx(heat, rel=1e-9)
    assert twin.temperature == pytest.approx(temp, rel=1e-12)
    assert twin.power == pytest.approx(voltage * current, rel=1e-9)  # energy in = V I dt


def test_constant_current_charge_over_several_steps() -> None:
    r0, r1, c, ocv = 0.05, 0.02, 9000.0, 350.0
    params = BatteryParams(grid=ParameterGrid.constant(r0, r1, c, ocv), init_soc=0.3)
    twin = BatteryTwin(params, TwinOptions(capacity_fade=False))
    twin.reset(temperature=298.15)
    current, dt, t_amb = 20.0, 600.0, 290.0
    rho = 1.0 / (1.0 + dt / (r1 * c))
    temp, r_tot = 298.15, params.r_cond + params.r_conv
    for n in range(1, 7):
        twin.step_current(current, dt, t_amb)
        i_r1 = current * (1.0 - rho**n)
        heat = r0 * current**2 + r1 * i_r1**2
        temp = (params.c_thermal / dt * temp + t_amb / r_tot + heat) / (params.c_thermal / dt + 1 / r_tot)
        assert twin.soc == pytest.approx(0.3 + n * current * dt / 3600.0 / 60.0, rel=1e-12)
        assert twin.voltage == pytest.approx(ocv + current * r0 + r1 * i_r1, rel=1e-9)
        assert twin.heat == pytest.approx(heat, rel=1e-9)
        assert twin.temperature == pytest.approx(temp, rel=1e-12)
        assert twin.surface_temperature == pytest.approx(temp + params.r_cond * (t_amb - temp) / r_tot, rel=1e-12)


def test_rest_relaxes_towards_ambient(params: BatteryParams) -> None:
    twin = BatteryTwin(params)
    twin.reset(soc=0.6, temperature=300.0)
    twin.step(0.0, 3600.0, 280.0)
    r_tot = params.r_cond + params.r_conv
    expected = (params.c_thermal / 3600 * 300.0 + 280.0 / r_tot) / (params.c_thermal / 3600 + 1 / r_tot)
    assert twin.temperature == pytest.approx(expected, rel=1e-12)
    assert twin.current == 0.0 and twin.heat == 0.0 and twin.soc == 0.6


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_soc_window_bounds_the_battery_and_the_clipped_part_is_reported(params: BatteryParams, fidelity: str) -> None:
    twin = BatteryTwin(params, TwinOptions.for_fidelity(fidelity))
    twin.reset(soc=0.95, temperature=293.15)
    applied = twin.step(10000.0, 3600.0, 293.15)  # 10 kWh into a battery with 3 % headroom
    assert twin.soc == pytest.approx(1.0, abs=1e-12)
    assert applied < 10000.0 and twin.clipped_power == pytest.approx(10000.0 - applied)
    assert twin.soc_violation > 0.3  # the request would have overfilled by ~0.4 of the capacity
    twin.reset(soc=0.25, temperature=293.15)
    twin.step(-10000.0, 3600.0, 293.15)
    assert twin.soc == pytest.approx(0.2, abs=1e-12)
    assert twin.clipped_power < 0


def test_power_limits_bound_the_current(params: BatteryParams) -> None:
    twin = BatteryTwin(params)
    twin.reset(soc=0.3, temperature=298.15)
    twin.step(30000.0, 60.0, 298.15)  # one minute: the SoC window allows far more than 60 A
    assert twin.current == pytest.approx(60.0, rel=1e-9)
    assert twin.soc_violation == 0.0  # clipped by the current bound, not by the SoC window
    loose = BatteryTwin(params, TwinOptions(power_limits=False))
    loose.reset(soc=0.3, temperature=298.15)
    loose.step(30000.0, 60.0, 298.15)
    assert loose.current > 60.0 and loose.clipped_power == 0.0


@settings(max_examples=50, deadline=None)
@given(powers=st.lists(st.floats(-8000, 8000), min_size=1, max_size=60))
def test_energy_is_conserved_and_soh_never_increases(powers: list[float]) -> None:
    twin = BatteryTwin(load_battery())
    twin.reset(soc=0.5, temperature=295.0)
    for p in powers:
        soh, soc, cap = twin.soh, twin.soc, twin.capacity
        applied = twin.step(p, 3600.0, 290.0)
        assert twin.voltage * twin.current == pytest.approx(applied, rel=1e-9, abs=1e-6)
        assert (twin.soc - soc) * cap == pytest.approx(twin.current, rel=1e-9, abs=1e-9)  # coulomb counting
        assert 0.2 - 1e-12 <= twin.soc <= 1.0 + 1e-12
        assert twin.soh <= soh
        assert applied + twin.clipped_power == pytest.approx(p)


def test_upstream_current_uses_the_previous_voltage(params: BatteryParams) -> None:
    twin = BatteryTwin(params, TwinOptions.for_fidelity("upstream"))
    twin.reset(soc=0.5, temperature=293.15)
    assert twin.voltage == 310.8  # the pack's init voltage, not the OCV
    twin.step(3000.0, 3600.0, 293.15)
    assert twin.current == pytest.approx(3000.0 / 310.8)
    assert twin.voltage * twin.current > 3000.0  # the energy moved differs from the request


def test_capacity_fade_scales_the_coulomb_counting(params: BatteryParams) -> None:
    faded = BatteryTwin(params)
    faded.reset(soc=0.5, temperature=298.15, soh=0.8)
    faded.step_current(10.0, 3600.0, 298.15)
    assert faded.soc == pytest.approx(0.5 + 10.0 / (60.0 * 0.8), rel=1e-12)
    nominal = BatteryTwin(params, TwinOptions(capacity_fade=False))
    nominal.reset(soc=0.5, temperature=298.15, soh=0.8)
    nominal.step_current(10.0, 3600.0, 298.15)
    assert nominal.soc == pytest.approx(0.5 + 10.0 / 60.0, rel=1e-12)


def test_end_of_life(params: BatteryParams) -> None:
    twin = BatteryTwin(params, eol_soh=0.6)
    twin.reset(soh=0.6000001)
    assert not twin.eol
    twin.step(0.0, 86400.0, 310.0)
    assert twin.eol


# -- bad configuration files ------------------------------------------------------------------------


def copy_battery(tmp: Path) -> Path:
    target = tmp / "battery"
    shutil.copytree(BATTERY_DIR, target)
    return target


def test_pack_yaml_without_a_key_names_the_file_and_key(tmp_path: Path) -> None:
    folder = copy_battery(tmp_path)
    pack = folder / "battery_pack.yaml"
    pack.write_text(pack.read_text().replace("nominal_capacity: 60.0", ""))
    with pytest.raises(DataFileError, match=r"battery_pack\.yaml.*battery\.params\.nominal_capacity"):
        load_battery(pack=pack)


def test_unparsable_yaml_is_a_data_file_error(tmp_path: Path) -> None:
    bad = tmp_path / "aging.yaml"
    bad.write_text("components: [unclosed\n")
    with pytest.raises(DataFileError, match=r"aging\.yaml"):
        load_battery(aging=bad)


def test_table_without_a_column_names_the_file_and_the_columns(tmp_path: Path) -> None:
    folder = copy_battery(tmp_path)
    table = folder / "params" / "r1_pack.csv"
    rows = [line.split(",") for line in table.read_text().splitlines()]
    table.write_text("\n".join(",".join([r[0], r[2]]) for r in rows))  # drop the `soc` column
    with pytest.raises(DataFileError, match=r"r1_pack\.csv.*lacks column\(s\) \['soc'\]"):
        load_battery(tables_dir=folder / "params")


def test_table_with_a_missing_grid_point_is_rejected(tmp_path: Path) -> None:
    folder = copy_battery(tmp_path)
    table = folder / "params" / "c_pack.csv"
    lines = table.read_text().splitlines()
    table.write_text("\n".join(lines[:-1]))  # truncated: the last (40 °C, SoC 1) point is gone
    with pytest.raises(DataFileError, match=r"c_pack\.csv"):
        load_battery(tables_dir=folder / "params")


def test_env_reports_a_bad_table(tmp_path: Path) -> None:
    from gym4real.microgrid import MicrogridEnv

    folder = copy_battery(tmp_path)
    table = folder / "params" / "voc_pack.csv"
    table.write_text(table.read_text().replace("voc", "ocv", 1))
    with pytest.raises(DataFileError, match=r"voc_pack\.csv.*\['voc'\]"):
        MicrogridEnv(battery={"tables_dir": str(folder / "params")})


@pytest.mark.parametrize("fidelity", ["corrected", "upstream"])
def test_power_limits_are_what_step_clips_to(params: BatteryParams, fidelity: str) -> None:
    twin = BatteryTwin(params, TwinOptions.for_fidelity(fidelity))
    twin.reset(soc=0.9, temperature=290.0)
    lo, hi = twin.power_limits(3600.0)
    assert lo < 0 < hi
    assert twin.step(1e6, 3600.0, 290.0) == pytest.approx(hi, rel=1e-12)
    twin.reset(soc=0.9, temperature=290.0)
    assert twin.step(-1e6, 3600.0, 290.0) == pytest.approx(lo, rel=1e-12)
    assert twin.snapshot()["clipped_power"] == pytest.approx(-1e6 - lo)


def test_scalar_components_replace_a_table(tmp_path: Path) -> None:
    folder = copy_battery(tmp_path)
    electrical = folder / "models" / "electrical.yaml"
    text = electrical.read_text()
    start = text.index("  r1:")
    electrical.write_text(text[:start] + text[start:].replace("selected_type: lookup", "selected_type: scalar", 1))
    params = load_battery(electrical=electrical)
    assert params.grid.bilinear(17.0, 0.33)[1] == 10.0  # the YAML's `scalar: 10.` of r1
    assert params.grid.bilinear(20.0, 0.5)[0] == table_value("r0", "r0", 20, 0.5)
