"""Run diagnostics and the gear-travel check against constructed signals whose answers
are known, and the closed-loop modes against a hand-derived characteristic polynomial."""

import json

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from ltdsim.analysis.diagnostics import (
    base_run_diagnostics, closed_loop_modes, cruise_window, oscillation, reference_corners,
)
from ltdsim.results.summary import (column_max, column_min, gear_travel_check, run_summary,
                             travel_warning)

from conftest import build, train_dict

fin = dict(allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(amp=st.floats(1e3, 1e6, **fin), period=st.floats(0.5, 8.0, **fin),
       mean=st.floats(-1e6, 1e6, **fin), drift=st.floats(-1e4, 1e4, **fin),
       phase=st.floats(0.0, 6.28, **fin))
def test_oscillation_reads_the_amplitude_and_period_of_a_sine_on_a_drift(amp, period, mean,
                                                                         drift, phase):
    t = np.arange(0.0, 40.0, 1e-3)
    x = mean + drift * t + amp * np.sin(2 * np.pi * t / period + phase)
    o = oscillation(t, x)
    assert_allclose(o["amplitude"], amp, rtol=2e-3)
    assert_allclose(o["rms"], amp / np.sqrt(2), rtol=3e-2)  # not whole periods
    assert_allclose(o["period_s"], period, rtol=5e-3)


def test_reference_corners_are_the_jumps_of_the_profile_slope():
    c = reference_corners([[0.0, 0.0], [20.9, 16.72], [120.0, 16.72], [130.0, 11.0],
                           [270.0, 11.0]])
    assert_allclose(c.jump_m_s2.abs().values, [0.8, 0.8, 0.572, 0.572], rtol=1e-12)
    assert set(c.time_s[:2]) == {0.0, 20.9}


SLACK = 0.025


def speed_train(travel=None):
    """A locomotive and two wagons under a speed controller (the constructed signals
    below stand in for its result)."""
    coupler = {"model": "simplified", "slack": SLACK, "damping": 1000.0, "k1": 8e6,
               "k2": 2e6, "k3": 4e6, "v_c": 0.6}
    if travel is not None:
        coupler["travel"] = travel
    d = train_dict([80000.0, 90000.0, 90000.0], t_end=100.0, dt=1e-3, output_interval=1e-2,
                   coupler=coupler)
    d["driver"] = {"mode": "speed", "speed_profile": [[0.0, 0.0], [20.0, 10.0], [100.0, 10.0]],
                   "pid": {"kp": 30.0, "ki": 15.0, "kd": 0.0, "ts": 1e-3}}
    return build(d)


def constructed_result(sc, *, amp=4e5, period=5.0, stretch=(0.3, 0.05), bunch=(0.02, 0.2),
                       acc=(0.5, 9.0)):
    """A result dataset: traction and coupler 1 ring with ``amp`` N at ``period`` s,
    coupler deflections peak at ``stretch`` (draft) and ``bunch`` (buff) beyond the
    slack, the wagons' accelerations peak at ``acc`` m/s^2."""
    t = np.arange(0.0, 100.0 + 1e-9, 1e-2)
    ring = amp * np.sin(2 * np.pi * t / period)
    vref = np.interp(t, [0.0, 20.0, 100.0], [0.0, 10.0, 10.0])
    h = 0.5 * SLACK
    d = np.zeros((t.size, 2))
    wave = np.sin(2 * np.pi * t / 7.0)
    for j in range(2):  # swings through the slack into draft and buff
        d[:, j] = np.where(wave > 0.0, h + stretch[j] * wave, -h + bunch[j] * wave)
    a = np.zeros((t.size, 3))
    a[:, 0] = 0.1 * np.sin(t)
    a[:, 1] = acc[0] * np.sin(3 * t)
    a[:, 2] = acc[1] * np.sin(2 * t)
    ds = xr.Dataset({
        "traction_force": ("time", 2e5 + ring),
        "coupler_force": (("time", "coupler"), np.stack([1.8e5 + ring, 0.9e5 + 0 * t], 1)),
        "coupler_deflection": (("time", "coupler"), d),
        "acceleration": (("time", "vehicle"), a),
        "speed_reference": ("time", vref),
        "speed_error": ("time", 0.01 * np.sin(t)),
    }, coords={"time": t, "coupler": [0, 1], "vehicle": [0, 1, 2]})
    ds.attrs["scenario_json"] = json.dumps(sc.to_dict())
    return ds


def test_base_run_diagnostics_reads_the_constructed_ringing():
    sc = speed_train()
    ds = constructed_result(sc)
    r = base_run_diagnostics(ds)
    assert r["window_s"] == pytest.approx((30.0, 100.0))  # level from 20 s, + 10 s settling
    assert_allclose(r["traction_swing_N"], 4e5, rtol=1e-3)
    assert_allclose(r["traction_period_s"], 5.0, rtol=5e-3)
    assert_allclose(r["traction_mean_N"], 2e5, rtol=1e-2)
    assert_allclose(r["coupler1_swing_N"], 4e5, rtol=1e-3)
    assert_allclose(r["max_draft_m"], [0.3, 0.05], rtol=1e-3)
    assert_allclose(r["max_buff_m"], [0.02, 0.2], rtol=1e-3)
    assert_allclose(r["max_gear_deflection_m"], [0.3, 0.2], rtol=1e-3)
    assert r["couplers_beyond_travel"] == [1, 2]  # both beyond the 83 mm reference
    assert_allclose(r["max_wagon_acceleration_m_s2"], 9.0, rtol=1e-3)
    assert r["max_wagon_acceleration_vehicle"] == 3
    assert_allclose(r["speed_error_rms_m_s"], 0.01 / np.sqrt(2), rtol=2e-2)
    assert_allclose(r["reference_corner_m_s2"], 0.5)
    # two wagons (90 t) behind a held locomotive on draft springs k = 6e6 N/m:
    # K = k [[2, -1], [-1, 1]], lowest frequency sqrt(k/m (3 - sqrt 5)/2) / (2 pi)
    k, m = 6e6, 9e4
    assert_allclose(r["held_mode_hz"], np.sqrt(k / m * (3 - np.sqrt(5)) / 2) / (2 * np.pi),
                    rtol=1e-9)


def test_gear_travel_check_and_warning_use_the_stated_travel_or_the_reference():
    ds = constructed_result(speed_train(), stretch=(0.3, 0.05), bunch=(0.02, 0.07))
    table = gear_travel_check(ds)
    assert_allclose(table.max_deflection_m, [0.3, 0.07], rtol=1e-3)
    assert_allclose(table.travel_m, [0.083, 0.083])
    assert list(table.exceeds) == [True, False]
    assert_allclose(table.excess_m[0], 0.3 - 0.083, rtol=1e-3)
    line = travel_warning(ds)
    assert "coupler 1 by 217 mm" in line and "83 mm" in line and "coupler 2" not in line
    # a stated travel of 60 mm: now coupler 2 (70 mm) is beyond it too
    sc = speed_train(travel=0.06)
    ds = constructed_result(sc, stretch=(0.3, 0.05), bunch=(0.02, 0.07))
    table = gear_travel_check(ds)
    assert list(table.exceeds) == [True, True] and table.travel_stated.all()
    assert_allclose(table.excess_m, [0.24, 0.01], rtol=1e-3, atol=1e-6)
    line = travel_warning(ds)
    assert "stated travel" in line and "couplers 1 by 240 mm, 2 by 10 mm" in line
    s = run_summary(ds.assign(traction_force=ds.traction_force,
                              adhesion_limit=ds.traction_force * 2))
    assert s["couplers_beyond_travel"] == 2
    assert_allclose(s["max_gear_deflection_m"], 0.3, rtol=1e-3)
    # all within: no warning
    quiet = constructed_result(speed_train(), stretch=(0.05, 0.05), bunch=(0.02, 0.07))
    assert travel_warning(quiet) is None


def test_a_gear_beyond_its_travel_by_less_than_a_millimetre_is_not_shown_as_0_mm():
    """Gears of 60 mm travel deflected 0.3 mm and 4.2 mm beyond it (coupler 1 in draft,
    coupler 2 in buff): the warning gives both to two figures, "by 0.3 mm" and
    "by 4.2 mm", never "by 0 mm"; 0.4 micrometres beyond it (the rounding of a gear at
    its travel) is not an excess and no warning is given."""
    sc = speed_train(travel=0.06)
    ds = constructed_result(sc, stretch=(0.0603, 0.05), bunch=(0.02, 0.0642))
    table = gear_travel_check(ds)
    assert_allclose(table.excess_m, [3e-4, 4.2e-3], rtol=1e-6)
    line = travel_warning(ds)
    assert "couplers 1 by 0.3 mm, 2 by 4.2 mm" in line, line
    assert "by 0 mm" not in line and "largest deflection beyond the slack 64 mm" in line
    assert list(table.exceeds) == [True, True]
    edge = constructed_result(sc, stretch=(0.06 + 4e-7, 0.05), bunch=(0.02, 0.05))
    assert not gear_travel_check(edge).exceeds.any()
    assert travel_warning(edge) is None


def test_cruise_window_needs_a_constant_reference():
    sc = speed_train()
    ds = constructed_result(sc)
    assert cruise_window(ds, settle=0.0) == pytest.approx((20.0, 100.0))
    with pytest.raises(ValueError, match="constant speed"):
        cruise_window(ds.assign(speed_reference=ds.time * 0.1))


def test_closed_loop_modes_match_the_hand_derived_characteristic_polynomial():
    # locomotive m1 and wagon m2 on a spring k, no damping; P controller kp with the
    # demand times M: (m1 s^2 + M kp s + k)(m2 s^2 + k) - k^2 = 0, i.e.
    # s (m1 m2 s^3 + M kp m2 s^2 + k (m1 + m2) s + M kp k) = 0
    m1, m2, k, kp = 74151.0, 90000.0, 5e6, 2.0
    d = train_dict([m1, m2], coupler={"model": "linear", "stiffness": k, "damping": 0.0})
    d["driver"] = {"mode": "speed", "speed_profile": [[0.0, 10.0]],
                   "pid": {"kp": kp, "ki": 0.0, "kd": 0.0, "ts": 1e-3}}
    sc = build(d)
    for M in (m1, m1 + m2):
        roots = np.roots([m1 * m2, M * kp * m2, k * (m1 + m2), M * kp * k])
        osc = roots[roots.imag > 0][0]
        modes = closed_loop_modes(sc, demand_mass=M)
        assert len(modes) == 1
        assert_allclose(modes.frequency_hz[0], abs(osc) / (2 * np.pi), rtol=1e-8)
        assert_allclose(modes.damping_ratio[0], -osc.real / abs(osc), rtol=1e-6)
    # the default demand mass is the one the scenario's controller multiplies
    assert_allclose(closed_loop_modes(sc).damping_ratio[0],
                    closed_loop_modes(sc, demand_mass=m1 + m2).damping_ratio[0])
    loco = sc.with_overrides({"driver.pid.acceleration_of": "locomotive"})
    assert_allclose(closed_loop_modes(loco).damping_ratio[0],
                    closed_loop_modes(sc, demand_mass=m1).damping_ratio[0])


def test_the_linearised_closed_loop_predicts_the_ring_and_its_cure_in_the_study_train():
    # the study's LHHL train without slack (so that the linear model applies), 80 s: with
    # the reading used before (sharp corners, demand x train mass) the wagons ring against
    # the held locomotive at the lowest closed-loop mode, decaying at its damping ratio;
    # with the scenario as shipped the ring is gone
    import ltdsim
    from ltdsim.analysis.diagnostics import PAPER_EARLIER_READING

    from conftest import PAPER

    base = ltdsim.load_scenario(PAPER, case="LHHL").with_overrides(
        {"couplers.default.slack": 0.0, "solver.t_end": 80.0})
    earlier = base.with_overrides(PAPER_EARLIER_READING)
    mode = closed_loop_modes(earlier).iloc[0]
    ds = ltdsim.simulate(earlier)
    starts = np.arange(25.0, 70.0, 10.0)
    rings = [oscillation(*_window(ds, a, a + 10.0)) for a in starts]
    periods = np.array([r["period_s"] for r in rings])
    assert_allclose(np.median(periods), 1.0 / mode.frequency_hz, rtol=0.05)
    decay = -np.polyfit(starts + 5.0, np.log([r["amplitude"] for r in rings]), 1)[0]  # 1/s
    assert_allclose(decay, mode.damping_ratio * 2 * np.pi * mode.frequency_hz, rtol=0.35)
    assert rings[0]["amplitude"] > 3e5  # N: the ring is there to be measured
    # the shipped reading damps that mode, and its cruise stays quiet
    assert closed_loop_modes(base).damping_ratio.iloc[0] > 0.1
    quiet = oscillation(*_window(ltdsim.simulate(base), 45.0, 75.0))
    assert quiet["amplitude"] < 0.05 * oscillation(*_window(ds, 45.0, 75.0))["amplitude"]


def _window(ds, a, b):
    w = ds.sel(time=slice(a, b))
    return w.time.values, w.traction_force.values


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(1, 700), cols=st.integers(0, 12), seed=st.integers(0, 2**32 - 1),
       nan=st.booleans(), step=st.sampled_from([1, 2]))
def test_column_peaks_equal_numpys_reduction_over_rows(rows, cols, seed, nan, step):
    """column_max / column_min (blocks of rows first) give exactly numpy's max / min over
    axis 0, NaN included, also for fewer rows than a block, no columns, a strided view."""
    rng = np.random.default_rng(seed)
    x = rng.normal(scale=1e5, size=(rows, cols * step))[:, ::step]
    if nan and x.size:
        x[rng.integers(rows), rng.integers(cols)] = np.nan
    np.testing.assert_array_equal(column_max(x), x.max(axis=0))
    np.testing.assert_array_equal(column_min(x), x.min(axis=0))
