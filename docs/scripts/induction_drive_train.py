"""The study's train with the induction drive against the traction-curve run: coupler
forces per phase (the table in docs/induction-drive-train.md) and the figure
docs/figures/induction_drive_train.png; and the heavy-haul wet start's figure
docs/figures/induction_wet_start.png; and the stiff drive (scenarios/paper-induction-stiff.toml)
against the curve: its table and docs/figures/induction_drive_stiff.png. Run:
PYTHONPATH=src python docs/scripts/induction_drive_train.py [study] [wet] [stiff] (none: all)"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import sys  # noqa: E402

import numpy as np  # noqa: E402

from ltdsim.scenario import load_scenario  # noqa: E402
from ltdsim.results.simulate import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]   # the repository
FIGURES = ROOT / "docs" / "figures"


def _rms(x):
    return float(np.sqrt(np.mean(x ** 2)))


def study_comparison():
    curve_s = load_scenario(ROOT / "scenarios/paper.toml")
    drive_s = load_scenario(ROOT / "scenarios/paper-induction.toml")
    runs = {"traction curve": simulate(curve_s), "induction drive": simulate(drive_s)}
    print("| phase | coupler | RMS force, curve, kN | RMS force, drive, kN | ratio | "
          "largest tension, curve / drive, kN |")
    print("|---|---|---|---|---|---|")
    for ph in curve_s.phases:
        for j in (0, 8):
            vals = []
            for ds in runs.values():
                sel = ds.sel(time=slice(ph.start, ph.end))
                f = sel.coupler_force.values[:, j]
                vals.append((_rms(f), f.max()))
            print(f"| {ph.name} ({ph.start:g}-{ph.end:g} s) | {j + 1} | {vals[0][0] / 1e3:.1f} | "
                  f"{vals[1][0] / 1e3:.1f} | {vals[1][0] / vals[0][0]:.2f} | "
                  f"{vals[0][1] / 1e3:.0f} / {vals[1][1] / 1e3:.0f} |")
    for name, ds in runs.items():
        print(f"{name}: speed error RMS {_rms(ds.speed_error.values):.3f} m/s, "
              f"largest coupler force {ds.max_coupler_force.values.max() / 1e3:.0f} kN, "
              f"time to 16 m/s {float(ds.time[np.argmax(ds.velocity.values[:, 0] > 16)]):.1f} s")
    ds = runs["induction drive"]
    e_dc = np.trapezoid(ds.dc_power.values[:, 0], ds.time.values) / 3.6e6
    print(f"drive: DC energy {e_dc:.1f} kWh over the run")

    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    for (name, d), col in zip(runs.items(), ("C0", "C3")):
        t = d.time.values
        ax[0].plot(t, d.velocity.values[:, 0], col, label=name)
        ax[1].plot(t, d.traction_force.values / 1e3, col, label=name)
        ax[2].plot(t, d.coupler_force.values[:, 0] / 1e3, col, lw=0.6, label=name)
    ax[0].plot(t, runs["traction curve"].speed_reference.values, "k:", lw=0.8,
               label="reference")
    t = ds.time.values
    ax[3].plot(t, ds.motor_torque.values[:, 0] / 1e3, "C3", label="motor torque, kN m")
    ax[3].plot(t, ds.stator_current.values[:, 0] / 100, "C2",
               label="stator current, 100 A rms")
    ax[3].plot(t, ds.creep.values[:, 0] * 100, "C1", label="creep, %")
    ax[0].set_ylabel("lead speed, m/s")
    ax[1].set_ylabel("traction force, kN")
    ax[2].set_ylabel("coupler 1 force, kN\n(+ tension)")
    ax[3].set_ylabel("drive (one motor)")
    ax[3].set_xlabel("time, s")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8, loc="upper right")
    ax[0].set_title("The study's train (case LHHL): traction curve against the induction drive, dry rail")
    fig.tight_layout()
    fig.savefig(FIGURES / "induction_drive_train.png", dpi=110)


def wet_start():
    ds = simulate(load_scenario(ROOT / "scenarios/heavy-haul-wet-start.toml"))
    t = ds.time.values
    fig, ax = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    ax[0].plot(t, ds.velocity.values[:, 0], "C0")
    ax[0].set_ylabel("lead speed, m/s")
    ax[1].plot(t, ds.locomotive_force.values[:, 0] / 1e3, "C3", label="lead (induction, wet)")
    ax[1].plot(t, ds.locomotive_force.values[:, 1] / 1e3, "C0", label="remote (curve)")
    ax[1].set_ylabel("consist force, kN")
    ax[2].plot(t, ds.creep.values[:, 0] * 100, "C1")
    ax[2].set_ylabel("lead creep, %")
    ax[3].plot(t, ds.motor_torque.values[:, 0] / 1e3, "C3", label="motor torque, kN m")
    ax[3].plot(t, ds.stator_current.values[:, 0] / 100, "C2", label="stator current, 100 A rms")
    ax[3].set_xlabel("time, s")
    for a in ax:
        a.grid(alpha=0.3)
    ax[1].legend(fontsize=8)
    ax[3].legend(fontsize=8)
    ax[0].set_title("Heavy-haul train: wet-rail start, lead consist on the induction drive")
    fig.tight_layout()
    fig.savefig(FIGURES / "induction_wet_start.png", dpi=110)
    sel = (t >= 10) & (t <= 60)
    print(f"wet start 10-60 s: lead consist force mean {ds.locomotive_force.values[sel, 0].mean() / 1e3:.0f} kN, "
          f"per axle {ds.locomotive_force.values[sel, 0].mean() / 12e3:.1f} kN; creep "
          f"{ds.creep.values[sel, 0].min() * 100:.1f}-{ds.creep.values[sel, 0].max() * 100:.1f} %; "
          f"motor torque mean {ds.motor_torque.values[sel, 0].mean():.0f} N m; "
          f"demand per consist {ds.traction_demand.values[-1] / 2e3:.0f} kN; "
          f"speed at 60 s {ds.velocity.values[-1, 0]:.2f} m/s; steps {ds.attrs['steps']} "
          f"({ds.attrs['rejected_steps']} rejected)")


def stiff_comparison():
    curve_s = load_scenario(ROOT / "scenarios/paper.toml")
    stiff_s = load_scenario(ROOT / "scenarios/paper-induction-stiff.toml")
    runs = {"traction curve": simulate(curve_s), "stiff induction drive": simulate(stiff_s)}
    cu, dr = runs.values()
    print("| phase | coupler | RMS force, curve, kN | RMS force, stiff drive, kN | "
          "stiff drive / curve | largest tension, curve / stiff drive, kN |")
    print("|---|---|---|---|---|---|")
    worst = {}
    for ph in curve_s.phases:
        a = cu.sel(time=slice(ph.start, ph.end)).coupler_force.values
        b = dr.sel(time=slice(ph.start, ph.end)).coupler_force.values
        ratios = [_rms(b[:, j]) / _rms(a[:, j]) for j in range(a.shape[1])]
        worst[ph.name] = (min(ratios), max(ratios))
        for j in (0, 8):
            print(f"| {ph.name} ({ph.start:g}-{ph.end:g} s) | {j + 1} | {_rms(a[:, j]) / 1e3:.1f} | "
                  f"{_rms(b[:, j]) / 1e3:.1f} | {ratios[j]:.3f} | "
                  f"{a[:, j].max() / 1e3:.0f} / {b[:, j].max() / 1e3:.0f} |")
    for name, (lo, hi) in worst.items():
        print(f"{name}: ratio over couplers 1-9 from {lo:.3f} to {hi:.3f}")
    for name, ds in runs.items():
        print(f"{name}: speed error RMS {_rms(ds.speed_error.values):.3f} m/s, "
              f"largest coupler force {np.abs(ds.coupler_force.values).max() / 1e3:.0f} kN, "
              f"largest traction force {ds.traction_force.values.max() / 1e3:.0f} kN")
    print(f"stiff drive: largest creep {np.nanmax(dr.creep.values[:, 0]) * 100:.2f} %, "
          f"largest stator current {np.nanmax(dr.stator_current.values[:, 0]):.0f} A rms, "
          f"largest |traction force difference| "
          f"{np.abs(dr.traction_force.values - cu.traction_force.values).max() / 1e3:.0f} kN")

    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    for (name, d), col in zip(runs.items(), ("C0", "C3")):
        t = d.time.values
        ax[0].plot(t, d.velocity.values[:, 0], col, label=name)
        ax[1].plot(t, d.traction_force.values / 1e3, col, lw=0.8, label=name)
        ax[2].plot(t, d.coupler_force.values[:, 0] / 1e3, col, lw=0.6, label=name)
    t = cu.time.values
    ax[3].plot(t, (dr.coupler_force.values[:, 0] - cu.coupler_force.values[:, 0]) / 1e3,
               "C3", lw=0.6, label="coupler 1")
    ax[3].plot(t, (dr.coupler_force.values[:, 8] - cu.coupler_force.values[:, 8]) / 1e3,
               "C2", lw=0.6, label="coupler 9")
    for ph in curve_s.phases:
        for a in ax:
            a.axvspan(ph.start, ph.end, color="0.9", zorder=0)
    ax[0].set_ylabel("lead speed, m/s")
    ax[1].set_ylabel("traction force, kN")
    ax[2].set_ylabel("coupler 1 force, kN\n(+ tension)")
    ax[3].set_ylabel("coupler force,\nstiff drive - curve, kN")
    ax[3].set_xlabel("time, s (grey: the study's four phases)")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8, loc="upper right")
    ax[0].set_title("The study's train (case LHHL): traction curve against a stiff induction "
                    "drive, dry rail", fontsize=10)
    fig.tight_layout()
    fig.savefig(FIGURES / "induction_drive_stiff.png", dpi=110)


if __name__ == "__main__":
    todo = sys.argv[1:] or ["study", "wet", "stiff"]
    if "study" in todo:
        study_comparison()
    if "wet" in todo:
        wet_start()
    if "stiff" in todo:
        stiff_comparison()
