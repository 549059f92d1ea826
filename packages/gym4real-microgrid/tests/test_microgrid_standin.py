"""The stand-in training households: layout of the real file, calibration, reproducibility, and which file
the ``train`` preset uses."""

from __future__ import annotations

import json
import random
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from gym4real.core import datasets
from gym4real.core.datasets import sha256_of
from gym4real.core.errors import DataFileError, Gym4RealError
from gym4real.microgrid import standin
from gym4real.microgrid.env import MicrogridEnv


def _fake_standin(folder: Path, households: int = 3) -> Path:
    """A file in the stand-in's place and layout (values from a generator, not the model: a fast test)."""
    rng = np.random.default_rng(0)
    frame = pd.DataFrame(rng.uniform(50, 2000, size=(standin.HOURS, households)), columns=map(str, range(households)))
    frame["delta_time"] = np.arange(standin.HOURS) * 3600.0
    path = folder / standin.PATH
    path.parent.mkdir(parents=True)
    frame.to_csv(path, index=False)
    return path


def test_the_train_preset_without_any_training_file_names_both_fixes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(DataFileError, match=r"profiles_train\.csv.*gym4real data synthesize microgrid"):
        MicrogridEnv(preset="train")


def test_the_train_preset_runs_on_the_stand_in_and_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    path = _fake_standin(tmp_path / "cache")
    env = MicrogridEnv(preset="train")
    _, info = env.reset(seed=0)
    assert info["demand_source"] == "stand-in"
    assert env.world.labels == ("0", "1", "2")
    assert path.exists()


