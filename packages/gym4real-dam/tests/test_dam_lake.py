from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gym4real.dam.lake import Lake, deficit_weight, np_sum

# The paper's Table "DamEnv's simulator parameters" (Lake Como), 24 hourly sub-steps.
COMO = {
    "surface": 145.9e6,
    "min_level": -0.5,
    "max_level": 1.25,
    "alpha": -2.5,
    "beta": 2.015,
    "C_r": 33.37,
    "linear_slope": 1488.1,
    "linear_intercept": 744.05,
    "linear_limit": -0.4,
}
LAKE = Lake(**COMO, substeps=24)
MEF = 5.0


def rating(h: float) -> float:
    return 33.37 * (h + 2.5) ** 2.015


@pytest.mark.parametrize(
    ("level", "expected"),
    [
        (-0.6, 0.0),  # below l_min: nothing
        (-0.5, 0.0),  # at l_min (closed): nothing
        (-0.45, 74.405),  # linear: 1488.1 * -0.45 + 744.05 (spec: 74.4)
        (-0.4, 148.81),  # at l_lim (closed): still linear (spec: 148.8)
        (0.0, 211.45),  # rating curve (spec: 211.4)
        (1.24, 476.09),  # spec: 476.1
        (1.25, 478.66),  # spec: 478.7
        (1.30, 491.61),  # the action bound is the rating curve at 1.30 m
    ],
)
def test_q_max_known_values(level: float, expected: float) -> None:
    assert LAKE.q_max(level) == pytest.approx(expected, abs=0.005)


def test_q_max_branches_at_the_boundaries() -> None:
    eps = 1e-9
    assert LAKE.q_max(-0.5 + eps) == pytest.approx(1488.1 * eps, rel=1e-3)  # linear starts at 0
    assert LAKE.q_max(-0.4) == pytest.approx(148.81, abs=1e-9)
    assert LAKE.q_max(-0.4 + eps) == pytest.approx(33.37 * 2.1**2.015, abs=1e-5)  # rating: 148.8086
    assert LAKE.q_max(-0.4 + eps) < LAKE.q_max(-0.4)  # the two branches do not meet exactly


@pytest.mark.parametrize(
    ("level", "expected"),
    [
        (-0.6, 0.0),
        (-0.5, 0.0),  # at l_min: 0
        (-0.5 + 1e-9, MEF),  # just above: the minimum environmental flow
        (0.35, MEF),
        (1.25, MEF),  # at l_max (closed): still the minimum flow
        (1.25 + 1e-9, rating(1.25)),  # above: forced onto the rating curve (478.66)
        (1.5, rating(1.5)),
    ],
)
def test_q_min_known_values(level: float, expected: float) -> None:
    assert LAKE.q_min(level, MEF) == pytest.approx(expected, rel=1e-9)


def test_release_is_the_decision_clipped_into_the_bounds() -> None:
    assert LAKE.release(0.35, 100.0, MEF) == 100.0
    assert LAKE.release(0.35, 0.0, MEF) == MEF  # raised to the minimum flow
    assert LAKE.release(0.35, 491.61, MEF) == pytest.approx(rating(0.35))  # capped by the rating curve
    assert LAKE.release(-0.45, 100.0, MEF) == pytest.approx(74.405)  # capped by the linear branch
    assert LAKE.release(-0.499, 100.0, MEF) == pytest.approx(1.4881, rel=1e-6)  # q_max below q_min wins
    assert LAKE.release(1.3, 0.0, MEF) == pytest.approx(491.61, abs=1e-3)  # flood: the rating curve
    assert LAKE.release(-0.7, 300.0, MEF) == 0.0


def test_storage_level_relation() -> None:
    assert LAKE.level_to_storage(0.35) == pytest.approx(1.24015e8)
    assert LAKE.storage_to_level(0.0) == -0.5
    assert LAKE.storage_to_level(LAKE.level_to_storage(1.1)) == pytest.approx(1.1)


def test_np_sum_matches_numpy_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    for n in (1, 5, 8, 24, 37, 128, 129, 300):
        values = rng.uniform(-500, 500, n).tolist()
        assert np_sum(values) == float(np.add.reduce(np.array(values)))
        assert np_sum(values) / n == float(np.mean(values))


def test_deficit_weight_peaks_in_summer() -> None:
    assert deficit_weight(0, True) == 1.0
    assert deficit_weight(182, True) == pytest.approx(2.0, abs=1e-4)
    assert [deficit_weight(d, False) for d in (119, 120, 242, 243)] == [1.0, 2.0, 2.0, 1.0]


levels = st.one_of(
    st.floats(-0.8, 3.0),
    st.floats(-0.52, -0.38),  # around l_min and l_lim
    st.floats(1.2, 1.3),  # around l_max
    st.sampled_from([-0.5, -0.4, 1.25]),
)
decisions = st.one_of(st.floats(0.0, 491.61), st.sampled_from([0.0, 5.0, 148.8086, 148.81, 245.805, 491.61]))
inflows = st.one_of(st.floats(0.0, 2000.0), st.floats(100.0, 200.0))


@settings(max_examples=400, deadline=None)
@given(
    level=levels,
    decision=decisions,
    inflow=inflows,
    evaporation=st.sampled_from([0.0, 0.0, 3.7]),
    substeps=st.sampled_from([24, 24, 1, 7, 48]),
)
def test_mass_balance_and_bounds_in_every_substep(
    level: float, decision: float, inflow: float, evaporation: float, substeps: int
) -> None:
    lake = Lake(**COMO, substeps=substeps)
    trace = lake.trace(lake.level_to_storage(level), decision, inflow, MEF, evaporation)
    dt = 86_400 / substeps
    for (s0, r), (s1, _) in itertools.pairwise(trace):
        h0, h1 = lake.storage_to_level(s0), lake.storage_to_level(s1)
        # level change times surface = (inflow - release - evaporation) * dt, up to rounding
        assert (h1 - h0) * lake.surface == pytest.approx(dt * (inflow - r - evaporation), rel=1e-9, abs=1e-2)
        assert lake.q_min(h0, MEF) - 1e-12 <= r or r == lake.q_max(h0)  # q_max wins where they cross
        assert r <= lake.q_max(h0) + 1e-12
        assert r >= 0.0
    # the fast integrator gives exactly the straightforward loop's storage and numpy mean
    storage, release = lake.day(trace[0][0], decision, inflow, MEF, evaporation)
    assert storage == trace[-1][0]
    assert release == float(np.mean([r for _, r in trace[:-1]]))


def test_level_range_bounds_every_reachable_level() -> None:
    low, high = LAKE.level_range(0.35, 2000.0)
    assert low == pytest.approx(-0.5, abs=1e-6)  # the lake never drains below l_min without evaporation
    # the equilibrium of the rating curve with 2000 m3/s plus one hour of that inflow
    assert high == pytest.approx(-2.5 + (2000 / 33.37) ** (1 / 2.015) + 3600 * 2000 / 145.9e6, abs=1e-6)
    s = LAKE.level_to_storage(0.35)
    for _ in range(365):  # full inflow, no release: stays below the bound
        s, _ = LAKE.day(s, 0.0, 2000.0, MEF, 0.0)
        assert LAKE.storage_to_level(s) <= high
    with pytest.raises(ValueError, match="integration"):
        Lake(**{**COMO, "surface": 1e6}, substeps=1).level_range(0.35, 2000.0)
    assert LAKE.level_range(0.35, 2000.0, 0.25) == pytest.approx((low - 0.25, high), abs=1e-12)
