"""Gear travel and solid closure of the linear and simplified couplers: the law over
ranges, a quasi-static pull and an undamped impact against closed forms, and the
kernel against the NumPy reference model under solve_ivp."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

import ltdsim
from ltdsim.physics import coupler_linear, coupler_simplified
from reference_rhs import make_rhs

from conftest import build, train_dict

fin = dict(allow_nan=False, allow_infinity=False)
INF = np.inf


@given(over=st.floats(0.0, 0.05, **fin), travel=st.floats(0.01, 0.1, **fin),
       s=st.floats(0.0, 0.05, **fin), dd=st.floats(-1.0, 1.0, **fin),
       ks=st.floats(1e7, 1e10, **fin), sign=st.sampled_from([1.0, -1.0]))
def test_beyond_travel_the_solid_gear_adds_its_stiffness_times_the_excess(over, travel, s, dd,
                                                                           ks, sign):
    # the study's LHHL gear and a linear one, pushed `over` m beyond their travel in draft
    # or buff: the force is the gear's own law plus ks x excess, in the deflection's sense
    d = sign * (0.5 * s + travel + over)
    for law in (lambda tr, k: coupler_simplified(d, dd, s, 0.0, 999.8706, 8.265776e6,
                                                 1.856364e6, 3.4748e6, 0.6, False, tr, k),
                lambda tr, k: coupler_linear(d, dd, s, 5e6, 2e3, tr, k)):
        free = law(INF, ks)
        solid = law(travel, ks)
        if free * sign > 0.0 or s == 0.0:  # not cut by the unilateral contact
            assert_allclose(solid, free + sign * ks * over, rtol=1e-12, atol=1e-6)
        # inside the travel nothing changes
        d_in = sign * (0.5 * s + travel * 0.999)
        assert coupler_linear(d_in, dd, s, 5e6, 2e3, travel, ks) == \
            coupler_linear(d_in, dd, s, 5e6, 2e3, INF, ks)


def test_a_slow_pull_beyond_travel_stretches_the_gear_by_the_closed_form():
    # two wagons, the lead pulled by a force that grows slowly to F: quasi-statically the
    # coupler carries F m2 / (m1 + m2) (Newton), and the gear, linear k up to its travel
    # and k + ks beyond, stretches travel + (T - k travel) / (k + ks)
    m1, m2, k, ks, travel, slack = 60000.0, 90000.0, 5e6, 2e8, 0.03, 0.025
    F = 6e5
    d = train_dict([m1, m2], force=F, t_end=60.0, dt=1e-3, output_interval=0.01,
                   coupler={"model": "linear", "stiffness": k, "damping": 2e5, "slack": slack,
                            "travel": travel, "solid_stiffness": ks})
    d["driver"]["force_profile"] = [[0.0, 0.0], [40.0, F], [60.0, F]]
    ds = ltdsim.simulate(build(d)).sel(time=slice(55.0, None))
    T = F * m2 / (m1 + m2)
    assert T > k * travel * 1.5  # the pull does close the gear
    assert_allclose(ds.coupler_force.values[:, 0], T, rtol=1e-3)
    e = ds.coupler_deflection.values[:, 0] - 0.5 * slack
    assert_allclose(e, travel + (T - k * travel) / (k + ks), rtol=1e-4)


def test_an_undamped_closure_impact_keeps_its_energy_and_peaks_at_the_closed_form():
    # a wagon runs at v0 into a standing one through an undamped linear gear without slack
    # that closes solid: the relative kinetic energy 1/2 mu v0^2 goes into the springs k
    # (to the deflection e) and ks (beyond travel), and the two keep exchanging it
    m1, m2, k, ks, travel, v0 = 90000.0, 60000.0, 4e6, 1e8, 0.02, 1.5
    mu = m1 * m2 / (m1 + m2)
    d = train_dict([m1, m2], force=0.0, t_end=1.0, dt=1e-5, output_interval=1e-5,
                   method="rk4",
                   coupler={"model": "linear", "stiffness": k, "damping": 0.0, "slack": 0.0,
                            "travel": travel, "solid_stiffness": ks})
    d["initial"] = {"velocities": [0.0, v0]}  # the rear wagon closes the gear in buff
    ds = ltdsim.simulate(build(d))
    # 1/2 mu v0^2 = 1/2 k e^2 + 1/2 ks (e - travel)^2 at the largest deflection e
    a, b, c = k + ks, -2.0 * ks * travel, ks * travel**2 - mu * v0**2
    e_max = (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert e_max > 1.5 * travel
    defl = ds.coupler_deflection.values[:, 0]
    assert_allclose(-defl.min(), e_max, rtol=1e-6)
    assert_allclose(-ds.min_coupler_force.values[0], k * e_max + ks * (e_max - travel),
                    rtol=1e-6)
    assert defl.max() > 0.99 * e_max  # it swings through to the same stretch in draft
    m = np.array([m1, m2])
    over = np.clip(np.abs(defl) - travel, 0.0, None)
    energy = 0.5 * (m * ds.velocity.values**2).sum(axis=1) + 0.5 * k * defl**2 \
        + 0.5 * ks * over**2
    assert np.max(np.abs(energy - energy[0])) <= 1e-6 * energy[0]


def test_kernel_matches_solve_ivp_with_gears_closing_solid():
    # a chain pulled hard enough that its gears close solid within the first second,
    # simplified and linear couplers with slack: ode3 at 1e-4 s against scipy's DOP853 on
    # the NumPy model. (Over longer runs the repeated closures make the histories
    # sensitive to the step, as every slack impact does; compare the first second.)
    def chain(travel):
        coupler = {"model": "simplified", "slack": 0.01, "damping": 2e4, "k1": 6e6,
                   "k2": 1e6, "k3": 3e6, "v_c": 0.6, "solid_stiffness": 5e7}
        if travel is not None:
            coupler["travel"] = travel
        d = train_dict([40000.0, 30000.0, 45000.0, 30000.0], force=4e5, t_end=1.0, dt=1e-4,
                       output_interval=1.0, coupler=coupler)
        d["couplers"]["override"] = [{"index": 1, "model": "linear", "stiffness": 4e6,
                                      "damping": 1e4}]
        return build(d)

    sc = chain(0.02)
    ds = ltdsim.simulate(sc)
    f, y0 = make_rhs(sc)
    sol = solve_ivp(f, (0.0, 1.0), y0, method="DOP853", rtol=1e-11, atol=1e-12, max_step=1e-3,
                    dense_output=True)
    n = 4
    x = ds.position.isel(time=-1).values - ds.position.isel(time=0).values
    v = ds.velocity.isel(time=-1).values
    assert_allclose(x, sol.y[:n, -1], rtol=0, atol=2e-6)  # m
    assert_allclose(v, sol.y[n:2 * n, -1], rtol=0, atol=5e-5)  # m/s
    # the gears did close (deflection beyond the 5 mm half-slack past the 20 mm travel),
    # and the closure changes the answer by far more than the tolerances
    xs = sol.sol(np.linspace(0.0, 1.0, 10001))[:n]
    beyond = np.abs(xs[:-1] - xs[1:]).max(axis=1) - 0.005
    assert np.all(beyond > 0.03)
    f0, _ = make_rhs(chain(None))
    free = solve_ivp(f0, (0.0, 1.0), y0, method="DOP853", rtol=1e-11, atol=1e-12,
                     max_step=1e-3)
    assert np.abs(free.y[n:2 * n, -1] - sol.y[n:2 * n, -1]).max() > 0.1
