"""Render docs/figures/cushion_impacts.png: two 90 t cars meeting through one end-of-car
cushioning unit (preset eoc-15) at 4, 8 and 14 mph, run by the train kernel
(ltdsim.analysis.gears.impact, no slack): the unit's force against its deflection and
against time, with the piston's stroke.

    PYTHONPATH=src python docs/scripts/cushion_impacts.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ltdsim.analysis.gears import impact
from ltdsim.scenario import CouplerParams
from ltdsim.viz.plotting import WIDTH, _save, plt

MPH = 0.44704                   # m/s per mph
SPEEDS_MPH = (4.0, 8.0, 14.0)   # closing speeds of the impacts
MASS = 9.0e4                    # kg, each car
FIGURES = Path(__file__).resolve().parents[1] / "figures"   # docs/figures


def main(path=FIGURES / "cushion_impacts.png"):
    params = CouplerParams(preset="eoc-15", slack=0.0)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(WIDTH, 4.4), constrained_layout=True)
    for mph, colour in zip(SPEEDS_MPH, ("tab:blue", "tab:orange", "tab:red")):
        v = mph * MPH
        r = impact(params, v, mass_moving=MASS, mass_standing=MASS, dt=2e-5, t_max=1.0)
        ds = r["dataset"]
        t = ds.time.values
        f = -ds.coupler_force.isel(coupler=0).values  # + compression (buff)
        x = -ds.coupler_deflection.isel(coupler=0).values
        ke = 0.25 * MASS * v * v
        label = (f"{mph:g} mph ({v:.2f} m/s): peak {f.max() / 1e6:.2f} MN, "
                 f"{1e3 * x.max():.0f} mm")
        ax1.plot(1e3 * x, 1e-6 * f, color=colour, lw=1.6, label=label)
        ax2.plot(1e3 * t, 1e-6 * f, color=colour, lw=1.6)
        print(f"{mph:4.0f} mph ({v:.2f} m/s): peak {f.max() / 1e6:.2f} MN at "
              f"{1e3 * t[np.argmax(f)]:.0f} ms, deflection {1e3 * x.max():.0f} mm, "
              f"kinetic energy lost {r['kinetic_energy_lost_J'] / 1e3:.0f} kJ of "
              f"{ke / 1e3:.0f} kJ relative")
    ax1.set_xlabel("unit deflection (mm, buff)")
    ax1.set_ylabel("force on the unit (MN, buff)")
    ax1.set_title("Force against deflection", loc="left")
    ax1.set_xlim(0.0, 400.0)
    ax1.set_ylim(0.0, None)
    ax1.axvline(381.0, color="0.5", lw=0.8, ls=":")
    ax1.text(378.0, 0.2, "stroke 381 mm", rotation=90, ha="right", va="bottom",
             color="0.4", fontsize=8)
    ax1.legend(loc="upper left", fontsize=8)
    ax2.set_xlabel("time from contact (ms)")
    ax2.set_ylabel("force on the unit (MN, buff)")
    ax2.set_title("Force against time", loc="left")
    ax2.set_ylim(0.0, None)
    fig.suptitle("End-of-car cushioning unit (preset eoc-15): two 90 t cars meeting",
                 x=0.01, ha="left")
    return _save(fig, path)


if __name__ == "__main__":
    print(main())
