"""Stand-in training households of MicrogridEnv: synthetic demand from the Richardson load model.

The paper trains on 370 households (``profiles_train.csv``) that are published nowhere we can reach. This
module writes a documented stand-in in the layout of that file (columns ``0`` .. ``369`` in W, one row
per hour of one year, ``delta_time`` in s): each household is one year of the Richardson et al. (2010)
domestic electricity demand model (occupancy Markov chain, appliance and lighting activity; validated on
measured UK households), as packaged in ``richardsonpy`` (RWTH-EBC, GPL-3.0; a tool of this command,
never a runtime dependency of gym4real).

Calibration to Italian households, never to the test households:

* household size: drawn from ISTAT's distribution of Italian households by number of members
  (:data:`HOUSEHOLD_SIZES`; ISTAT, Annuario statistico italiano 2022, ch. 3 "Popolazione e famiglie");
* annual energy: each household's model is calibrated (its appliance activity) to the reference
  consumption of a flat of its size (richardsonpy's multi-family table, Stromspiegel 2014) scaled so that
  the mean over ISTAT's sizes is 2,700 kWh per year, the consumption of ARERA's reference domestic
  customer ("cliente domestico tipo", 3 kW, 2,700 kWh/year); lighting and chance move each household off
  its target, so the whole file is then multiplied by one factor that makes the households' mean annual
  energy exactly 2,700 kWh (the factor is in the provenance); the spread between households is the model's;
* no electric space heating or hot water (``prev_heat_dev``): Italian homes heat mostly with gas;
* daily shape: the model's own (UK-validated) activity statistics; no published Italian hourly shape is
  bundled here, so the shape is not fitted to one (the docs show it beside the test households').

The file is reproducible: every household draws from its own seed (``seed * 1000 + index``), whatever
the number of worker processes, and the provenance beside the file (``profiles_train_standin.json``)
records the model, its version, the seed, the calibration and the SHA-256 of the CSV. richardsonpy draws
each household's occupancy and appliances; its minute-by-minute days run compiled
(:mod:`gym4real.microgrid.standin_kernel`, numba), bit for bit as richardsonpy runs them, about 50 times
faster. ``gym4real data synthesize microgrid`` writes the file into the user cache, where the ``train``
preset finds it when the real file is absent.
"""

from __future__ import annotations

import functools
import json
import multiprocessing
import random
import sys
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from gym4real.core.errors import DataFileError, Gym4RealError
from gym4real.microgrid.data import (
    DOMAIN,
    PAPER_HOUSEHOLDS,
    SECONDS_OVERHEAD,
    SECONDS_PER_HOUSEHOLD,
    STAND_IN,
    TRAIN_DEMAND,
    synthesis_time,
    training_demand,
)

#: Households of the paper's training file.
HOUSEHOLDS = PAPER_HOUSEHOLDS
#: What ``gym4real data synthesize microgrid`` writes (said at its start).
DESCRIPTION = "synthetic stand-in training households (Richardson load model, not real households)"
#: Default seed of the stand-in (the file's provenance records it).
SEED = 2015
#: The stand-in the published microgrid runs trained on (docs/results, section microgrid-v0-paper): its
#: households, seed and the SHA-256 of its CSV, which the same command writes again byte for byte.
PUBLISHED = {
    "households": PAPER_HOUSEHOLDS,
    "seed": SEED,
    "sha256": "29e71466e3ce6e69c6c5ba00f2ca2124b7f3349f594089877f67a6332be9675f",
}
#: Path of the stand-in under a data folder (beside the real ``demand/profiles_train.csv``).
PATH = STAND_IN
#: The registered data file it stands in for (read in its place when that one is absent).
STANDS_IN_FOR = f"{DOMAIN}/{TRAIN_DEMAND}"
#: Share of Italian households by number of members (ISTAT, Annuario statistico italiano 2022; 5: five or more).
HOUSEHOLD_SIZES = {1: 0.332, 2: 0.271, 3: 0.192, 4: 0.150, 5: 0.055}
#: Annual consumption of ARERA's reference domestic customer, kWh.
ANNUAL_KWH = 2700.0
#: Weekday of the first day (1 Monday .. 7 Sunday): 2015-01-01, the first day of the training split, a Thursday.
FIRST_WEEKDAY = 4
HOURS = 8760
DAYS = HOURS // 24
#: Share of a household's annual energy its appliances use (richardsonpy's ElectricLoad: 9 % is lighting).
APPLIANCE_SHARE = 0.91


