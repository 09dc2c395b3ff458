"""The polymer draft gear (ltdsim.physics.gears.polymer) on its own.

Checked against things independent of the law's code:
(a) over a closed deflection loop the energy the gear absorbs (the integral of F dx)
    equals the area between its loading and unloading curves, written here in closed
    form, less the corners its locked transitions cut (also closed form), within 1 %;
    the corners are 1.5-7 % of the area with the preset's locked stiffness;
(b) the loading and unloading stiffness measured on a driven gear rise with the closing
    speed as the model's closed form says (hypothesis over speeds);
(c) an impact of two wagons through the gear conserves momentum to 1e-9 and the kinetic
    energy lost equals the energy the gear absorbed (its force-deflection loop) within
    1 %; a second solver (SciPy's DOP853) gives the same impact.

The histories come from two small drivers, :func:`loop_history` (deflection imposed)
and :func:`impact_history` (two free wagons), each returning a dict of arrays. Once the
polymer gear is wired into the scenario schema and the kernel, a driver built on
``ltdsim.simulate`` (or the gear rig) can replace them with no change to the checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from ltdsim.physics.gears.polymer import polymer_gear
from ltdsim.data import load_preset

PRESET = "polymer-heavy-haul"
#: the law's parameters in the order :func:`polymer_gear` takes them
LAW_KEYS = ("preload", "initial_stiffness", "force_at_travel", "travel", "exponent",
            "return_ratio", "gain_loading", "gain_unloading", "rate_speed")


def gear():
    """The preset's keys as a dict (floats)."""
    return {k: v for k, v in load_preset("gears", PRESET).items() if k != "model"}


def law(p):
    """The law's parameters as an array, in :data:`LAW_KEYS` order."""
    return np.array([float(p[k]) for k in LAW_KEYS])


# ---------------------------------------------------------------- closed forms (independent)

def f_static(p, x):
    """Static loading force, N: ``P + k0 x + (F_X - P - k0 X)(x/X)^n``."""
    c = p["force_at_travel"] - p["preload"] - p["initial_stiffness"] * p["travel"]
    return p["preload"] + p["initial_stiffness"] * x + c * (x / p["travel"]) ** p["exponent"]


def s_static(p, x):
    """Its slope, N/m."""
    c = p["force_at_travel"] - p["preload"] - p["initial_stiffness"] * p["travel"]
    n = p["exponent"]
    return p["initial_stiffness"] + c * n * x ** (n - 1.0) / p["travel"] ** n


def work_static(p, x):
    """Its integral from 0 to ``x``, J."""
    c = p["force_at_travel"] - p["preload"] - p["initial_stiffness"] * p["travel"]
    n, big_x = p["exponent"], p["travel"]
    return (p["preload"] * x + 0.5 * p["initial_stiffness"] * x * x
            + c * big_x / (n + 1.0) * (x / big_x) ** (n + 1.0))


def factors(p, v):
    """``(R_l(v), r R_u(v))``: what multiplies the static curve on loading and unloading."""
    fade = 1.0 - math.exp(-abs(v) / p["rate_speed"])
    return (1.0 + p["gain_loading"] * fade,
            p["return_ratio"] * (1.0 + p["gain_unloading"] * fade))


# ---------------------------------------------------------------- drivers

@njit(cache=False)
def _stage(f1, x, v, q, k_locked, rate, ks):
    f, df1 = polymer_gear(f1, x, v, (q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]),
                          k_locked, rate, ks)
    return f, df1


