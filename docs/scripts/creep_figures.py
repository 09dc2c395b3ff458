"""Figures of docs/creep.md: Polach's creep-force curves of the three rail presets, and a
wet-rail start of one driven wheelset with and without slip control.

Run: ``python docs/scripts/creep_figures.py`` (writes docs/figures/creep_curves.png and
docs/figures/creep_start.png and prints the numbers the text quotes). The wheelset is the
study's locomotive's (66.63 t static mass on 6 driven axles, ``ltdsim.scenario.creep.Wheelset``
defaults, motor rotor 15 kg m^2); it pulls the study's whole train (884 t dynamic mass)
divided by 6 axles.
Integrated by scipy's LSODA, the same rig as tests/physics/test_creep.py.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

from ltdsim.scenario.creep import RailCondition, SlipControl, Wheelset, rail_row, slip_row
from ltdsim.scenario.creep import wheelset_row as ws_row_of
from ltdsim.physics.drive import creep as cr

ROOT = Path(__file__).resolve().parents[2]   # the repository
FIGURES = ROOT / "docs" / "figures"
STATIC_MASS = 66630.0        # kg, the study's locomotive
MOTOR_INERTIA = 15.0         # kg m^2, rotor (placeholder until the motor preset sets it)
M_AXLE = 884050.0 / 6        # kg, the study's train per driven axle
WS = ws_row_of(Wheelset(), STATIC_MASS, gravity=9.81, motor_inertia=MOTOR_INERTIA)
Q, R = WS[cr.WS_Q], WS[cr.WS_R]
NAMES = ("dry", "wet", "low-adhesion")
RAILS = {n: rail_row(RailCondition(preset=n)) for n in NAMES}
SPEEDS = (1.0, 10.0, 20.0, 30.0)   # m/s


def adhesion(rail, v, s):
    """Creep force of the wheelset over its load 2Q at creep s and speed v, -."""
    w = s * max(v, WS[cr.WS_VREG])
    return np.array([cr.creep_force((v + x) / R, v, WS, rail) for x in w]) / (2 * Q)


def peak(rail, v):
    s = np.geomspace(1e-5, 2.0, 6000)
    mu = adhesion(rail, v, s)
    i = int(np.argmax(mu))
    return mu[i], s[i]


def curves():
    s = np.geomspace(1e-4, 1.0, 800)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True)
    print("peak adhesion coefficient (creep at the peak) per preset and speed:")
    for ax, name in zip(axes, NAMES):
        rail = RAILS[name]
        for v in SPEEDS:
            mu = adhesion(rail, v, s)
            (line,) = ax.semilogx(100 * s, mu, label=f"{v:.0f} m/s ({3.6 * v:.0f} km/h)")
            mp, sp = peak(rail, v)
            ax.plot(100 * sp, mp, "o", color=line.get_color(), ms=4)
            print(f"  {name:13s} {v:5.1f} m/s: {mp:.4f} at {100 * sp:.2f} %")
        ax.set_title(f"{name}: mu0 {rail[0]:.2f}, A {rail[1]:.2f}, B {rail[2]:.2f} s/m, "
                     f"kA {rail[3]:.2f}, kS {rail[4]:.2f}", fontsize=9)
        ax.set_xlabel("creep (omega r - v) / v, %")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("creep force / wheel load, -")
    axes[0].legend(title="speed (dot: peak)", fontsize=8)
    fig.suptitle("Polach creep-force curves, wheelset of the study's locomotive "
                 f"(wheel load {Q / 1e3:.1f} kN, f11 {WS[cr.WS_F11] / 1e6:.2f} MN)")
    fig.tight_layout()
    fig.savefig(FIGURES / "creep_curves.png", dpi=110)


def start(control):
    rail = RAILS["wet"]
    demand = 1.3 * 2 * Q * peak(rail, 0.0)[0] * R
    sp = slip_row(SlipControl(), WS, demand)

    def rhs(t, y):
        om, v, lim = y
        tw, dl = cr.slip_control(lim, demand, om, v, R, sp) if control else (demand, 0.0)
        dom, f = cr.wheelset_rate(om, v, tw, WS, rail)
        return [dom, f / M_AXLE, dl]

    sol = solve_ivp(rhs, (0.0, 20.0), [0.0, 0.0, demand], method="LSODA", rtol=1e-7,
                    atol=[1e-7, 1e-7, 1e-3], max_step=0.01)
    om, v, lim = sol.y
    tw = np.array([cr.slip_control(a, demand, b, c, R, sp)[0] if control else demand
                   for a, b, c in zip(lim, om, v)])
    f = np.array([cr.creep_force(a, b, WS, rail) for a, b in zip(om, v)])
    return sol.t, om * R - v, v, tw, f, demand


def starts():
    fig, axes = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    rail = RAILS["wet"]
    for control, style in ((False, "C3"), (True, "C0")):
        t, w, v, tw, f, demand = start(control)
        lab = "with slip control" if control else "without slip control"
        axes[0, 0].plot(t, w, style, label=lab)
        axes[0, 1].plot(t, f / 1e3, style, label=lab)
        axes[1, 0].plot(t, v, style, label=lab)
        axes[1, 1].plot(t, tw / 1e3, style, label=lab)
        late = t > 2.0
        pk = np.array([2 * Q * peak(rail, x)[0] for x in v])
        mean_ratio = np.trapezoid(f[late] / pk[late], t[late]) / (t[late][-1] - t[late][0])
        print(f"wet start {lab}: speed at 20 s {v[-1]:.2f} m/s, slip velocity "
              f"{w[-1]:.3g} m/s, mean force / peak over 2-20 s {mean_ratio:.3f}")
    pk_t = np.linspace(0, 20, 5)
    tt, _, vv, _, _, demand = start(True)
    axes[0, 1].plot(tt, [2 * Q * peak(rail, x)[0] / 1e3 for x in vv], "k--", lw=1,
                    label="curve's peak at the speed (controlled run)")
    axes[1, 1].axhline(demand / 1e3, color="k", ls=":", lw=1, label="demand (1.3 x peak)")
    sc = SlipControl()
    axes[0, 0].plot(tt, sc.w_set + sc.w_slope * vv, "k--", lw=1, label="set value w_ref")
    axes[0, 0].set_yscale("symlog", linthresh=1.0)
    axes[0, 0].set_ylabel("slip velocity omega r - v, m/s")
    axes[0, 1].set_ylabel("creep force on the vehicle, kN")
    axes[1, 0].set_ylabel("vehicle speed, m/s")
    axes[1, 1].set_ylabel("wheel torque, kN m")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("time, s")
    fig.suptitle("Wet rail, one driven wheelset from rest under a constant torque demand "
                 "of 1.3 x the adhesion peak (train share 147 t)")
    fig.tight_layout()
    fig.savefig(FIGURES / "creep_start.png", dpi=110)
    del pk_t


def setpoint_fit():
    """The slip controller's set value: a straight line fitted to the slip velocity at
    the wet curve's peak over 0-30 m/s, and the force it holds against the peak."""
    rail = RAILS["wet"]
    vs = np.linspace(0.0, 30.0, 31)
    wpk = np.array([peak(rail, v)[1] * max(v, WS[cr.WS_VREG]) for v in vs])
    slope, w0 = np.polyfit(vs, wpk, 1)
    sc = SlipControl()
    ratio = [cr.creep_force((v + sc.w_set + sc.w_slope * v) / R, v, WS, rail)
             / (2 * Q * peak(rail, v)[0]) for v in vs]
    print(f"set value fit: w_set {w0:.3f} m/s, w_slope {slope:.4f}; with the defaults "
          f"({sc.w_set}, {sc.w_slope}) the held force is {min(ratio):.4f}-{max(ratio):.4f} "
          "of the peak over 0-30 m/s")
    for name in ("dry", "low-adhesion"):
        r2 = [cr.creep_force((v + sc.w_set + sc.w_slope * v) / R, v, WS, RAILS[name])
              / (2 * Q * peak(RAILS[name], v)[0]) for v in vs]
        print(f"  the same set value on {name}: {min(r2):.4f}-{max(r2):.4f} of the peak")


def regularisation():
    """The wheelset's fastest slip mode on the rising branch at v_reg: rate
    (kA + kS)/2 x 2 f11 r^2 / (J v_reg), 1/s, and ode3's step limit 2.51 / rate."""
    for name in NAMES:
        rail = RAILS[name]
        rate = (rail[3] + rail[4]) / 2 * 2 * WS[cr.WS_F11] * R**2 / (WS[cr.WS_J] * WS[cr.WS_VREG])
        print(f"slip mode at v_reg {WS[cr.WS_VREG]} m/s, {name}: {rate:.0f} 1/s, ode3 stable "
              f"below a step of {2.51 / rate * 1e3:.3f} ms")


if __name__ == "__main__":
    print(f"wheel load {Q:.0f} N, f11 {WS[cr.WS_F11]:.4g} N, inertia at the wheelset "
          f"{WS[cr.WS_J]:.1f} kg m^2, v_reg {WS[cr.WS_VREG]} m/s")
    regularisation()
    setpoint_fit()
    curves()
    starts()
    sys.exit(0)