def status(data_dir: str | Path | None = None) -> str:
    """Which training households the ``train`` preset reads: the real file, the stand-in, or neither."""
    try:
        path, source = training_demand(data_dir)
    except DataFileError:
        return "training households missing: `gym4real data synthesize microgrid` writes the stand-in"
    if source == "real":
        return f"training households: the real profiles_train.csv ({path})"
    return "training households: the synthetic stand-in (Richardson model, not real households; see its .json)"


def _richardson() -> Any:
    try:
        import richardsonpy
    except ImportError as exc:
        raise Gym4RealError(
            "the stand-in training households are generated with the Richardson load model: `pip install "
            "richardsonpy` (GPL-3.0, needed only by this command), then run it again"
        ) from exc
    return richardsonpy


def check_tools() -> None:
    """Refuse, before anything is written, when the load model or numba is missing (with its ``pip install``)."""
    _richardson()
    try:
        import numba  # noqa: F401
    except ImportError as exc:
        raise Gym4RealError(
            "the stand-in's households run compiled with numba: `pip install 'gym4real-microgrid[fast]'`, then run "
            "it again"
        ) from exc


def expected_time(households: int = HOUSEHOLDS, jobs: int = 1) -> str:
    """How long :func:`synthesize` takes for ``households`` with ``jobs`` worker processes, and on what it rests.

    ``about 82 s on idle cores (measured: 0.42 s of CPU per household, 4 s to start and write the file)``.
    """
    return (
        f"{synthesis_time(households, jobs)} on idle cores (measured: {SECONDS_PER_HOUSEHOLD} s of CPU per "
        f"household, {SECONDS_OVERHEAD:.0f} s to start and write the file)"
    )


def annual_targets() -> dict[int, float]:
    """Reference annual energy (kWh) per household size: the model's flat table scaled to ARERA's mean."""
    from richardsonpy.classes.electric_load import ElectricLoad

    flat = ElectricLoad.standard_consumption["MFH"]
    mean = sum(share * flat[size] for size, share in HOUSEHOLD_SIZES.items()) / sum(HOUSEHOLD_SIZES.values())
    return {size: flat[size] * ANNUAL_KWH / mean for size in HOUSEHOLD_SIZES}


def household_size(index: int, seed: int) -> int:
    """The number of members of household ``index``, drawn from ISTAT's distribution."""
    rng = np.random.default_rng([seed, index])
    sizes = np.array(list(HOUSEHOLD_SIZES))
    shares = np.array(list(HOUSEHOLD_SIZES.values()))
    return int(rng.choice(sizes, p=shares / shares.sum()))


@functools.cache
def _model() -> dict[str, np.ndarray]:
    """The household-independent inputs of richardsonpy, as arrays of :func:`standin_kernel.simulate_year`.

    The irradiance of each day is interpolated to minutes as its ``ElectricLoad`` does (the test reference
    year of its TRY weather file); the light bulbs are its first lighting configuration.
    """
    import richardsonpy.classes.lighting as lighting
    import richardsonpy.classes.stochastic_el_load_wrapper as wrapper
    import richardsonpy.functions.change_resolution as resolution
    import richardsonpy.functions.load_radiation as radiation

    direct, diffuse = radiation.get_rad_from_try_path()
    irradiance = resolution.change_resolution(direct, old_res=3600, new_res=60) + resolution.change_resolution(
        diffuse, old_res=3600, new_res=60
    )
    minutes = np.arange(1440)
    days = [np.interp(minutes, 60 * minutes, irradiance[1440 * d : 1440 * (d + 1)]) for d in range(DAYS)]
    config = lighting.LightingModelConfiguration()
    wrapper.ElectricityProfile(None, None)  # loads its activity statistics
    activity = wrapper.ElectricityProfile.activity_statistics
    return {
        "irradiance": np.array(days),
        "bulbs": np.array(lighting.load_lighting_profile(_input("LightBulbs.csv"), index=0)),
        "lighting": np.array([config.ext_irr_threshold_mean, config.ext_irr_threshold_std_dev, config.calib_scalar]),
        "effective": np.array(config.eff_occupancy, dtype=np.float64),
        "lower": np.array(config.light_event_lower_value, dtype=np.float64),
        "upper": np.array(config.light_event_upper_value, dtype=np.float64),
        "activity": np.array([activity["wd"], activity["we"]]),
    }