@njit(cache=False)
def _drive(x0, f10, ends, speeds, dx_max, dt_max, q, k_locked, rate, ks):
    """Classical RK4 of the internal force F1 and the work W = int F dx along a deflection
    path of straight legs (leg ``i`` from the previous end to ``ends[i]`` at speed
    ``speeds[i]`` > 0, m and m/s). Steps end exactly on the leg ends."""
    counts = np.empty(ends.shape[0], np.int64)
    x = x0
    for i in range(ends.shape[0]):
        h_max = min(dx_max / speeds[i], dt_max)
        counts[i] = max(1, int(math.ceil(abs(ends[i] - x) / speeds[i] / h_max)))
        x = ends[i]
    n = counts.sum()
    t_o = np.zeros(n + 1)
    x_o = np.zeros(n + 1)
    v_o = np.zeros(n + 1)
    f_o = np.zeros(n + 1)
    w_o = np.zeros(n + 1)
    x = x0
    f1 = f10
    w = 0.0
    t = 0.0
    x_o[0] = x0
    v_o[0] = speeds[0] if ends[0] >= x0 else -speeds[0]
    f_o[0] = _stage(f1, x0, v_o[0], q, k_locked, rate, ks)[0]
    j = 0
    for i in range(ends.shape[0]):
        v = speeds[i] if ends[i] >= x else -speeds[i]
        xa = x
        h = abs(ends[i] - xa) / speeds[i] / counts[i]
        for k in range(counts[i]):
            xs = xa + v * h * k
            f_a, d_a = _stage(f1, xs, v, q, k_locked, rate, ks)
            f_b, d_b = _stage(f1 + 0.5 * h * d_a, xs + 0.5 * h * v, v, q, k_locked, rate, ks)
            f_c, d_c = _stage(f1 + 0.5 * h * d_b, xs + 0.5 * h * v, v, q, k_locked, rate, ks)
            f_d, d_d = _stage(f1 + h * d_c, xs + h * v, v, q, k_locked, rate, ks)
            f1 += h / 6.0 * (d_a + 2.0 * d_b + 2.0 * d_c + d_d)
            w += h / 6.0 * v * (f_a + 2.0 * f_b + 2.0 * f_c + f_d)
            t += h
            j += 1
            x_o[j] = xa + v * h * (k + 1)
            t_o[j] = t
            v_o[j] = v
            f_o[j] = _stage(f1, x_o[j], v, q, k_locked, rate, ks)[0]
            w_o[j] = w
        x = ends[i]
        x_o[j] = x
    return t_o, x_o, v_o, f_o, w_o


def loop_history(p, ends, speeds, *, tracking_time, dx_max=2e-5):
    """Time history of one gear driven along imposed deflection legs (from 0, its
    internal force at the released force ``preload``): dict of ``t`` (s), ``x`` (m),
    ``v`` (m/s), ``force`` (N) and ``work`` (J, int F dx from the start)."""
    t, x, v, f, w = _drive(0.0, p["preload"], np.asarray(ends, float),
                           np.asarray(speeds, float), dx_max, 0.5 * tracking_time, law(p),
                           p["k_locked"], 1.0 / tracking_time, p["solid_stiffness"])
    return {"t": t, "x": x, "v": v, "force": f, "work": w}


@njit(cache=False)
def _impact(m1, m2, v0, h, t_end, q, k_locked, rate, ks):
    """Classical RK4 of two wagons meeting through the gear: state (x1, v1, x2, v2, F1);
    the gear's closure is e = x1 - x2 (no slack: contact from e = 0 on), it can only
    push, and out of contact its internal force relaxes to the released force."""
    n = int(math.ceil(t_end / h))
    y = np.zeros((n + 1, 5))
    force = np.zeros(n + 1)
    y[0, 1] = v0
    y[0, 4] = q[0]
    dy = np.zeros((4, 5))
    for i in range(n):
        for s in range(4):
            c = 0.0 if s == 0 else (0.5 if s < 3 else 1.0)
            ys = y[i] + c * h * dy[s - 1] if s > 0 else y[i].copy()
            e = ys[0] - ys[2]
            ed = ys[1] - ys[3]
            if e > 0.0:
                f, df1 = _stage(ys[4], e, ed, q, k_locked, rate, ks)
            else:
                f, df1 = 0.0, rate * (q[0] - ys[4])
            dy[s, 0] = ys[1]
            dy[s, 1] = -f / m1
            dy[s, 2] = ys[3]
            dy[s, 3] = f / m2
            dy[s, 4] = df1
        y[i + 1] = y[i] + h / 6.0 * (dy[0] + 2.0 * dy[1] + 2.0 * dy[2] + dy[3])
        e = y[i + 1, 0] - y[i + 1, 2]
        force[i + 1] = (_stage(y[i + 1, 4], e, y[i + 1, 1] - y[i + 1, 3], q, k_locked, rate,
                               ks)[0] if e > 0.0 else 0.0)
    return y, force


