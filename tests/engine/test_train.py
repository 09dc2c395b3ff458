"""Whole-train checks against closed forms, conservation laws and scipy's solve_ivp."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import ltdsim
from reference_rhs import make_rhs

from conftest import ROOT, build, smooth_chain, train_dict

MASSES = [80000.0, 60000.0, 90000.0, 45000.0, 70000.0]


def test_coupler_forces_in_steady_traction_are_proportional_to_the_mass_behind():
    F = 2.0e5
    d = train_dict(MASSES, force=F, t_end=40.0, output_interval=0.01,
                   coupler={"model": "linear", "stiffness": 4e6, "damping": 2e5, "slack": 0.025})
    ds = ltdsim.simulate(build(d))
    M = sum(MASSES)
    behind = np.array([sum(MASSES[j + 1:]) for j in range(len(MASSES) - 1)])
    late = ds.coupler_force.sel(time=slice(30.0, 40.0)).mean("time").values
    assert_allclose(late, F * behind / M, rtol=5e-3)
    # and the train accelerates as one body, a = F / M
    assert_allclose(ds.acceleration.sel(time=slice(30.0, 40.0)).mean().item(), F / M, rtol=5e-3)
    # kinematics: a vehicle trails the lead by the deflections of the couplers between them
    trail = -np.cumsum(ds.coupler_deflection.values, axis=1)
    assert_allclose(ds.relative_position.values[:, 1:], trail, atol=1e-12)
    late = ds.time.values >= 5.0  # after the slack run-in, where differences are smooth
    assert_allclose(ds.relative_velocity.values[late, 1:],
                    np.gradient(trail, ds.time.values, axis=0)[late], atol=2e-3)


def test_terminal_speed_is_the_root_of_traction_equals_davis_resistance():
    masses = [2000.0] * 5
    davis = {"a": 8202.0, "b": 106.56, "c": 11.9322}
    F = 3.0e5
    v_term = brentq(lambda v: F - 5 * (8202.0 + 106.56 * v + 11.9322 * v * v), 0.0, 200.0)
    d = train_dict(masses, force=F, t_end=60.0, output_interval=0.1, davis=davis,
                   speed=0.9 * v_term,
                   coupler={"model": "linear", "stiffness": 1e6, "damping": 5e3, "slack": 0.0})
    ds = ltdsim.simulate(build(d))
    assert_allclose(ds.velocity.isel(time=-1).values, v_term, rtol=1e-3)


def test_mechanical_energy_is_conserved_with_undamped_couplers():
    # a 1 s push sets the train moving and its couplers ringing; then no force acts
    k = 5e6
    F = 5e4
    d = train_dict(MASSES, force=F, t_end=100.0, dt=1e-3, output_interval=0.01, method="rk4",
                   coupler={"model": "linear", "stiffness": k, "damping": 0.0, "slack": 0.0})
    d["driver"]["force_profile"] = [[0.0, F], [1.0, F], [1.001, 0.0]]
    ds = ltdsim.simulate(build(d)).sel(time=slice(1.01, None))
    m = np.array(MASSES)
    v = ds.velocity.values
    kinetic = 0.5 * (m * v**2).sum(axis=1)
    spring = 0.5 * k * (ds.coupler_deflection.values**2).sum(axis=1)
    energy = kinetic + spring
    assert np.max(np.abs(energy - energy[0])) <= 1e-6 * energy[0]
    # the couplers really do exchange energy with the masses
    assert spring.max() > 0.02 * energy[0]
    internal = energy - 0.5 * (m @ v.T) ** 2 / m.sum()
    assert np.max(np.abs(internal - internal[0])) <= 1e-5 * internal[0]


def test_a_train_held_on_a_one_in_two_hundred_grade_stays_still():
    masses = [74151.0, 90000.0, 90000.0, 90000.0]
    static = [66630.0, 90000.0, 90000.0, 90000.0]
    g = 9.81
    hold = g * sum(static) / 200.0
    d = train_dict(masses, static_masses=static, force=hold, t_end=60.0, output_interval=0.01,
                   gradient=[[-1000.0, 1.0 / 200.0]],
                   coupler={"model": "linear", "stiffness": 4e6, "damping": 3e5, "slack": 0.0})
    ds = ltdsim.simulate(build(d))
    m = np.array(masses)
    momentum = (ds.velocity.values * m).sum(axis=1)
    assert np.max(np.abs(momentum)) < 1e-9 * hold  # net force zero: the centre of mass stays
    # and it settles into static equilibrium: each coupler holds the weight behind it
    behind = np.array([sum(static[j + 1:]) for j in range(len(static) - 1)])
    assert_allclose(ds.coupler_force.isel(time=-1).values, g * behind / 200.0, rtol=1e-3)
    assert np.max(np.abs(ds.velocity.isel(time=-1).values)) < 1e-6


def _final_state(ds):
    return np.concatenate([ds.position.values[-1] - ds.position.values[0], ds.velocity.values[-1]])


@pytest.mark.parametrize("method,order", [("euler", 1), ("heun", 2), ("ode3", 3), ("rk4", 4)])
def test_measured_order_of_convergence_matches_the_method(method, order, chain_reference):
    dts = {1: [2e-4, 1e-4, 5e-5], 2: [4e-3, 2e-3, 1e-3], 3: [4e-3, 2e-3, 1e-3],
           4: [8e-3, 4e-3, 2e-3]}[order]
    errors = []
    for dt in dts:
        ds = ltdsim.simulate(build(smooth_chain(method, dt)))
        errors.append(np.max(np.abs(_final_state(ds) - chain_reference)))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert_allclose(rates, order, atol=0.1), (errors, rates)


def test_ode3_at_a_small_step_agrees_with_solve_ivp(chain_reference):
    ds = ltdsim.simulate(build(smooth_chain("ode3", 1e-4)))
    y = _final_state(ds)
    assert np.max(np.abs(y - chain_reference)) <= 1e-6 * np.max(np.abs(chain_reference))
    sc = build(smooth_chain("ode3", 1e-4))
    f, y0 = make_rhs(sc)
    sol = solve_ivp(f, (0.0, 2.0), y0, method="RK45", rtol=1e-10, atol=1e-12)
    assert_allclose(y, sol.y[:, -1], rtol=1e-6, atol=1e-9)


def test_recorded_acceleration_is_the_derivative_of_recorded_velocity():
    d = train_dict(MASSES, force=2e5, t_end=5.0, dt=1e-4, output_interval=1e-3,
                   coupler={"model": "simplified", "slack": 0.025, "damping": 999.87,
                            "k1": 8.27e6, "k2": 1.86e6, "k3": 3.47e6, "v_c": 0.6})
    ds = ltdsim.simulate(build(d))
    v = ds.velocity.values
    dvdt = np.gradient(v, ds.time.values, axis=0)
    inner = slice(10, -10)
    scale = np.abs(ds.acceleration.values).max()
    # central differences of a smooth-enough signal: agreement to ~1 % of the range
    err = np.abs(dvdt[inner] - ds.acceleration.values[inner])
    assert np.median(err) < 1e-3 * scale


def test_tracked_peaks_are_the_peaks_of_every_step():
    # recorded at every step, the record itself holds the peaks: the tracked ones agree;
    # recorded coarsely, the tracked peaks bound the record and keep their exact times
    d = train_dict(MASSES, force=2e5, t_end=5.0, dt=1e-4, output_interval=1e-4,
                   coupler={"model": "simplified", "slack": 0.025, "damping": 999.87,
                            "k1": 8.27e6, "k2": 1.86e6, "k3": 3.47e6, "v_c": 0.6})
    fine = ltdsim.simulate(build(d))
    f, t = fine.coupler_force.values, fine.time.values
    assert_allclose(fine.max_coupler_force.values, f.max(axis=0), rtol=1e-14)
    assert_allclose(fine.min_coupler_force.values, f.min(axis=0), rtol=1e-14)
    assert_allclose(fine.time_max_coupler_force.values, t[f.argmax(axis=0)], atol=1e-12)
    d["solver"]["output_interval"] = 0.05
    coarse = ltdsim.simulate(build(d))
    assert_allclose(coarse.max_coupler_force.values, fine.max_coupler_force.values, rtol=1e-12)
    assert np.all(coarse.max_coupler_force.values >= coarse.coupler_force.values.max(axis=0))
    assert np.any(coarse.max_coupler_force.values > coarse.coupler_force.values.max(axis=0))


@settings(max_examples=10, deadline=None)
@given(v0=st.floats(0.5, 1.5), grade=st.floats(0.015, 0.03), radius=st.floats(200.0, 2000.0))
def test_train_rolling_back_over_graded_curved_track_obeys_newton_as_a_whole(v0, grade,
                                                                            radius):
    """A train set rolling up a grade with curves stops and rolls back over the track
    pieces it passed (its resistances change sign with its speed): the sum of m a is at
    every record minus the resistances that the laws give on each vehicle's piece of
    track (the couplers' forces cancel; no traction, no brakes)."""
    from ltdsim.engine.lowering import merge_track
    from ltdsim.physics import curve_resistance, davis_resistance, grade_resistance

    sc = ltdsim.load_scenario(ROOT / "scenarios" / "two-wagons-linear.toml").with_overrides({
        "initial.velocities": [v0] * 3, "driver.force_profile": [[0.0, 0.0]],
        "track.gradient": [[0.0, grade], [0.1, 1.3 * grade], [0.25, 0.8 * grade],
                           [0.4, grade]],
        "track.curve": [[0.0, 0.0], [0.05, radius], [0.2, 0.0], [0.35, 0.5 * radius]],
        "solver.t_end": 15.0, "solver.output_interval": 0.01})
    ds = ltdsim.simulate(sc)
    v = ds.velocity.values
    assert v[0, 0] > 0.4 and v[-1, 0] < -0.1  # it went up and came back down
    m = np.array([u.mass for u in sc.vehicles])
    wm = np.array([u.weight_mass for u in sc.vehicles])
    dav = np.array([[u.davis.a, u.davis.b, u.davis.c, u.davis.v0] for u in sc.vehicles])
    pos, grades, curv = merge_track(sc.track.gradient, sc.track.curve)
    k = np.clip(np.searchsorted(pos, ds.position.values, side="right") - 1, 0, None)
    assert len(np.unique(k[:, 0])) >= 4  # the lead crossed several pieces each way
    g = sc.track.gravity
    res = (davis_resistance(v, *dav.T) + grade_resistance(wm, grades[k], g)
           + curve_resistance(v, wm, curv[k], sc.track.curve_h, g))
    ma = (ds.acceleration.values * m).sum(axis=1)
    assert_allclose(ma, -res.sum(axis=1), rtol=1e-9, atol=1e-6 * np.abs(res).sum(axis=1).max())
