"""Rig: one traction motor of the study under indirect field-oriented control, started from
standstill to beyond its maximum speed at full torque demand.

The shaft carries a fixed inertia that stands for the train's share of one motor (no
wheelset, no creep: those are the wheelset's rig). Integrated with scipy's solve_ivp
(Radau). Writes docs/figures/induction_drive_start.png (torque, power, current, flux, voltage
against shaft speed) and prints the numbers of the rated points.

    PYTHONPATH=src python docs/scripts/induction_drive_start.py [--inertia 1000] [--out PATH]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from ltdsim.scenario.motor import load_motor
from ltdsim.physics.drive import foc
from ltdsim.physics.drive.induction import motor_row

RPM = math.pi / 30.0
FIGURES = Path(__file__).resolve().parents[1] / "figures"   # docs/figures


def run(preset: str, inertia: float, t_end: float, demand: float):
    motor = load_motor(preset)
    m = motor_row(motor)
    c = foc.controller_row(motor)
    n = foc.N_DRIVE
    dy = np.zeros(n)
    out = np.zeros(foc.N_OUT)
    last = [time.monotonic()]

    def f(t, x):
        te = foc.drive_rates(x[:n], x[n], demand, motor.dc_link_voltage, m, c, dy, out)
        if time.monotonic() - last[0] > 2.0:
            last[0] = time.monotonic()
            print(f"  t = {t:5.1f} s of {t_end:.0f} s, {x[n] / RPM:6.0f} rpm", flush=True)
        return np.concatenate((dy, [te / inertia]))

    t_eval = np.linspace(0.0, t_end, 1201)
    sol = solve_ivp(f, (0.0, t_end), np.concatenate((foc.drive_init(m, c), [0.0])),
                    method="Radau", t_eval=t_eval, rtol=1e-7, atol=1e-6)
    if not sol.success:
        sys.exit(f"rig: the integration failed: {sol.message}")
    outs = np.empty((t_eval.size, foc.N_OUT))
    for k in range(t_eval.size):
        foc.drive_rates(sol.y[:n, k], sol.y[n, k], demand, motor.dc_link_voltage, m, c,
                        dy, out)
        outs[k] = out
    return motor, c, sol, outs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="study-850kw")
    ap.add_argument("--inertia", type=float, default=1000.0, help="shaft inertia, kg m^2")
    ap.add_argument("--t-end", type=float, default=70.0, help="duration, s")
    ap.add_argument("--out", type=Path,
                    default=FIGURES / "induction_drive_start.png")
    a = ap.parse_args(argv)
    if a.inertia <= 0.0 or a.t_end <= 0.0:
        sys.exit("rig: --inertia and --t-end must be > 0")
    if not a.out.parent.is_dir():
        sys.exit(f"rig: --out: folder {a.out.parent} does not exist")
    print(f"rig: {a.preset}, shaft inertia {a.inertia:g} kg m^2, {a.t_end:g} s", flush=True)
    motor, _, sol, o = run(a.preset, a.inertia, a.t_end, 1e6)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n_rpm = sol.y[foc.N_DRIVE] / RPM
    wm = sol.y[foc.N_DRIVE]
    delta = math.sqrt(3.0) if motor.connection == "delta" else 1.0
    i_w = np.hypot(o[:, foc.O_ID], o[:, foc.O_IQ]) / math.sqrt(2.0) / delta
    v = np.hypot(o[:, foc.O_VD], o[:, foc.O_VQ])
    vmax = motor.dc_link_voltage / math.sqrt(3.0)
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    a0, a1, a2, a3 = ax.ravel()
    a0.plot(n_rpm, o[:, foc.O_T] / 1e3, label="torque")
    a0.plot(n_rpm, o[:, foc.O_TREF] / 1e3, "--", label="limited demand")
    a0.set_ylabel("torque (kN m)")
    a0b = a0.twinx()
    a0b.plot(n_rpm, o[:, foc.O_T] * wm / 1e3, color="C2", label="shaft power")
    a0b.plot(n_rpm, o[:, foc.O_PDC] / 1e3, ":", color="C3", label="DC power")
    a0b.set_ylabel("power (kW)")
    a0b.set_ylim(0, 1000)
    h0, l0 = a0.get_legend_handles_labels()
    h1, l1 = a0b.get_legend_handles_labels()
    a0.legend(h0 + h1, l0 + l1, loc="center right", fontsize=8)
    a0.set_title("torque and power")
    a1.plot(n_rpm, i_w, label="winding current")
    a1.axhline(motor.rated_current, color="k", lw=0.8, ls="--", label="rated 270 A")
    a1.axhline(motor.max_current, color="r", lw=0.8, ls="--", label="limit 310 A")
    a1.set_ylabel("stator winding current (A rms)")
    a1.set_ylim(0, 350)
    a1.legend(fontsize=8, loc="lower left")
    a1.set_title("current")
    a2.plot(n_rpm, o[:, foc.O_PSIR], label="rotor flux (machine)")
    a2.plot(n_rpm, o[:, foc.O_PSIREF], "--", label="reference")
    a2.set_ylabel("rotor flux (Wb peak)")
    a2.set_ylim(0, 4.5)
    a2.legend(fontsize=8, loc="lower left")
    a2.set_title("flux: rated, then field weakening")
    a3.plot(n_rpm, v, label="applied voltage")
    a3.axhline(vmax, color="r", lw=0.8, ls="--", label="limit V_dc/sqrt(3)")
    a3.axhline(motor.voltage_margin * vmax, color="k", lw=0.8, ls=":",
               label=f"planned {motor.voltage_margin:.0%}")
    a3.set_ylabel("phase voltage (V peak)")
    a3.set_ylim(0, 1400)
    a3.legend(fontsize=8, loc="lower right")
    a3.set_title("voltage")
    for x in ax.ravel():
        x.axvline(motor.base_speed, color="grey", lw=0.6)
        x.axvline(motor.max_speed, color="grey", lw=0.6)
        x.grid(alpha=0.3)
    for x in (a2, a3):
        x.set_xlabel("shaft speed (rpm); grey lines: base 1283, maximum 2484")
    fig.suptitle(f"Start of one {motor.rated_power / 1e3:.0f} kW motor ({a.preset}), "
                 f"full demand, shaft inertia {a.inertia:g} kg m^2, {a.t_end:g} s",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(f"wrote {a.out}")
    for target in (motor.base_speed, motor.max_speed):
        k = int(np.searchsorted(n_rpm, target))
        if k < n_rpm.size:
            print(f"at {n_rpm[k]:6.0f} rpm (t = {sol.t[k]:5.1f} s): torque "
                  f"{o[k, foc.O_T]:6.0f} N m, shaft power {o[k, foc.O_T] * wm[k] / 1e3:5.0f} kW, "
                  f"DC power {o[k, foc.O_PDC] / 1e3:5.0f} kW, current {i_w[k]:5.1f} A rms "
                  f"(winding), flux {o[k, foc.O_PSIR]:.3f} Wb, voltage {v[k]:6.0f} V peak")


if __name__ == "__main__":
    main()
