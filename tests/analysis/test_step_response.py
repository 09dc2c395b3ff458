"""The simulated force step (ltdsim.analysis.experiments.force_step) against the closed form of a
locomotive and one wagon joined by a linear spring-damper coupler."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ltdsim.analysis.experiments import force_step, step_info

from conftest import build, train_dict


def two_body_response(t, m1, m2, k, c):
    """Wagon acceleration per unit of the rigid pair's acceleration after a force step
    on the locomotive: y = 1 - exp(-z w t) (cos(wd t) - z / sqrt(1 - z^2) sin(wd t)),
    with w = sqrt(k / mu), mu = m1 m2 / (m1 + m2), z = c / (2 sqrt(k mu))."""
    mu = m1 * m2 / (m1 + m2)
    w = math.sqrt(k / mu)
    z = c / (2.0 * math.sqrt(k * mu))
    wd = w * math.sqrt(1.0 - z * z)
    return 1.0 - np.exp(-z * w * t) * (np.cos(wd * t) - z / math.sqrt(1 - z * z)
                                       * np.sin(wd * t)), z


@settings(max_examples=6, deadline=None)
@given(zeta=st.floats(0.0, 0.6), m2=st.floats(20e3, 120e3), k=st.floats(1e6, 1e7))
def test_a_force_step_makes_the_wagon_ring_as_the_two_body_closed_form_says(zeta, m2, k):
    m1 = 80e3
    mu = m1 * m2 / (m1 + m2)
    c = 2.0 * zeta * math.sqrt(k * mu)
    sc = build(train_dict([m1, m2], dt=1e-4, output_interval=1e-4, t_end=1.0,
                          coupler={"model": "linear", "stiffness": k, "damping": c,
                                   "slack": 0.0}))
    t, y = force_step(sc, speed=5.0, step=5e4, settle=0.5, duration=4.0)
    exact, z = two_body_response(t, m1, m2, k, c)
    assert np.max(np.abs(y - exact)) < 5e-3 * np.max(np.abs(exact))
    # the overshoot python-control reads off the record is the closed form's
    info = step_info(t, y)
    overshoot = 100.0 * (exact.max() - 1.0)
    assert abs(info["Overshoot"] - overshoot) < 0.5 + 0.01 * overshoot
    if z == 0.0:  # undamped: the wagon's acceleration swings to twice the rigid pair's
        assert abs(info["Peak"] - 2.0) < 1e-2 and math.isnan(info["SettlingTime"])


@settings(max_examples=4, deadline=None)
@given(zeta=st.floats(0.0, 0.3), m2=st.floats(20e3, 120e3), k=st.floats(1e6, 1e7))
def test_the_force_step_in_physical_units_is_the_two_body_closed_form(zeta, m2, k):
    """step_physics on a locomotive and one wagon: the rigid pair's F/M, the coupler's
    steady change F m2 / (m1 + m2), and its peak over that, the time it settles within
    5 % and its ringing, all as the closed form (the coupler's force change is m2 times
    the wagon's change of acceleration)."""
    from ltdsim.analysis.experiments import force_step_run, step_physics

    m1, step = 80e3, 5e4
    mu = m1 * m2 / (m1 + m2)
    c = 2.0 * zeta * math.sqrt(k * mu)
    sc = build(train_dict([m1, m2], dt=1e-4, output_interval=1e-4, t_end=1.0,
                          coupler={"model": "linear", "stiffness": k, "damping": c,
                                   "slack": 0.0}))
    ds, t0, step, mass = force_step_run(sc, speed=5.0, step=step, settle=0.5, duration=4.0)
    ph = step_physics(ds, t0, step, mass, sc.vehicles[0].mass)
    t = ds.time.values
    tt = t[t > t0] - t0
    exact, _ = two_body_response(tt, m1, m2, k, c)
    assert math.isclose(ph["rigid_acceleration_m_s2"], step / (m1 + m2), rel_tol=1e-12)
    assert math.isclose(ph["steady_coupler_change_N"], step * m2 / (m1 + m2), rel_tol=1e-12)
    assert abs(ph["coupler_peak_to_steady"] - exact.max()) < 1e-2
    assert abs(ph["peak_acceleration_m_s2"] - exact.max() * step / (m1 + m2)) \
        < 1e-2 * exact.max() * step / (m1 + m2)
    assert abs(ph["ringing_first"] - np.abs(exact - 1.0).max()) < 1e-2
    out = np.abs(exact - 1.0) > 0.05
    settled = tt[out][-1] if out.any() else 0.0
    if settled < tt[-1] - 0.2:
        assert abs(ph["decay_time_s"] - settled) < 0.05
    else:
        assert math.isnan(ph["decay_time_s"]) or ph["decay_time_s"] > tt[-1] - 0.3