def impact_history(p, m1, m2, v0, *, tracking_time, h=2e-5, t_end=0.6):
    """Time history of wagon 1 (``m1`` kg, at ``v0`` m/s) running into wagon 2 (``m2``
    kg, at rest) through one gear: dict of ``t`` (s), ``x1, v1, x2, v2`` (m, m/s),
    ``closure`` (m), ``force`` (N, pushing the wagons apart)."""
    y, f = _impact(m1, m2, v0, h, t_end, law(p), p["k_locked"], 1.0 / tracking_time,
                   p["solid_stiffness"])
    return {"t": h * np.arange(y.shape[0]), "x1": y[:, 0], "v1": y[:, 1], "x2": y[:, 2],
            "v2": y[:, 3], "closure": y[:, 0] - y[:, 2], "force": f}


# ---------------------------------------------------------------- (a) loop energy

def _corner(b0, g, k):
    """Energy (J) a locked transition cuts from the loop: the force crosses a band of
    width ``b(u) = b0 - g u`` (N; ``u`` the deflection travelled since the reversal, m)
    at stiffness ``k`` (N/m) relative to it, its place in the band falling at ``k / b``
    per metre. Integrating, with ``eps = g / k``:
    ``k b0^2 / g^2 (1/4 - exp(-2 eps) (eps/2 + 1/4))``, which is ``b0^2 / (2 k)
    (1 - 4 eps / 3)`` for small ``eps``."""
    eps = g / k
    if abs(eps) < 1e-4:
        return b0 * b0 / (2.0 * k) * (1.0 - 4.0 * eps / 3.0)
    return k * b0 * b0 / (g * g) * (0.25 - math.exp(-2.0 * eps) * (0.5 * eps + 0.25))


def _expected_loop(p, amplitude, v, tracking_time):
    """Energy (J) absorbed per closed loop 0 -> A -> 0 at speed v: the area between the
    curves less the two corners the locked transitions cut (:func:`_corner`; at the top
    the band narrows as the gear opens, at the bottom it widens as it closes) and the
    deflection ``v * tracking_time`` the gear retraces on its curve at each reversal
    before it turns (``b v tau``)."""
    rl, ru = factors(p, v)
    area = (rl - ru) * work_static(p, amplitude)
    b_top = (rl - ru) * f_static(p, amplitude)
    b_bot = (rl - ru) * p["preload"]
    k = p["k_locked"]
    cut = (_corner(b_top, (rl - ru) * s_static(p, amplitude), k)
           + _corner(b_bot, -(rl - ru) * s_static(p, 0.0), k)
           + (b_top + b_bot) * v * tracking_time)
    return area, area - cut


@settings(max_examples=12, deadline=None)
@given(v=st.floats(0.01, 2.5), share=st.floats(0.2, 1.0))
def test_loop_energy_equals_loop_area(v, share):
    p = gear()
    amp = share * p["travel"]
    tau = 5e-5  # s: tracking time of the internal force
    h = loop_history(p, [amp, 0.0, amp, 0.0], [v] * 4, tracking_time=tau)
    first = np.flatnonzero(h["x"] == 0.0)[1]   # back at 0 after the first loop
    w_loop = h["work"][-1] - h["work"][first]
    area, expected = _expected_loop(p, amp, v, tau)
    assert w_loop == pytest.approx(expected, rel=0.01)
    # the corners are a small share: the loop is the area between the curves
    assert w_loop == pytest.approx(area, rel=0.08)


def test_loop_energy_at_the_preset_tracking_time():
    """With the heavy-haul scenario's tracking time (2 ms) the corner estimate still
    holds at a slow loop to full travel, where the loop has its largest band."""
    p = gear()
    v, tau = 0.05, 2e-3
    h = loop_history(p, [p["travel"], 0.0, p["travel"], 0.0], [v] * 4, tracking_time=tau)
    first = np.flatnonzero(h["x"] == 0.0)[1]
    _, expected = _expected_loop(p, p["travel"], v, tau)
    assert h["work"][-1] - h["work"][first] == pytest.approx(expected, rel=0.01)