def test_the_provenance_of_a_run_records_the_stand_in_it_reads_with_its_hash(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gym4real.results.provenance import data_files

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    row = next(r for r in data_files("gym4real/microgrid-v0") if r["name"] == standin.STANDS_IN_FOR)
    assert row["found"] == "no" and "read_instead" not in row  # neither file: nothing read in its place
    path = _fake_standin(tmp_path / "cache")
    row = next(r for r in data_files("gym4real/microgrid-v0") if r["name"] == standin.STANDS_IN_FOR)
    assert row["found"] == "no"
    assert row["read_instead"] == {"path": standin.PATH, "sha256": sha256_of(path), "found": "user cache"}


def test_the_real_training_file_is_preferred_to_the_stand_in(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    _fake_standin(tmp_path / "cache", households=3)
    real = tmp_path / "data" / "microgrid" / "demand" / "profiles_train.csv"
    real.parent.mkdir(parents=True)
    frame = pd.DataFrame(np.full((standin.HOURS, 2), 500.0), columns=["7", "8"])
    frame["delta_time"] = np.arange(standin.HOURS) * 3600.0
    frame.to_csv(real, index=False)
    # the real file is not available offline: this copy stands for it, its checksum taken as registered
    intact = datasets.is_intact
    monkeypatch.setattr(datasets, "is_intact", lambda spec, path: path == real or intact(spec, path))
    env = MicrogridEnv(preset="train", data_dir=str(tmp_path / "data"))
    _, info = env.reset(seed=0)
    assert info["demand_source"] == "real"
    assert env.world.labels == ("7", "8")


def test_gym4real_info_says_which_training_households_the_train_preset_reads(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gym4real.cli.envs import summary

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    assert "missing" in summary("gym4real/microgrid-v0")["training_data"]
    _fake_standin(tmp_path / "cache")
    assert "stand-in" in summary("gym4real/microgrid-v0")["training_data"]
    assert summary("gym4real/dam-v0")["training_data"] is None  # a domain without a stand-in says nothing


def test_synthesize_names_a_domain_without_a_stand_in(capsys: pytest.CaptureFixture[str]) -> None:
    from gym4real.cli import main

    assert main(["data", "synthesize", "dam"]) != 0
    assert "domain `dam` has no stand-in data" in capsys.readouterr().err


def test_training_on_fewer_stand_in_households_than_the_papers_warns_once_naming_the_count(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gym4real.microgrid.data import StandInWarning

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    _fake_standin(tmp_path / "cache", households=3)
    with pytest.warns(StandInWarning) as caught:
        for _ in range(2):  # a second env (a second run of a plan) says nothing new
            MicrogridEnv(preset="train").close()
    (warning,) = [w for w in caught if issubclass(w.category, StandInWarning)]
    assert "training on 3 stand-in households" in str(warning.message)
    assert f"fewer than the {standin.HOUSEHOLDS}" in str(warning.message)
    assert "gym4real data synthesize microgrid" in str(warning.message)


def test_data_list_shows_the_stand_in_in_place_of_the_missing_training_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from gym4real.cli import main

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    assert datasets.find(standin.STANDS_IN_FOR) is None  # the paper's file is not in the data folder
    assert main(["data", "list", "microgrid"]) == 0
    assert "1 missing (microgrid/demand/train)" in capsys.readouterr().out
    path = _fake_standin(tmp_path / "cache")
    assert main(["data", "list", "microgrid"]) == 0
    out = capsys.readouterr().out
    (row,) = [line.split(maxsplit=3) for line in out.splitlines() if line.startswith(f"{standin.STANDS_IN_FOR} ")]
    assert row[3:] == [f"stand-in  user cache ({path.name})"]
    assert "missing" not in out and "Fix:" not in out


def test_synthesize_without_the_load_model_says_how_to_install_it_before_anything_else(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import sys

    from gym4real.cli import main

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setitem(sys.modules, "richardsonpy", None)  # not installed: its import fails
    assert main(["data", "synthesize", "microgrid", "--households", "2"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gym4real: error: ") and "`pip install richardsonpy`" in err  # no progress bar drawn first
    assert not (tmp_path / "cache").exists()  # nothing written


def test_synthesize_says_what_it_writes_and_its_expected_time_then_a_short_progress_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from gym4real.cli import main

    written: list[tuple[int, int]] = []

    def synthesize(out: Path, households: int, jobs: int, progress: Any, **_: object) -> Path:
        written.append((households, jobs))
        for done in range(1, households + 1):
            progress(done, households)
        out.parent.mkdir(parents=True)
        out.write_text("stand-in")
        return out

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(standin, "check_tools", lambda: None)
    monkeypatch.setattr(standin, "synthesize", synthesize)
    assert main(["data", "synthesize", "microgrid", "--households", "40", "--jobs", "2"]) == 0
    assert written == [(40, 2)]
    first, *lines = capsys.readouterr().err.splitlines()
    assert first.startswith(f"writing {standin.DESCRIPTION} of microgrid to {tmp_path / 'cache' / standin.PATH}: ")
    assert f"40 households with 2 worker process(es), {standin.expected_time(40, 2)}" in first
    # not a terminal: a line after the first household and at each tenth, not one per household (nor a
    # bar's redraws)
    expected = [f"synthesize microgrid: {n}/40 households" for n in [1, *range(4, 41, 4)]]
    assert [line.split(" (")[0] for line in lines] == expected


def test_the_expected_time_counts_the_households_of_the_busiest_worker() -> None:
    from gym4real.microgrid.data import SECONDS_OVERHEAD, SECONDS_PER_HOUSEHOLD

    assert standin.expected_time(40, 2).startswith(f"about {SECONDS_OVERHEAD + 20 * SECONDS_PER_HOUSEHOLD:.0f} s")
    seconds = SECONDS_OVERHEAD + standin.HOUSEHOLDS * SECONDS_PER_HOUSEHOLD
    assert standin.expected_time(standin.HOUSEHOLDS, 1).startswith(f"about {seconds / 60:.0f} min")
    assert "measured" in standin.expected_time()


def test_reproduce_without_either_training_file_names_the_command_that_writes_the_stand_in_and_its_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("stable_baselines3")
    from gym4real.microgrid.data import synthesis_time
    from gym4real.results.reproduce import reproduce

    monkeypatch.setenv("GYM4REAL_CACHE_DIR", str(tmp_path / "cache"))
    text = reproduce(["gym4real/microgrid-v0"], "paper", 1, tmp_path / "out")
    (line,) = [line for line in text.splitlines() if line.startswith("== gym4real/microgrid-v0")]
    assert "not run" in line and "`gym4real data synthesize microgrid`" in line
    assert f"({synthesis_time()} for the {standin.HOUSEHOLDS} households on one core" in line


def test_the_fit_figure_is_drawn_from_the_two_files(tmp_path: Path) -> None:
    fake = _fake_standin(tmp_path)
    out = standin.fit_figure(fake, datasets.resolve("microgrid/demand/test"), tmp_path / "fit.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_test_preset_env_reports_real_demand() -> None:
    _, info = MicrogridEnv(preset="test").reset(seed=0)
    assert info["demand_source"] == "real"


def test_annual_targets_average_to_the_arera_reference_household() -> None:
    pytest.importorskip("richardsonpy")
    targets = standin.annual_targets()
    shares = standin.HOUSEHOLD_SIZES
    mean = sum(shares[k] * targets[k] for k in shares) / sum(shares.values())
    assert mean == pytest.approx(standin.ANNUAL_KWH)
    assert all(targets[k] < targets[k + 1] for k in range(1, 5))  # larger households use more


def test_household_sizes_follow_the_istat_shares() -> None:
    sizes = np.array([standin.household_size(i, standin.SEED) for i in range(standin.HOUSEHOLDS)])
    for size, share in standin.HOUSEHOLD_SIZES.items():
        # binomial standard error of a share over 370 households is at most 0.026: 4 of them
        assert abs(np.mean(sizes == size) - share) < 0.1


def test_a_synthesized_file_has_the_real_layout_its_calibration_and_is_reproducible(tmp_path: Path) -> None:
    pytest.importorskip("richardsonpy")
    pytest.importorskip("numba")
    path = standin.synthesize(tmp_path / "profiles_train_standin.csv", households=1, seed=7)
    frame = pd.read_csv(path)
    # the layout of profiles_test.csv: one column per household (W), then delta_time (s)
    real = pd.read_csv(datasets.resolve("microgrid/demand/test"), nrows=2)
    assert list(real.columns)[-1] == "delta_time"
    assert list(frame.columns) == ["0", "delta_time"]
    assert len(frame) == 8760
    assert np.all(np.diff(frame["delta_time"]) == 3600.0)
    power = frame["0"].to_numpy()
    assert np.all(np.isfinite(power)) and power.min() >= 0
    provenance = json.loads(path.with_suffix(".json").read_text())
    assert provenance["sha256"] == sha256_of(path)
    assert provenance["seed"] == 7
    # the file's mean annual energy is ARERA's reference household's (to the CSV's 6 decimals)
    assert power.sum() / 1000 == pytest.approx(standin.ANNUAL_KWH, rel=1e-6)
    # the model's own level is within a small factor of its calibration target (one household of seed 7
    # overshoots it 2.4 times: lighting and chance); a unit error, W for kW, would be a factor of 1000
    assert 0.2 < provenance["calibration"]["mean_scaling_factor"] < 5.0
    # the same (index, seed) is the same household, bit for bit
    assert np.array_equal(standin.household(0, 7), np.load(path.with_name(".profiles_train_standin-seed7") / "0.npy"))
    hours = power.reshape(365, 24).mean(axis=0)
    assert hours[18:22].mean() > hours[2:5].mean()  # an evening peak above the night's base load


def test_the_compiled_generator_draws_pythons_random_stream_bit_for_bit() -> None:
    pytest.importorskip("numba")
    from gym4real.microgrid import standin_kernel

    python = random.Random(2015 * 1000 + 7)
    python.gauss(0.0, 1.0)  # a normal deviate is pending: the compiled one starts with it
    words, cached = standin_kernel.random_state(python.getstate())
    for k in range(3000):  # several refills of the 624 state words
        if k % 3:
            assert standin_kernel.random_float(words) == python.random()
        else:
            assert standin_kernel.gauss(words, cached, 60.0, 10.0) == python.gauss(60.0, 10.0)
    assert standin_kernel.random_state(python.getstate())[0].tolist() == words.tolist()


def _richardsonpy_days(index: int, seed: int, days: int) -> np.ndarray:
    """The first ``days`` days of a household as richardsonpy computes them, one ``power_sim`` a day (the oracle)."""
    import richardsonpy.classes.appliance as appliance
    import richardsonpy.classes.lighting as lighting
    import richardsonpy.classes.occupancy as occupancy
    import richardsonpy.classes.stochastic_el_load_wrapper as wrapper
    import richardsonpy.functions.change_resolution as resolution
    import richardsonpy.functions.load_radiation as radiation

    inputs = Path(occupancy.__file__).parents[1] / "inputs"
    size = standin.household_size(index, seed)
    random.seed(seed * 1000 + index)
    occupants = occupancy.Occupancy(number_occupants=size, initial_day=standin.FIRST_WEEKDAY).occupancy
    annual = 0.91 * standin.annual_targets()[size]  # ElectricLoad's appliance share (lighting is 9 %)
    appliances = appliance.Appliances(
        str(inputs / "Appliances.csv"), annual, randomize_appliances=True, prev_heat_dev=True
    )
    profile = wrapper.ElectricityProfile(appliances, lighting.load_lighting_profile(str(inputs / "LightBulbs.csv")))
    direct, diffuse = radiation.get_rad_from_try_path()
    irradiance = resolution.change_resolution(direct, 3600, 60) + resolution.change_resolution(diffuse, 3600, 60)
    out = []
    for day in range(days):
        minutes = np.interp(np.arange(1440), 60 * np.arange(1440), irradiance[1440 * day : 1440 * (day + 1)])
        weekend = (day + standin.FIRST_WEEKDAY) % 7 in (0, 6)
        total, _, _ = profile.power_sim(minutes, weekend, day, occupants[144 * day : 144 * (day + 1)])
        out.append(total)
    return np.concatenate(out)


@pytest.mark.parametrize("index", [1, 8])  # five members and one (seed 2015)
def test_compiled_households_are_richardsonpys_minute_by_minute_bit_for_bit(index: int) -> None:
    pytest.importorskip("richardsonpy")
    pytest.importorskip("numba")
    days = 9  # a weekend and both weekday kinds of start
    reference = _richardsonpy_days(index, standin.SEED, days)
    compiled = standin.household_minutes(index, standin.SEED, days=days)
    assert compiled.shape == (days * 1440,)
    assert np.array_equal(compiled, reference)
    assert compiled.max() > 1000  # an appliance ran: not an empty day that any code would match


@pytest.mark.slow
def test_a_compiled_household_year_is_richardsonpys_electric_load_bit_for_bit() -> None:
    """The whole year against richardsonpy's ElectricLoad, as the published stand-in was first written."""
    pytest.importorskip("richardsonpy")
    pytest.importorskip("numba")
    import richardsonpy.classes.electric_load as eload
    import richardsonpy.classes.occupancy as occupancy
    import richardsonpy.functions.change_resolution as resolution
    import richardsonpy.functions.load_radiation as radiation

    index, seed = 3, standin.SEED
    size = standin.household_size(index, seed)
    random.seed(seed * 1000 + index)
    occupants = occupancy.Occupancy(number_occupants=size, initial_day=standin.FIRST_WEEKDAY)
    direct, diffuse = radiation.get_rad_from_try_path()
    load = eload.ElectricLoad(
        occ_profile=occupants.occupancy,
        total_nb_occ=size,
        q_direct=resolution.change_resolution(direct, old_res=3600, new_res=60),
        q_diffuse=resolution.change_resolution(diffuse, old_res=3600, new_res=60),
        annual_demand=standin.annual_targets()[size],
        is_sfh=False,
        prev_heat_dev=True,
        timestep=60,
        initial_day=standin.FIRST_WEEKDAY,
    )
    reference = np.asarray(load.loadcurve, dtype=np.float64).reshape(standin.HOURS, 60).mean(axis=1)
    assert np.array_equal(standin.household(index, seed), reference)


def test_the_file_is_the_same_with_one_or_two_worker_processes(tmp_path: Path) -> None:
    pytest.importorskip("richardsonpy")
    pytest.importorskip("numba")
    one = standin.synthesize(tmp_path / "one" / "standin.csv", households=3, seed=11, jobs=1)
    done: list[int] = []
    two = standin.synthesize(
        tmp_path / "two" / "standin.csv", households=3, seed=11, jobs=2, progress=lambda d, _: done.append(d)
    )
    assert one.read_bytes() == two.read_bytes()
    assert done == [1, 2, 3]
    assert json.loads(two.with_suffix(".json").read_text())["sha256"] == sha256_of(one)


def test_the_worker_processes_are_not_forked_from_a_threaded_process(tmp_path: Path) -> None:
    """A forked child of a multithreaded process (JAX, torch) can deadlock; JAX warns at every fork."""
    pytest.importorskip("richardsonpy")
    pytest.importorskip("numba")
    jnp = pytest.importorskip("jax.numpy")
    jnp.zeros(1).block_until_ready()  # JAX's backend (its threads and its at-fork warning) started
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        standin.synthesize(tmp_path / "standin.csv", households=2, seed=11, jobs=2)
    assert not [w for w in caught if "fork" in str(w.message)]


def test_synthesize_without_numba_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    pytest.importorskip("richardsonpy")
    monkeypatch.setitem(sys.modules, "numba", None)  # not installed: its import fails
    with pytest.raises(Gym4RealError, match=r"pip install 'gym4real-microgrid\[fast\]'"):
        standin.check_tools()


def test_the_published_stand_ins_hash_is_the_one_the_results_page_records() -> None:
    manifest = json.loads((Path(__file__).parents[3] / "docs" / "results" / "manifest.json").read_text())
    recorded = {
        row["read_instead"]["sha256"]
        for rows in manifest["data_files"].values()
        for row in rows
        if row.get("read_instead", {}).get("path") == standin.PATH
    }
    assert recorded == {standin.PUBLISHED["sha256"]}


def test_the_docs_quote_the_measured_time_of_the_command_on_two_cores() -> None:
    from gym4real.microgrid.data import synthesis_time

    root = Path(__file__).parents[3]
    quoted = f"{synthesis_time(standin.HOUSEHOLDS, 2)} on 2 idle cores"
    for page in (root / "README.md", root / "docs" / "microgrid-standin.md", Path(__file__).parents[1] / "README.md"):
        assert quoted in " ".join(page.read_text(encoding="utf-8").split()), page.name