def _input(name: str) -> str:
    """Path of one of richardsonpy's input tables."""
    return str(Path(_richardson().__file__).parent / "inputs" / name)


def household_minutes(index: int, seed: int = SEED, days: int = DAYS) -> np.ndarray:
    """Power (W) of household ``index`` in each minute of its first ``days`` days: a pure function of its arguments.

    richardsonpy draws the household's occupancy and appliances from Python's generator seeded with
    ``seed * 1000 + index``; its days then run compiled (:func:`standin_kernel.simulate_year`), drawing on
    from the same generator: bit for bit richardsonpy's ``ElectricLoad`` (appliances calibrated to the
    size's :func:`annual_targets` less lighting's share, no electric heating).
    """
    import richardsonpy.classes.appliance as appliance
    import richardsonpy.classes.occupancy as occupancy

    from gym4real.microgrid import standin_kernel

    size = household_size(index, seed)
    random.seed(seed * 1000 + index)
    occupants = occupancy.Occupancy(number_occupants=size, initial_day=FIRST_WEEKDAY)
    appliances = appliance.Appliances(
        _input("Appliances.csv"),
        annual_consumption=APPLIANCE_SHARE * annual_targets()[size],
        randomize_appliances=True,
        prev_heat_dev=True,
    )
    model = _model()
    words, cached = standin_kernel.random_state(random.getstate())
    return standin_kernel.simulate_year(
        words,
        cached,
        np.asarray(occupants.occupancy, dtype=np.int64),
        model["irradiance"][:days],
        FIRST_WEEKDAY,
        model["bulbs"],
        model["lighting"],
        model["effective"],
        model["lower"],
        model["upper"],
        np.array(appliances.data),
        np.array(appliances.calib_scalar),
        model["activity"],
    )


def household(index: int, seed: int = SEED) -> np.ndarray:
    """One year of hourly mean power (W) of household ``index``: a pure function of ``(index, seed)``."""
    return household_minutes(index, seed).reshape(HOURS, 60).mean(axis=1)


def _write_household(index: int, seed: int, staging: Path) -> int:
    """Write household ``index`` into the staging folder (whole or not at all: a resumed run reuses it)."""
    tmp = staging / f"{index}.npy.tmp"
    with tmp.open("wb") as f:
        np.save(f, household(index, seed))
    tmp.replace(staging / f"{index}.npy")
    return index