# ---------------------------------------------------------------- (b) rate dependence

def _measured_slopes(p, v):
    """Loading and unloading stiffness (N/m) measured on the driven gear at speed v:
    the force's gradient along the deflection on each leg, at 30-90 % of the travel
    (loading) and 10-60 % (unloading, past the turn)."""
    h = loop_history(p, [p["travel"], 0.0], [v, v], tracking_time=5e-5)
    x, f, vel = h["x"], h["force"], h["v"]
    out = []
    for sign, lo, hi in ((1.0, 0.3, 0.9), (-1.0, 0.1, 0.6)):
        leg = np.flatnonzero((vel * sign > 0) & (x > lo * p["travel"]) & (x < hi * p["travel"]))
        order = np.argsort(x[leg])           # increasing deflection on both legs
        xs, fs = x[leg][order], f[leg][order]
        out.append((xs, np.gradient(fs, xs)))
    return out


@settings(max_examples=10, deadline=None)
@given(v=st.floats(0.01, 3.0))
def test_stiffness_follows_the_closed_form(v):
    p = gear()
    (xl, kl), (xu, ku) = _measured_slopes(p, v)
    rl, ru = factors(p, v)
    np.testing.assert_allclose(kl[2:-2], rl * s_static(p, xl[2:-2]), rtol=1e-3)
    np.testing.assert_allclose(ku[2:-2], ru * s_static(p, xu[2:-2]), rtol=1e-3)


@settings(max_examples=10, deadline=None)
@given(v1=st.floats(0.01, 2.0), ratio=st.floats(1.2, 5.0))
def test_stiffness_rises_with_rate(v1, ratio):
    """Both curves stiffer at the faster closing speed, measured at the same deflection."""
    p = gear()
    v2 = v1 * ratio
    at = (0.6 * p["travel"], 0.4 * p["travel"])
    slow, fast = _measured_slopes(p, v1), _measured_slopes(p, v2)
    for (xs, ks), (xf, kf), x in zip(slow, fast, at):
        assert np.interp(x, xf, kf) > np.interp(x, xs, ks) * (1.0 + 1e-6)


def test_stiffness_limits():
    """Near rest the gear follows its static curve; at impact speeds both curves approach
    (1 + gain) times it."""
    p = gear()
    x = 0.5 * p["travel"]
    (xl, kl), (xu, ku) = _measured_slopes(p, 1e-3)
    assert np.interp(x, xl, kl) == pytest.approx(s_static(p, x), rel=0.01)
    assert np.interp(x, xu, ku) == pytest.approx(p["return_ratio"] * s_static(p, x), rel=0.01)
    (xl, kl), (xu, ku) = _measured_slopes(p, 10.0 * p["rate_speed"])
    assert np.interp(x, xl, kl) == pytest.approx((1 + p["gain_loading"]) * s_static(p, x),
                                                 rel=0.01)
    assert np.interp(x, xu, ku) == pytest.approx(
        p["return_ratio"] * (1 + p["gain_unloading"]) * s_static(p, x), rel=0.01)


# ---------------------------------------------------------------- (c) wagon impact

@pytest.mark.parametrize("v0", [1.0, 2.0, 3.0])
@pytest.mark.parametrize("m1, m2", [(100e3, 100e3), (120e3, 80e3)])
def test_impact_conserves_momentum_and_energy(m1, m2, v0):
    p = gear()
    h = impact_history(p, m1, m2, v0, tracking_time=2e-3)
    mom = m1 * h["v1"] + m2 * h["v2"]
    np.testing.assert_allclose(mom, m1 * v0, rtol=1e-9)
    e = h["closure"]
    assert e.max() > 0.01                     # the gear was closed ...
    sep = np.flatnonzero((e[1:] <= 0.0) & (e[:-1] > 0.0))
    assert sep.size, "the wagons never separated"
    end = sep[0] + 1                          # ... and the wagons separated again
    lost = 0.5 * m1 * v0**2 - 0.5 * (m1 * h["v1"][end] ** 2 + m2 * h["v2"][end] ** 2)
    absorbed = np.trapezoid(h["force"][:end + 1], e[:end + 1])   # the gear's loop, J
    assert lost > 0.0
    assert absorbed == pytest.approx(lost, rel=0.01)
    # a hysteretic gear keeps part of the energy: the wagons part slower than they met
    assert 0.0 < h["v2"][end] - h["v1"][end] < v0


