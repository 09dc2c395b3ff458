"""The brake pipe (physics/brakepipe.py) against closed forms and conservation laws.

A small rig integrates ``pipe_rates`` with the classical Runge-Kutta method (written
here, no kernel): waves against the wave equation and the telegraph equation, steady
flow to a leak against isothermal pipe flow with friction, mass against its balance,
the friction law against Colebrook's equation, the rate bound against numpy's
eigenvalues of the linearised pipe.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from ltdsim.physics.air.brakepipe import (
    air_viscosity,
    friction_factor,
    friction_phi,
    pipe_geometry,
    pipe_mass,
    pipe_max_rate,
    pipe_rates,
)
from ltdsim.physics.air.pneumatics import orifice_flow

GAMMA, R, T, PATM, R_LIN = 1.4, 287.05, 293.15, 101325.0, 0.995
C = math.sqrt(R * T)  # isothermal speed of sound, m/s (290.1)
MU = 1.81e-5  # dynamic viscosity of air at 20 C, Pa s (handbook value)
D = 0.0318  # 1 1/4 in brake pipe bore, m
A = math.pi * D**2 / 4
EPS = 4.5e-5  # commercial steel, m
P0 = 6e5  # a charged pipe, Pa abs (5 bar gauge)


class Pipe:
    """A pipe with its grid and parameters; ``feed(p)`` gives the external inflow into
    each cell (kg/s) at pressures ``p``."""

    def __init__(self, dx_cell, dx_face, *, diameter=D, roughness=EPS, viscosity=MU,
                 leaks=None, feed=None):
        self.dx_cell, self.dx_face = np.asarray(dx_cell, float), np.asarray(dx_face, float)
        self.nc = self.dx_cell.size
        self.diameter, self.roughness, self.viscosity = diameter, roughness, viscosity
        self.area = math.pi * diameter**2 / 4
        self.leaks = np.zeros(self.nc) if leaks is None else np.asarray(leaks, float)
        self.feed = feed

    def rates(self, y, dy):
        """Rates of ``y = [p (nc), q (nc - 1), net mass out (1)]`` into ``dy``."""
        nc = self.nc
        p, q = y[:nc], y[nc:2 * nc - 1]
        inflow = self.feed(p) if self.feed is not None else np.zeros(nc)
        leak = pipe_rates(p, q, inflow, (self.area, self.dx_cell, self.dx_face,
                                         self.diameter, self.roughness, self.viscosity,
                                         self.leaks),
                          (GAMMA, R, T, PATM, R_LIN), dy[:nc], dy[nc:2 * nc - 1])
        dy[-1] = leak - float(np.sum(inflow))

    def mass(self, y):
        """Pipe air mass plus the air that left it, kg (constant if mass is conserved)."""
        return pipe_mass(y[:self.nc], self.dx_cell, self.area, R, T) + y[-1]


def state(p, q):
    return np.concatenate([p, q, [0.0]])


def rk4(pipe, y, dt, steps, probe=None):
    """Classical Runge-Kutta, fixed step ``dt`` (s); ``probe(k, y)`` after each step."""
    k1, k2, k3, k4 = (np.zeros_like(y) for _ in range(4))
    for k in range(steps):
        pipe.rates(y, k1)
        pipe.rates(y + 0.5 * dt * k1, k2)
        pipe.rates(y + 0.5 * dt * k2, k3)
        pipe.rates(y + dt * k3, k4)
        y = y + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if probe is not None:
            probe(k, y)
    return y


def uniform(length, nc):
    dx = np.full(nc, length / nc)
    return dx, 0.5 * (dx[:-1] + dx[1:]), np.cumsum(dx) - 0.5 * dx


# ------------------------------------------------------------------- waves
def test_pulse_travels_at_the_isothermal_speed_of_sound():
    """A 100 Pa Gaussian pulse (sigma 15 m) in a frictionless closed 1200 m pipe of 1 m
    cells: its peak passes stations 600 m apart at sqrt(R T) within 1 %."""
    dx, dxf, x = uniform(1200.0, 1200)
    pipe = Pipe(dx, dxf, viscosity=0.0)
    xf = 0.5 * (x[:-1] + x[1:])
    pulse = lambda s: 100.0 * np.exp(-0.5 * ((s - 150.0) / 15.0) ** 2)
    # a right-running simple wave: q = A p' / c
    y = state(P0 + pulse(x), A / C * pulse(xf))
    stations = [int(np.argmin(abs(x - s))) for s in (300.0, 900.0)]
    dt, steps = 1e-3, 2800
    rec = np.zeros((steps, 2))

    def probe(k, yk):
        rec[k] = yk[stations] - P0

    rk4(pipe, y, dt, steps, probe)
    times = []
    for col in rec.T:
        k = int(np.argmax(col))
        a, b, c = col[k - 1:k + 2]
        times.append(dt * (k + 1 + 0.5 * (a - c) / (a - 2 * b + c)))  # parabola's top
    speed = (x[stations[1]] - x[stations[0]]) / (times[1] - times[0])
    assert abs(speed / C - 1.0) < 0.01, speed
    assert abs(speed / C - 1.0) < 1e-3  # in fact within 0.1 % at 15 cells per sigma


@pytest.mark.parametrize("drop", [200.0, 40e3])
def test_front_travels_at_the_speed_of_sound_on_the_default_grid(drop):
    """A pressure drop rising over 0.5 s (10-90 %) runs down a 100-wagon pipe cut as
    the engine cuts it by default (2 cells per 15 m wagon, 7.5 m cells). Its half-drop
    passes stations 750 m apart at the speed of isothermal simple-wave theory within
    0.5 %: each pressure level of a wave running into still air travels at
    ``u + c = c (1 + ln(p / p0))`` (the Riemann invariant ``u - c ln(rho)`` is uniform),
    i.e. at sqrt(R T) for a small drop (200 Pa) and 3.4 % slower at the half level of a
    40 kPa drop, whose air flows back towards the vent."""
    g = pipe_geometry(np.full(100, 15.0), 2)
    pipe = Pipe(g.dx_cell, g.dx_face, viscosity=0.0)
    width = 0.5 * C / 2.197  # tanh front: 10-90 % over 0.5 s, m
    front = lambda s: P0 - 0.5 * drop * (1.0 - np.tanh((s - 300.0) / width))
    wave = lambda p: p / (R * T) * A * C * np.log(p / P0)  # simple wave's flow, kg/s
    xf = 0.5 * (g.x_cell[:-1] + g.x_cell[1:])
    y = state(front(g.x_cell), wave(front(xf)))
    stations = [int(np.argmin(abs(g.x_cell - s))) for s in (450.0, 1200.0)]
    dt, steps = 5e-3, 700
    rec = np.zeros((steps, 2))

    def probe(k, yk):
        rec[k] = yk[stations] - P0

    rk4(pipe, y, dt, steps, probe)
    times = []
    half = -0.5 * drop
    for col in rec.T:
        k = int(np.argmax(col < half))  # first sample past the half drop
        times.append(dt * (k + (col[k - 1] - half) / (col[k - 1] - col[k])))
    speed = (g.x_cell[stations[1]] - g.x_cell[stations[0]]) / (times[1] - times[0])
    expected = C * (1.0 + math.log((P0 + half) / P0))
    assert abs(speed / expected - 1.0) < 0.005, (speed, expected)
    if drop < 1e3:
        assert abs(speed / C - 1.0) < 0.01


def test_laminar_friction_slows_and_damps_a_wave_as_the_telegraph_equation_says():
    """The first standing mode of a closed 100 m pipe of 4 mm bore (laminar friction
    rate kappa = 32 mu / (D^2 rho) = 5.1 1/s, of the order of the mode's 9.1 rad/s)
    against the linearised damped-wave (telegraph) equation
    ``p_tt + kappa p_t = c^2 p_xx``: amplitude ``exp(-kappa t / 2)``, frequency
    ``omega_d = sqrt(c^2 k^2 - kappa^2 / 4)``, i.e. a phase speed ``omega_d / k`` below c."""
    from scipy.optimize import curve_fit

    d = 0.004
    length, nc = 100.0, 100
    dx, dxf, x = uniform(length, nc)
    pipe = Pipe(dx, dxf, diameter=d, roughness=0.0)
    k = math.pi / length
    eps = 100.0  # Pa, Reynolds number ~80: laminar
    y = state(P0 + eps * np.cos(k * x), np.zeros(nc - 1))
    kappa = 32.0 * MU * R * T / (d**2 * P0)
    omega_d = math.sqrt((C * k) ** 2 - kappa**2 / 4)
    dt, steps = 1e-3, 2100  # three periods
    amp = np.zeros(steps)
    basis = 2.0 / length * np.cos(k * x) * dx

    def probe(j, yj):
        amp[j] = basis @ (yj[:nc] - P0)

    rk4(pipe, y, dt, steps, probe)
    t = dt * np.arange(1, steps + 1)
    exact = eps * np.exp(-kappa * t / 2) * (np.cos(omega_d * t)
                                            + kappa / (2 * omega_d) * np.sin(omega_d * t))
    assert np.max(np.abs(amp - exact)) < 2e-3 * eps

    def model(t, alpha, omega):
        return eps * np.exp(-alpha * t) * (np.cos(omega * t) + alpha / omega * np.sin(omega * t))

    (alpha, omega), _ = curve_fit(model, t, amp, p0=(1.0, C * k))
    assert abs(alpha / (kappa / 2) - 1) < 2e-3
    assert abs(omega / omega_d - 1) < 2e-4
    speed = omega / k
    assert 0.95 < speed / C < 0.97  # slower than c by 4.0 % ...
    assert abs(speed / (omega_d / k) - 1) < 2e-4  # ... as the closed form says


# -------------------------------------------------------------- steady flow
def _closed_form_profile(p1, x, g_flux, f, d):
    """Pressures (Pa) at distances ``x`` (m) downstream of ``p1`` in isothermal flow of
    mass flux ``g_flux`` (kg/(m^2 s)) with Darcy factor ``f`` in a pipe of bore ``d``:
    ``p1^2 - p^2 = g^2 R T (f x / d + 2 ln(p1 / p))``."""
    def gap(p, xi):
        return p1**2 - p**2 - g_flux**2 * R * T * (f * xi / d + 2 * math.log(p1 / p))

    return np.array([brentq(gap, 0.3 * p1, p1, args=(xi,), xtol=1e-9) for xi in x])


def _steady(pipe, p_feed, feed_cd_area, dt, steps):
    def feed(p):
        w = np.zeros(pipe.nc)
        w[0] = orifice_flow(p_feed, p[0], feed_cd_area, GAMMA, R, T, R_LIN)
        return w

    pipe.feed = feed
    y = state(np.full(pipe.nc, p_feed), np.zeros(pipe.nc - 1))
    return rk4(pipe, y, dt, steps)


@pytest.mark.parametrize("case", ["train", "short"])
def test_steady_flow_to_a_leak_matches_isothermal_pipe_flow_with_friction(case):
    """Fed from 6 bar abs at the head, leaking at the tail; at steady state every face
    carries the leak's flow and the pressure drop from cell 2 to each cell further back
    matches ``p1^2 - p2^2 = (mdot/A)^2 R T (f L / D + 2 ln(p1/p2))`` within 1 % of the
    drop (f from the friction law at the steady Reynolds number).

    ``train``: 50 wagons of 15 m, 2 cells each, a 0.02 kg/s leak (the friction term).
    ``short``: 5 m of pipe, 40 cells, Mach 0.74 at the leak, where the convected
    momentum (the ``2 ln`` term) makes a third of the drop."""
    if case == "train":
        g = pipe_geometry(np.full(50, 15.0), 2)
        dx, dxf, x = g.dx_cell, g.dx_face, g.x_cell
        leak_cda, feed_cda, dt, steps = 1.5e-5, 2e-4, 5e-3, 16000
    else:
        dx, dxf, x = uniform(5.0, 40)
        leak_cda, feed_cda, dt, steps = 6e-4, 1e-3, 2.5e-5, 16000
    leaks = np.zeros(dx.size)
    leaks[-1] = leak_cda
    pipe = Pipe(dx, dxf, leaks=leaks)
    y = _steady(pipe, P0, feed_cda, dt, steps)
    nc = pipe.nc
    p, q = y[:nc], y[nc:2 * nc - 1]
    mdot = orifice_flow(p[-1], PATM, leak_cda, GAMMA, R, T, R_LIN)
    assert np.max(np.abs(q / mdot - 1)) < 1e-4  # steady: every face carries the leak
    g_flux = mdot / A
    re = g_flux * D / MU
    f = friction_factor(re, EPS / D)
    inner = slice(1, nc - 1)  # the end cells take flow from the side (see the module)
    exact = _closed_form_profile(p[1], x[inner] - x[1], g_flux, f, D)
    drop, drop_exact = p[1] - p[inner], p[1] - exact
    error = np.max(np.abs(drop - drop_exact)[1:] / drop_exact[1:])
    assert error < 0.01
    assert error < 1e-3  # in fact 1e-5 ("train") and 1e-4 ("short")
    mach = g_flux * R * T / (p[-2] * C)
    if case == "short":
        assert mach > 0.6
        no_convection = np.sqrt(p[1] ** 2 - g_flux**2 * R * T * f * (x[-2] - x[1]) / D)
        assert (p[1] - no_convection) / drop[-1] < 0.7  # the 2 ln term is a third of it
    else:
        assert re > 4000 and mach < 0.05


# ------------------------------------------------------------- conservation
def test_mass_is_conserved_through_an_emergency_vent_and_leaks():
    """20 wagons, fed at the head, vented through a 25 mm emergency orifice at the tail,
    leaking in every cell and drawn by a control valve in every wagon, for 5 s: pipe
    mass plus the accumulated net outflow stays constant within 1e-9 relative."""
    rng = np.random.default_rng(7)
    g = pipe_geometry(rng.uniform(12.0, 22.0, 20), 2)
    nc = g.dx_cell.size
    leaks = rng.uniform(0.0, 2e-7, nc)
    leaks[-1] = 0.8 * math.pi * 0.025**2 / 4

    def feed(p):
        w = np.zeros(nc)
        w[0] = orifice_flow(P0, p[0], 5e-5, GAMMA, R, T, R_LIN)
        w[g.vehicle_cell] -= 1e-4 * p[g.vehicle_cell] / P0  # charging reservoirs
        return w

    pipe = Pipe(g.dx_cell, g.dx_face, leaks=leaks, feed=feed)
    y = state(np.full(nc, P0), np.zeros(nc - 1))
    m0 = pipe.mass(y)
    seen = []
    y = rk4(pipe, y, 1e-3, 5000, lambda k, yk: seen.append(yk[nc - 1]) if k % 50 == 0 else None)
    assert abs(pipe.mass(y) - m0) < 1e-9 * m0
    assert min(seen) < 0.5 * P0  # the vent did empty the tail
    assert np.all(np.isfinite(y))


GEOM = st.lists(st.floats(5.0, 30.0), min_size=1, max_size=6)


@settings(deadline=None, max_examples=80)
@given(lengths=GEOM, n=st.integers(1, 4), seed=st.integers(0, 2**31))
def test_rates_conserve_mass_and_mirror(lengths, n, seed):
    """For random grids and states (0.5-10 bar abs, flows up to 0.5 kg/s, inflows and
    leaks): the rates change the pipe's mass by exactly inflow minus leak (1e-12 of the
    flows), and a pipe turned end for end gives the mirrored rates (friction and
    convected momentum oppose and follow the flow, whichever way it runs)."""
    rng = np.random.default_rng(seed)
    g = pipe_geometry(lengths, n)
    nc = g.dx_cell.size
    p = rng.uniform(1.5e5, 1e6, nc)
    q = rng.uniform(-0.5, 0.5, nc - 1)
    inflow = rng.uniform(-0.05, 0.05, nc)
    leaks = rng.uniform(0.0, 1e-5, nc) * (rng.random(nc) < 0.5)
    args = (A, g.dx_cell, g.dx_face, D, EPS, MU)
    gas = (GAMMA, R, T, PATM, R_LIN)
    dp, dq = np.zeros(nc), np.zeros(nc - 1)
    leak = pipe_rates(p, q, inflow, (*args, leaks), gas, dp, dq)
    dm = np.sum(dp * g.dx_cell) * A / (R * T)
    scale = np.sum(np.abs(q)) + np.sum(np.abs(inflow)) + abs(leak) + 1e-12
    assert abs(dm - (np.sum(inflow) - leak)) < 1e-12 * scale
    rp, rq = np.zeros(nc), np.zeros(nc - 1)
    rev = (A, g.dx_cell[::-1].copy(), g.dx_face[::-1].copy(), D, EPS, MU)
    leak_r = pipe_rates(p[::-1].copy(), -q[::-1], inflow[::-1].copy(),
                        (*rev, leaks[::-1].copy()), gas, rp, rq)
    assert math.isclose(leak_r, leak, rel_tol=1e-12, abs_tol=1e-15)
    np.testing.assert_allclose(rp[::-1], dp, rtol=1e-9, atol=1e-9 * np.max(np.abs(dp)))
    np.testing.assert_allclose(-rq[::-1], dq, rtol=1e-9, atol=1e-9 * np.max(np.abs(dq), initial=0.0))


def test_rest_is_an_equilibrium():
    """A uniformly charged tight pipe without flow has zero rates."""
    g = pipe_geometry([20.0, 15.0, 15.0], 3)
    nc = g.dx_cell.size
    dp, dq = np.ones(nc), np.ones(nc - 1)
    leak = pipe_rates(np.full(nc, P0), np.zeros(nc - 1), np.zeros(nc),
                      (A, g.dx_cell, g.dx_face, D, EPS, MU, np.zeros(nc)),
                      (GAMMA, R, T, PATM, R_LIN), dp, dq)
    assert leak == 0.0 and not dp.any() and not dq.any()


# ---------------------------------------------------------------- friction
def test_viscosity_of_air():
    """Sutherland's law against tabulated viscosities of dry air at 1 atm, Pa s
    (chem-casts.com's air property table, 3 digits): within 2 % from -20 C to 100 C
    (within 1 % from 20 C up)."""
    for temp, mu, tol in ((253.15, 1.59e-5, 0.02), (293.15, 1.81e-5, 0.01),
                          (353.15, 2.08e-5, 0.01), (373.15, 2.16e-5, 0.01)):
        assert abs(air_viscosity(temp) / mu - 1) < tol


def _colebrook(re, rel):
    fun = lambda s: s + 2.0 * math.log10(rel / 3.7 + 2.51 * s / re)
    s = brentq(fun, 0.5, 50.0)
    return 1.0 / s**2


@settings(deadline=None, max_examples=200)
@given(re=st.floats(4000.0, 1e8), rel=st.floats(0.0, 0.05))
def test_turbulent_friction_is_colebrook_within_two_percent(re, rel):
    assert abs(friction_factor(re, rel) / _colebrook(re, rel) - 1) < 0.02


@settings(deadline=None, max_examples=200)
@given(re=st.floats(1e-3, 1e8), ratio=st.floats(1.0001, 1.5), rel=st.floats(0.0, 0.05))
def test_wall_shear_grows_with_the_flow(re, ratio, rel):
    """``phi(Re) Re = f Re^2`` (the wall shear at a given density) rises strictly with
    Re everywhere, through the laminar-turbulent blend: one flow per pressure drop."""
    assert friction_phi(re * ratio, rel) * re * ratio > friction_phi(re, rel) * re


@pytest.mark.parametrize("edge", [2300.0, 4000.0])
def test_friction_is_continuous_in_value_and_slope_at_the_blend(edge):
    rel = 0.0014
    h = 1e-3
    val = [friction_phi(edge + s * h, rel) for s in (-2, -1, 0, 1, 2)]
    assert abs(val[3] - val[1]) < 1e-5 * val[2]
    left, right = (val[2] - val[0]) / (2 * h), (val[4] - val[2]) / (2 * h)
    mean_slope = (friction_phi(4000.0, rel) - friction_phi(2300.0, rel)) / 1700.0
    assert abs(left - right) < 1e-4 * mean_slope  # one-sided slopes differ by O(h) only
    assert friction_phi(0.0, rel) == 64.0 and friction_phi(1000.0, rel) == 64.0


# ------------------------------------------------------------ stiffness bound
def _jacobian(p, q, pipe_args, leaks):
    nc = p.size
    y0 = np.concatenate([p, q])

    def f(y):
        dp, dq = np.zeros(nc), np.zeros(nc - 1)
        pipe_rates(y[:nc], y[nc:], np.zeros(nc), (*pipe_args, leaks),
                   (GAMMA, R, T, PATM, R_LIN), dp, dq)
        return np.concatenate([dp, dq])

    jac = np.zeros((y0.size, y0.size))
    for i in range(y0.size):
        h = 1e-6 * max(abs(y0[i]), 1e-3 if i >= nc else 1.0)
        e = np.zeros(y0.size)
        e[i] = h
        jac[:, i] = (f(y0 + e) - f(y0 - e)) / (2 * h)
    return jac


@settings(deadline=None, max_examples=60)
@given(lengths=GEOM, n=st.integers(1, 4), flow=st.floats(0.0, 0.6),
       leak=st.floats(0.0, 2e-5), seed=st.integers(0, 2**31))
def test_max_rate_bounds_the_eigenvalues(lengths, n, flow, leak, seed):
    """pipe_max_rate is above the largest |eigenvalue| of the numerically linearised
    pipe (numpy), for random grids, flows up to 0.6 kg/s (Mach 0.7) and leaks up to a
    5 mm orifice per cell; and not far above: equal to it (1e-3) at rest in a tight
    pipe, within 1.25 times with leaks, within 3 times with flow (friction's and the
    flow's shares are added as if they met in one mode)."""
    rng = np.random.default_rng(seed)
    g = pipe_geometry(lengths, n)
    nc = g.dx_cell.size
    if nc < 2:
        return
    p = rng.uniform(1.5e5, 7e5, nc)
    q = flow * rng.uniform(-1.0, 1.0, nc - 1)
    leaks = leak * rng.random(nc)
    args = (A, g.dx_cell, g.dx_face, D, EPS, MU)
    lam = np.max(np.abs(np.linalg.eigvals(_jacobian(p, q, args, leaks))))
    bound = pipe_max_rate(p, q, (*args, leaks), (GAMMA, R, T, PATM, R_LIN))
    assert lam <= bound * (1 + 1e-6)
    assert bound <= (3.0 if flow > 0.0 else 1.25 if leak > 0.0 else 1.001) * lam


def test_max_rate_is_tight_on_a_uniform_pipe_at_rest():
    """Uniform 7.5 m cells, no flow: the highest mode is (2 c / dx) cos(pi / (2 nc))."""
    g = pipe_geometry(np.full(20, 15.0), 2)
    nc = g.dx_cell.size
    args = (A, g.dx_cell, g.dx_face, D, EPS, MU)
    p, q = np.full(nc, P0), np.zeros(nc - 1)
    lam = np.max(np.abs(np.linalg.eigvals(_jacobian(p, q, args, np.zeros(nc)))))
    exact = 2 * C / 7.5 * math.cos(math.pi / (2 * nc))
    assert abs(lam / exact - 1) < 1e-4
    bound = pipe_max_rate(p, q, (*args, np.zeros(nc)), (GAMMA, R, T, PATM, R_LIN))
    assert lam * (1 - 1e-6) <= bound < 1.0001 * lam
