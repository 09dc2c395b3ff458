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
