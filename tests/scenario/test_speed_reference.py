"""The speed controller's reference and plant: rounded (jerk-limited) corners of the
speed profile against the constant-jerk closed form, and the demand multiplied by the
train's or the locomotive's mass against the tracking error of a P controller."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import ltdsim
from ltdsim.errors import ScenarioError
from ltdsim.engine.lowering import rounded_profile

from conftest import build, train_dict

fin = dict(allow_nan=False, allow_infinity=False)


def s_curve(t, v0, v1, t0, accel, jerk_time):
    """Closed form of a speed change v0 -> v1 from t0 with peak acceleration accel and
    linear acceleration ramps of jerk_time s at both ends (constant jerk)."""
    tc = abs(v1 - v0) / accel - jerk_time  # time at full acceleration
    T = 2 * jerk_time + tc
    s = np.sign(v1 - v0)
    u = np.clip(t - t0, 0.0, T)
    j = accel / jerk_time
    dv = np.where(u < jerk_time, 0.5 * j * u**2,
                  np.where(u < jerk_time + tc, 0.5 * accel * jerk_time + accel * (u - jerk_time),
                           abs(v1 - v0) - 0.5 * j * (T - u) ** 2))
    return v0 + s * dv


@settings(max_examples=40, deadline=None)
@given(accel=st.floats(0.2, 1.0, **fin), jerk_time=st.floats(0.5, 12.0, **fin),
       v1=st.floats(10.0, 30.0, **fin), cruise=st.floats(0.0, 50.0, **fin))
def test_rounded_corners_are_the_constant_jerk_s_curve(accel, jerk_time, v1, cruise):
    # a ramp from rest to v1 at accel, both corners rounded over jerk_time: the straight
    # ramp starts jerk_time / 2 after t = 0, so the train starts from rest at t = 0
    ramp = v1 / accel
    if ramp < jerk_time:
        return  # the roundings of the two corners would overlap (refused, tested below)
    t1 = 0.5 * jerk_time
    pts = [[0.0, 0.0], [t1, 0.0, jerk_time], [t1 + ramp, v1, jerk_time],
           [t1 + ramp + 0.5 * jerk_time + cruise + 1.0, v1]]
    t, v = rounded_profile(pts)
    tt = np.linspace(0.0, pts[-1][0], 20001)
    got = np.interp(tt, t, v)
    jerk = accel / jerk_time
    # sampled every 0.02 s or finer: a parabola's chord lies within jerk x step^2 / 8
    assert_allclose(got, s_curve(tt, 0.0, v1, 0.0, accel, jerk_time), rtol=0,
                    atol=jerk * 0.02**2 / 8 + 1e-12)
    slope = np.diff(v) / np.diff(t)
    # a finite difference of speeds rounded to double precision: its own rounding error
    rounding = 4 * np.finfo(float).eps * np.abs(v).max() / np.diff(t).min()
    assert slope.max() <= accel + rounding and slope.min() >= -rounding
    assert np.abs(np.diff(slope)).max() <= jerk * 0.02 * (1 + 1e-6)  # no corner left


def test_the_paper_reference_starts_from_rest_and_keeps_its_straight_segments():
    pts = [[0.0, 0.0], [5.0, 0.0, 10.0], [25.9, 16.72, 10.0], [121.5, 16.72, 3.0],
           [128.5, 11.0, 3.0], [270.0, 11.0]]
    t, v = rounded_profile(pts)
    f = lambda x: np.interp(x, t, v)  # noqa: E731
    assert f(0.0) == 0.0 and f(30.9) == pytest.approx(16.72) and f(130.0) == pytest.approx(11.0)
    assert_allclose(f(np.array([15.0, 20.0])), 0.8 * (np.array([15.0, 20.0]) - 5.0))
    assert_allclose(f(np.array([50.0, 119.9, 130.0, 200.0])), [16.72, 16.72, 11.0, 11.0])
    # deceleration between the rounded corners: 5.72 m/s over 7 s
    assert_allclose(f(125.0), 16.72 - 5.72 / 7.0 * 3.5)
    # without jerk times the profile is used as given
    plain = [[0.0, 0.0], [20.9, 16.72], [270.0, 16.72]]
    t, v = rounded_profile(plain)
    assert t.tolist() == [0.0, 20.9, 270.0] and v.tolist() == [0.0, 16.72, 16.72]


@pytest.mark.parametrize("profile, message", [
    ([[0.0, 0.0, 2.0], [10.0, 5.0]], "first and last"),
    ([[0.0, 0.0], [5.0, 0.0, 8.0], [8.0, 3.0, 4.0], [20.0, 3.0]], "overlap"),
    ([[0.0, 0.0], [5.0, 0.0, -1.0], [20.0, 3.0]], "jerk time"),
])
def test_impossible_roundings_are_refused_naming_the_points(profile, message):
    d = train_dict([80000.0, 90000.0])
    d["driver"] = {"mode": "speed", "speed_profile": profile,
                   "pid": {"kp": 1.0, "ts": 1e-3}}
    with pytest.raises(ScenarioError, match=message):
        build(d)


@pytest.mark.parametrize("acceleration_of", ["train", "locomotive"])
def test_a_p_controller_lags_a_ramp_by_the_ramp_times_train_over_demand_mass(acceleration_of):
    # locomotive 30 t + wagon 60 t joined stiffly, no resistance: under a P controller the
    # train, following a reference ramp r, lags by e = r / (kp m_demand / m_train)
    m_loco, m_wagon, kp, r = 30000.0, 60000.0, 2.0, 0.2
    d = train_dict([m_loco, m_wagon], t_end=40.0, dt=1e-3, output_interval=0.01,
                   coupler={"model": "linear", "stiffness": 5e7, "damping": 2e6})
    d["driver"] = {"mode": "speed", "speed_profile": [[0.0, 0.0], [100.0, 100.0 * r]],
                   "pid": {"kp": kp, "ts": 1e-3, "acceleration_of": acceleration_of}}
    ds = ltdsim.simulate(build(d))
    m_demand = m_loco + m_wagon if acceleration_of == "train" else m_loco
    lag = r * (m_loco + m_wagon) / (kp * m_demand)
    assert_allclose(ds.speed_error.sel(time=slice(30.0, 40.0)).values, lag, rtol=1e-3)
    # the output is the demanded acceleration of the train or of the locomotive
    assert_allclose(ds.demanded_acceleration.sel(time=slice(30.0, 40.0)).values,
                    r * (m_loco + m_wagon) / m_demand, rtol=1e-3)


@pytest.mark.parametrize("acceleration_of", ["train", "locomotive"])
def test_max_accel_limits_the_trains_acceleration_whoever_is_demanded(acceleration_of):
    # a large speed step: the demand saturates at max_accel x train mass (no resistance,
    # traction limits far away), so the train accelerates at max_accel either way
    d = train_dict([30000.0, 60000.0], t_end=10.0, dt=1e-3, output_interval=0.01,
                   coupler={"model": "linear", "stiffness": 5e7, "damping": 2e6})
    d["driver"] = {"mode": "speed", "speed_profile": [[0.0, 50.0]],
                   "pid": {"kp": 10.0, "ts": 1e-3, "acceleration_of": acceleration_of}}
    d["traction"].update({"max_accel": 0.5})
    ds = ltdsim.simulate(build(d))
    assert_allclose(ds.traction_force.values, 0.5 * 90000.0, rtol=1e-12)
    assert_allclose(ds.acceleration.sel(time=slice(5.0, 10.0)).values, 0.5, rtol=1e-6)