def test_impact_agrees_with_another_solver():
    """The fixed-step driver against SciPy's DOP853 (adaptive, tight tolerances) on the
    same right-hand side: same parting speeds and peak force."""
    from scipy.integrate import solve_ivp

    p = gear()
    m1, m2, v0, tau = 100e3, 100e3, 1.5, 2e-3
    h = impact_history(p, m1, m2, v0, tracking_time=tau)
    q = law(p)

    def rhs(t, y):
        e, ed = y[0] - y[2], y[1] - y[3]
        if e > 0.0:
            f, df1 = _stage(y[4], e, ed, q, p["k_locked"], 1.0 / tau, p["solid_stiffness"])
        else:
            f, df1 = 0.0, (q[0] - y[4]) / tau
        return [y[1], -f / m1, y[3], f / m2, df1]

    def parted(t, y):
        return y[0] - y[2] + 1e-9 if t > 1e-3 else 1.0
    parted.terminal = True
    parted.direction = -1
    sol = solve_ivp(rhs, (0.0, 0.6), [0.0, v0, 0.0, 0.0, q[0]], method="DOP853",
                    rtol=1e-10, atol=1e-12, max_step=1e-3, events=parted)
    e = h["closure"]
    end = np.flatnonzero((e[1:] <= 0.0) & (e[:-1] > 0.0))[0] + 1
    assert sol.status == 1
    assert sol.y[1, -1] == pytest.approx(h["v1"][end], abs=1e-3 * v0)
    assert sol.y[3, -1] == pytest.approx(h["v2"][end], abs=1e-3 * v0)
    peak = max(_stage(y[4], y[0] - y[2], y[1] - y[3], q, p["k_locked"], 1.0 / tau,
                      p["solid_stiffness"])[0] for y in sol.y.T if y[0] > y[2])
    assert peak == pytest.approx(h["force"].max(), rel=2e-3)


# ------------------------------------------------- (c) the same impact through the train
@pytest.mark.parametrize("v0", [1.0, 2.0])
def test_impact_through_simulate(v0):
    """The polymer gear wired into the coupler registry: a wagon impact run by
    ``simulate()`` (``ltdsim.analysis.gears.impact``) conserves momentum, its kinetic energy lost
    equals the energy the coupling absorbed, and its peak force, travel and energy agree
    with this file's own driver of the law."""
    from ltdsim.analysis.gears import impact
    from ltdsim.scenario import CouplerParams

    p = gear()
    tau, m = 2e-3, 100e3
    # (a slack wide enough that the wagons part after the impact instead of pulling
    # back in draft)
    params = CouplerParams(preset=PRESET, slack=0.5, tracking_time=tau)
    r = impact(params, v0, mass_moving=m, mass_standing=m, dt=2e-5, t_max=1.0)
    assert r["separated"]
    assert r["momentum_after"] == pytest.approx(r["momentum_before"], rel=1e-9)
    assert r["energy_absorbed_J"] == pytest.approx(r["kinetic_energy_lost_J"], rel=0.01)
    h = impact_history(p, m, m, v0, tracking_time=tau)
    e = h["closure"]
    end = np.flatnonzero((e[1:] <= 0.0) & (e[:-1] > 0.0))[0] + 1
    lost = 0.5 * m * v0**2 - 0.5 * m * (h["v1"][end] ** 2 + h["v2"][end] ** 2)
    assert r["peak_force_N"] == pytest.approx(h["force"].max(), rel=1e-3)
    # (the coupling's deflection counts the half slack it starts bunched at)
    assert r["max_deflection_m"] - 0.25 == pytest.approx(e.max(), rel=1e-3)
    assert r["kinetic_energy_lost_J"] == pytest.approx(lost, rel=1e-3)
