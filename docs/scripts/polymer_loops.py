"""Render docs/figures/polymer_loops.png: force-deflection loops of the polymer-heavy-haul preset.

The gear's deflection is driven 0 -> travel -> 0 at a constant closing speed (three
speeds), its internal force integrated by the classical Runge-Kutta method with the
law of ltdsim.physics.gears.polymer; the static curves (speed 0) are drawn for reference.

    PYTHONPATH=src python docs/scripts/polymer_loops.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ltdsim.physics.gears.polymer import polymer_curves, polymer_gear
from ltdsim.viz.plotting import WIDTH, _save, plt
from ltdsim.data import load_preset

KEYS = ("preload", "initial_stiffness", "force_at_travel", "travel", "exponent",
        "return_ratio", "gain_loading", "gain_unloading", "rate_speed")
SPEEDS = (0.02, 0.5, 2.0)       # m/s, closing and opening speed of each loop
TRACKING_TIME = 4e-4            # s, the kernel's default (4 dt) at dt = 1e-4 s
STEPS = 4000                    # RK4 steps per leg
FIGURES = Path(__file__).resolve().parents[1] / "figures"   # docs/figures


def loop(p, speed):
    """Deflection (m) and force (N) of one loop 0 -> travel -> 0 at ``speed`` m/s."""
    q = tuple(p[k] for k in KEYS)
    extra = (p["k_locked"], 1.0 / TRACKING_TIME, p["solid_stiffness"])
    travel = p["travel"]
    h = travel / speed / STEPS
    f1 = p["preload"]  # released gear
    xs, fs = [0.0], [polymer_gear(f1, 0.0, speed, q, *extra)[0]]
    for v, x0 in ((speed, 0.0), (-speed, travel)):
        for k in range(STEPS):
            x = x0 + v * h * k

            def rate(f, xx, v=v):
                return polymer_gear(f, xx, v, q, *extra)[1]
            d1 = rate(f1, x)
            d2 = rate(f1 + 0.5 * h * d1, x + 0.5 * h * v)
            d3 = rate(f1 + 0.5 * h * d2, x + 0.5 * h * v)
            d4 = rate(f1 + h * d3, x + h * v)
            f1 += h / 6.0 * (d1 + 2 * d2 + 2 * d3 + d4)
            xs.append(x + h * v)
            fs.append(polymer_gear(f1, xs[-1], v, q, *extra)[0])
    return np.array(xs), np.array(fs)


def main(path=FIGURES / "polymer_loops.png"):
    p = {k: v for k, v in load_preset("gears", "polymer-heavy-haul").items() if k != "model"}
    q = tuple(p[k] for k in KEYS)
    fig, ax = plt.subplots(figsize=(0.62 * WIDTH, 4.6), constrained_layout=True)
    xq = np.linspace(0.0, p["travel"], 200)
    static = np.array([polymer_curves(x, 0.0, *q)[:2] for x in xq])
    ax.plot(1e3 * xq, 1e-6 * static[:, 0], "k--", lw=1.0, label="static loading / unloading")
    ax.plot(1e3 * xq, 1e-6 * static[:, 1], "k--", lw=1.0)
    for speed, colour in zip(SPEEDS, ("tab:blue", "tab:orange", "tab:red")):
        x, f = loop(p, speed)
        w = np.trapezoid(f, x)  # J: the loop's area, absorbed per closing and release
        ax.plot(1e3 * x, 1e-6 * f, color=colour, lw=1.6,
                label=f"{speed:g} m/s: absorbs {w / 1e3:.0f} kJ")
        print(f"{speed:5.2f} m/s: peak {f.max() / 1e6:.2f} MN, loop {w / 1e3:.1f} kJ")
    ax.set_xlabel("gear deflection (mm)")
    ax.set_ylabel("gear force (MN)")
    ax.set_title("Polymer gear (preset polymer-heavy-haul): loops 0 - 82.6 mm - 0\n"
                 "at constant closing and opening speed", loc="left")
    ax.set_xlim(0.0, 1e3 * p["travel"] * 1.02)
    ax.set_ylim(0.0, None)
    ax.legend(loc="upper left")
    return _save(fig, path)


if __name__ == "__main__":
    print(main())
