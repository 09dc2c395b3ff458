"""The end-of-car cushioning unit (ltdsim.physics.gears.cushion), on its own and in a train.

Checked against things independent of the law's code:
(a) the orifice's speed inverts its resistance, F_o(u) = c_l u + c_q u|u| (hypothesis);
(b) below its preload the unit is the oil column alone: F = k_h x on the gear rig;
(c) closed at a constant speed V past its preload, it settles on the closed form
    F = (P + k_s x + F_o(u)) k_h / (k_h + k_s), u = V k_h / (k_h + k_s) the piston's
    speed (hypothesis over speeds);
(d) a two-wagon impact through the unit, run by the train kernel, agrees with SciPy's
    DOP853 on this file's own equations of the two wagons and the piston (peak force,
    stroke, energy the orifice dissipated), conserves momentum, and its energy balance
    closes: the relative kinetic energy lost is what the orifice dissipated once the
    piston is back on its seat.
(The passivity over random cycles is in test_passivity.py.)
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from ltdsim.analysis.gears import drive_deflection, impact
from ltdsim.data import load_preset
from ltdsim.physics.gears.cushion import orifice_speed
from ltdsim.scenario import CouplerParams

PRESET = "eoc-15"
fin = {"allow_nan": False, "allow_infinity": False}


def unit():
    """The preset's keys as a dict."""
    return {k: v for k, v in load_preset("gears", PRESET).items() if k != "model"}


def f_orifice(u, p):
    """The orifice's resistance at the piston speed ``u`` (m/s), N."""
    return p["orifice_linear"] * u + p["orifice_quadratic"] * u * abs(u)


# ---------------------------------------------------------------- (a) the orifice
@settings(max_examples=200, deadline=None)
@given(u=st.floats(-20.0, 20.0, **fin), cl=st.floats(1e2, 1e8, **fin),
       cq=st.floats(0.0, 1e8, **fin))
def test_orifice_speed_inverts_the_resistance(u, cl, cq):
    force = cl * u + cq * u * abs(u)
    assert orifice_speed(force, cl, cq) == pytest.approx(u, rel=1e-9, abs=1e-12)


# ---------------------------------------------------------------- (b), (c) on the rig
def test_rigid_below_its_preload():
    p = unit()
    params = CouplerParams(preset=PRESET, slack=0.0)
    x_max = 0.9 * p["preload"] / p["oil_stiffness"]  # m, the column's force stays below P
    t = np.linspace(0.0, 2.0, 2001)
    d = -x_max * np.sin(np.pi * t / 2.0) ** 2  # in buff and back
    ds = drive_deflection(params, t, d, dt=1e-4)
    f = ds.force.values
    np.testing.assert_allclose(f, p["oil_stiffness"] * ds.deflection.values, rtol=0,
                               atol=1e-6 * p["preload"])


@settings(max_examples=8, deadline=None)
@given(v=st.floats(0.05, 1.5, **fin))
def test_steady_stroke_follows_the_closed_form(v):
    p = unit()
    params = CouplerParams(preset=PRESET, slack=0.0)
    kh, ks = p["oil_stiffness"], p["spring_stiffness"]
    # closed at constant speed to 80 % of the stroke
    t_end = 0.8 * p["travel"] / v
    t = np.linspace(0.0, t_end, 2001)
    ds = drive_deflection(params, t, v * t, dt=min(2e-4, t_end / 4000))
    x, f = ds.deflection.values, ds.force.values
    # the piston starts once the column reaches the preload, at P / (k_h V), and its
    # start decays at the rate (k_h + k_s) / F_o'(u): twelve of its time constants (at
    # most 0.1 s) later it is below 1e-5 of the force
    tau = (p["orifice_linear"] + 2 * p["orifice_quadratic"] * v) / (kh + ks)
    # (the record's last sample, at the drive's end, reads the drive's rate past its
    # table: left out)
    time = ds.time.values
    settled = (time > p["preload"] / (kh * v) + 12 * tau) & (time < time[-1])
    assert settled.sum() > 500
    # steady, the column's force grows with the spring's, k_h (V - u) = k_s u: the piston
    # strokes at u = V k_h / (k_h + k_s), and T = P + k_s s + F_o(u) with s = x - T / k_h
    u = v * kh / (kh + ks)
    closed = (p["preload"] + ks * x + f_orifice(u, p)) * kh / (kh + ks)
    np.testing.assert_allclose(f[settled], closed[settled], rtol=1e-4)


# ---------------------------------------------------------------- (d) an impact
def _impact_reference(p, m1, m2, v0, t_end):
    """Two wagons (kg) meeting at ``v0`` (m/s) through the unit with no slack, by DOP853
    on this file's own equations: state [x1, x2, v1, v2, s, dissipated]; returns the
    solution with the unit's force (N, + compression) on its time grid."""
    kh, ks, P, L = p["oil_stiffness"], p["spring_stiffness"], p["preload"], p["travel"]
    cl, cq = p["orifice_linear"], p["orifice_quadratic"]
    rate = (kh + ks) / cl

    def speed(force, s):
        if s <= 0.0 and force <= P:
            return -s * rate
        drive = force - P - ks * s
        u = np.sign(drive) * (-cl + np.sqrt(cl * cl + 4 * cq * abs(drive))) / (2 * cq)
        return max(u, -s * rate) if u < 0.0 else min(u, (L - s) * rate)

    def rhs(t, y):
        x1, x2, v1, v2, s, _ = y
        x = max(x1 - x2, 0.0)  # the coupling's closing (buff), m
        f = kh * max(x - s, 0.0)
        u = speed(f, s)
        return [v1, v2, -f / m1, f / m2, u, (f - P - ks * s) * u]

    sol = solve_ivp(rhs, (0.0, t_end), [0.0, 0.0, v0, 0.0, 0.0, 0.0], method="DOP853",
                    rtol=1e-10, atol=1e-12, max_step=2e-4, dense_output=True)
    x = np.maximum(sol.y[0] - sol.y[1], 0.0)
    force = kh * np.maximum(x - sol.y[4], 0.0)
    return sol, force


@pytest.mark.parametrize("v0", [1.5, 4.0])
def test_impact_agrees_with_another_solver_and_closes_its_energy(v0):
    p = unit()
    m = 9e4
    # no slack: the wagons start touching and part after the impact
    r = impact(CouplerParams(preset=PRESET, slack=0.0), v0, mass_moving=m,
               mass_standing=m, dt=2e-5, t_max=1.0)
    assert r["separated"]
    assert r["momentum_after"] == pytest.approx(r["momentum_before"], rel=1e-9)
    sol, force = _impact_reference(p, m, m, v0, 1.0)
    assert r["peak_force_N"] == pytest.approx(force.max(), rel=2e-3)
    assert r["max_deflection_m"] == pytest.approx(np.max(sol.y[0] - sol.y[1]), rel=2e-3)
    # the kinetic energy lost by the time the wagons part is the coupling's work, which
    # the reference splits into what the orifice dissipated and what the spring still
    # holds (P s + k_s s^2 / 2 at that instant; the oil column is unloaded then)
    lost = r["kinetic_energy_lost_J"]
    part = np.flatnonzero(force[1:] == 0.0)
    end = part[part > np.argmax(force)][0] + 1
    s = sol.y[4, end]
    held = p["preload"] * s + 0.5 * p["spring_stiffness"] * s * s
    assert lost == pytest.approx(sol.y[5, end] + held, rel=5e-3)
    assert r["energy_absorbed_J"] == pytest.approx(lost, rel=5e-3)