def synthesize(
    out: str | Path,
    households: int = HOUSEHOLDS,
    seed: int = SEED,
    jobs: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Write the stand-in CSV (and its provenance JSON beside it) to ``out``; return its path.

    Each household is a pure function of ``(index, seed)`` (:func:`household`), so the file is the same
    whatever the number of worker processes and the order they finish in. Households already generated
    for the same seed (in the staging folder beside ``out``) are reused, so an interrupted run resumes.

    Args:
        out: Path of the CSV to write.
        households: Number of households (columns ``0`` .. ``households - 1``).
        seed: Seed of the whole file.
        jobs: Worker processes.
        progress: Called with ``(done, total)`` after each household.
    """
    richardsonpy = _richardson()
    out = Path(out)
    staging = out.with_name(f".{out.stem}-seed{seed}")
    staging.mkdir(parents=True, exist_ok=True)
    todo = [i for i in range(households) if not (staging / f"{i}.npy").exists()]
    done = households - len(todo)
    if jobs > 1 and len(todo) > 1:
        spawn = multiprocessing.get_context("spawn")  # a forked child of a threaded process (JAX, torch) can hang
        with ProcessPoolExecutor(min(jobs, len(todo)), mp_context=spawn) as pool:
            for future in as_completed([pool.submit(_write_household, i, seed, staging) for i in todo]):
                future.result()
                done += 1
                if progress:
                    progress(done, households)
    else:
        for i in todo:
            _write_household(i, seed, staging)
            done += 1
            if progress:
                progress(done, households)
    raw = np.stack([np.load(staging / f"{i}.npy") for i in range(households)], axis=1)
    factor = ANNUAL_KWH * 1000 * households / raw.sum()
    power = raw * factor
    header = ",".join([*(str(i) for i in range(households)), "delta_time"])
    rows = np.column_stack([power, np.arange(HOURS) * 3600.0])
    tmp = out.with_suffix(".csv.tmp")
    np.savetxt(tmp, rows, fmt="%.6f", delimiter=",", header=header, comments="")
    tmp.replace(out)
    from gym4real.core.datasets import sha256_of

    provenance = {
        "what": "stand-in for the paper's 370 training households (profiles_train.csv), not real households",
        "model": "Richardson et al. (2010), Energy and Buildings 42(10): domestic electricity demand model",
        "package": f"richardsonpy {richardsonpy.__version__}",
        "households": households,
        "seed": seed,
        "household_sizes": [household_size(i, seed) for i in range(households)],
        "calibration": {
            "household_size_shares": {str(k): v for k, v in HOUSEHOLD_SIZES.items()},
            "household_size_source": "ISTAT, Annuario statistico italiano 2022, ch. 3",
            "annual_kwh_by_size": {str(k): v for k, v in annual_targets().items()},
            "annual_kwh_source": "ARERA reference domestic customer (3 kW, 2,700 kWh/year), relative sizes from "
            "richardsonpy's multi-family table (Stromspiegel 2014)",
            "mean_scaling_factor": factor,
            "electric_heating": False,
            "first_weekday": FIRST_WEEKDAY,
        },
        "annual_kwh": {"mean": float(power.sum(axis=0).mean() / 1000), "per_household": (power.sum(0) / 1000).tolist()},
        "python": sys.version.split()[0],
        "numpy": metadata.version("numpy"),
        "sha256": sha256_of(out),
        "command": f"gym4real data synthesize microgrid --households {households} --seed {seed}",
    }
    out.with_suffix(".json").write_text(json.dumps(provenance, indent=1))
    return out


def fit_figure(standin_csv: str | Path, test_csv: str | Path, out: str | Path) -> Path:
    """The stand-in beside the real test households: mean daily profile (weekdays, weekends) and annual energy.

    A figure of the docs, drawn with matplotlib (the ``bench`` extra of gym4real-core, not a dependency of this
    distribution).

    Args:
        standin_csv: A stand-in file (:func:`synthesize`).
        test_csv: The test households (``microgrid/demand/profiles_test.csv``).
        out: PNG to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    fig, (daily, annual) = plt.subplots(1, 2, figsize=(10, 3.8))
    energies = []
    for path, label, color in ((standin_csv, "stand-in", "tab:orange"), (test_csv, "test households", "tab:blue")):
        frame = pd.read_csv(path)
        power = frame.drop(columns=["delta_time"]).to_numpy(dtype=float)[:HOURS]
        days = power.reshape(HOURS // 24, 24, -1)
        shape = days.mean(axis=(0, 2)) / 1000
        daily.plot(range(24), shape, marker="o", color=color, label=f"{label} ({power.shape[1]})")
        energies.append((label, power.sum(axis=0) / 1000, color))
    daily.set(xlabel="hour of the day", ylabel="mean power (kW)", title="mean daily profile, whole year")
    daily.legend(fontsize=8)
    annual.boxplot([e for _, e, _ in energies], tick_labels=[label for label, _, _ in energies])
    for i, (_, e, color) in enumerate(energies, start=1):
        annual.scatter(np.full(len(e), i) + np.linspace(-0.15, 0.15, len(e)), e, s=10, color=color, zorder=3)
    annual.axhline(ANNUAL_KWH, color="grey", ls="--", lw=1, label="ARERA reference household (2,700 kWh)")
    annual.set(ylabel="annual energy (kWh)", title="annual energy per household")
    annual.legend(fontsize=8)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
