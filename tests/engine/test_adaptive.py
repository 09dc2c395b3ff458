"""The adaptive Bogacki-Shampine 3(2) integrator against references."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

import ltdsim

from conftest import build, smooth_chain, train_dict


def _final_state(ds):
    return np.concatenate([ds.position.values[-1] - ds.position.values[0], ds.velocity.values[-1]])


def _bs23(tol, t_end=2.0, output_interval=None):
    d = smooth_chain("bs23", 1e-3, t_end=t_end)
    d["solver"].update(rtol=tol, atol=tol, max_step=1.0,
                       output_interval=output_interval or t_end)
    return ltdsim.simulate(build(d))


def test_bs23_error_follows_its_tolerance_and_its_order(chain_reference):
    errors, steps = [], []
    for tol in (1e-5, 1e-7, 1e-9):
        ds = _bs23(tol)
        errors.append(np.max(np.abs(_final_state(ds) - chain_reference)))
        steps.append(ds.attrs["steps"])
    # tighter tolerance, smaller error; at 1e-9 it agrees with DOP853 to 1e-6 relative
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] <= 1e-6 * np.max(np.abs(chain_reference))
    # a third-order local error: 100x tighter tolerance costs about 100^(1/3) = 4.6x steps
    ratios = np.array(steps[1:]) / np.array(steps[:-1])
    assert np.all((ratios > 3.0) & (ratios < 7.0)), steps


def test_bs23_lands_on_every_output_time_and_agrees_with_ode3():
    ds = _bs23(1e-9, t_end=1.0, output_interval=0.01)
    ref = ltdsim.simulate(build(smooth_chain("ode3", 1e-4, t_end=1.0)
                                | {"solver": {"method": "ode3", "dt": 1e-4, "t_end": 1.0,
                                              "output_interval": 0.01}}))
    assert_allclose(ds.time.values, ref.time.values, rtol=0, atol=1e-12)
    scale = np.abs(ref.coupler_force.values).max()
    assert np.abs(ds.coupler_force.values - ref.coupler_force.values).max() < 1e-6 * scale


def test_bs23_tableau_is_scipys_rk23_and_meets_the_order_conditions():
    from scipy.integrate import RK23

    from ltdsim.engine.integrators import BS23

    # the same pair as SciPy's RK23, whose error weights are b_hat - b (ours: b - b_hat)
    assert_allclose(BS23.A, RK23.A, rtol=0, atol=1e-15)
    assert_allclose(BS23.b, RK23.B, rtol=0, atol=1e-15)
    assert_allclose(BS23.c, RK23.C, rtol=0, atol=1e-15)
    assert_allclose(BS23.e, -RK23.E, rtol=0, atol=1e-15)
    # third order: sum b = 1, b.c = 1/2, b.c^2 = 1/3, b.A.c = 1/6
    b, A, c = BS23.b, BS23.A, BS23.c
    assert_allclose([b.sum(), b @ c, b @ c**2, b @ A @ c], [1, 1 / 2, 1 / 3, 1 / 6], atol=1e-15)
    # the embedded solution over the three stages and the step's end (c = 1): 2nd order
    b_hat = np.append(b, 0.0) - BS23.e
    c4 = np.append(c, 1.0)
    assert_allclose([b_hat.sum(), b_hat @ c4], [1, 1 / 2], atol=1e-15)


RING_K = 5e8  # N/m, as stiff as the heavy-haul train's polymer gears when locked


def _ringing_pair(speed, speed_atol=None):
    """Two 60 t wagons on an undamped coupler of RING_K without slack, moving at ``speed``
    (m/s) and closing at 0.1 m/s, under bs23 at the heavy-haul scenario's tolerances
    (rtol 1e-3, atol 1e-4), with ``speed_atol`` (m/s) when given; no force acts."""
    d = train_dict([60000.0, 60000.0], force=0.0, t_end=5.0, dt=1e-4, output_interval=0.1,
                   method="bs23", speed=0.0,
                   coupler={"model": "linear", "stiffness": RING_K, "damping": 0.0,
                            "slack": 0.0})
    d["initial"] = {"velocities": [speed, speed + 0.1]}
    d["solver"].update(rtol=1e-3, atol=1e-4)
    if speed_atol is not None:
        d["solver"]["speed_atol"] = speed_atol
    return ltdsim.simulate(build(d))


def _ringing_error(ds):
    """Largest error of the pair's coupler deflection (m) against the closed form of the
    undamped oscillator, d(t) = -(u / w) sin(w t) (u the closing speed, w = sqrt(k / mu),
    mu the reduced mass)."""
    w = np.sqrt(RING_K / 30000.0)
    exact = -(0.1 / w) * np.sin(w * ds.time.values)
    return np.abs(ds.coupler_deflection.values[:, 0] - exact).max()


def test_a_speed_tolerance_holds_the_coupling_to_it_at_any_train_speed():
    # Galilean invariance: the coupling's motion does not depend on the train's speed, so
    # with the speeds held to speed_atol alone neither does its error; and that error
    # follows the tolerance (over 100 periods of the 20 Hz ringing, about 0.8 mm at rest at
    # the scenario's own tolerances, where the speeds' relative part lets it grow with the
    # train's speed)
    amplitude = 0.1 / np.sqrt(RING_K / 30000.0)  # 0.77 mm
    held = {v: _ringing_error(_ringing_pair(v, 1e-6)) for v in (0.0, 40.0)}
    assert held[0.0] < 0.05 * amplitude, held
    assert 0.9 < held[40.0] / held[0.0] < 1.1, held
    looser = _ringing_error(_ringing_pair(40.0, 1e-5))
    assert looser > 4.0 * held[40.0], (looser, held)
