"""Render docs/figures/fluid_brake_comparison.png and print the table of
docs/fluid-brake-comparison.md: the heavy-haul train's emergency stop from 18 m/s with
the lumped brake (scenarios/heavy-haul.toml, case emergency) and with the fluid brake
(scenarios/heavy-haul-fluid.toml, cases emergency-remote and emergency-lead), with the
remote consist venting and from the lead alone; a lumped run given the fluid brake's
emergency cylinder force, and the lumped twins of the fluid runs with the
constants calibrated on the fluid brake (``brake.calibration = "aar"``), which say where
the differences come from. Every run 90 s, recorded every 0.05 s.

    PYTHONPATH=src python docs/scripts/fluid_brake_comparison.py [--results DIR]

With ``--results DIR`` the runs are saved there as netCDF and read back on the next call
instead of run again.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import xarray as xr

import ltdsim
from ltdsim.analysis.calibration import lumped_twin
from ltdsim.results.io import save_result
from ltdsim.viz.plotting import WIDTH, _save, plt
from ltdsim.results.summary import fluid_brake_summary, stopping

ROOT = Path(__file__).resolve().parents[2]   # the repository
FIGURES = ROOT / "docs" / "figures"
SCEN = ROOT / "scenarios"
COMMON = {"solver.t_end": 90.0, "solver.output_interval": 0.05}


def lumped_case(remote: bool, force_scale: float = 1.0, tau: float | None = None):
    """The lumped heavy-haul emergency, vented from both consists or from the lead alone;
    optionally every wagon's cylinder force scaled and another fill time constant, s."""
    sc = ltdsim.load_scenario(SCEN / "heavy-haul.toml", case="emergency")
    ov = dict(COMMON, **{"locomotives.1.brake_control": remote})
    if tau is not None:
        ov["brake.apply_time_constant"] = tau
    if force_scale != 1.0:
        for i, v in enumerate(sc.vehicles):
            if v.brake is not None:
                # (the keys given: the defaults of fluid-brake keys would be refused)
                b = v.brake.model_dump(exclude_none=True, exclude_defaults=True)
                b["cylinder_force"] *= force_scale
                ov[f"vehicles.{i}.brake"] = b
    return sc.with_overrides(ov)


def fluid_case(case: str):
    return ltdsim.load_scenario(SCEN / "heavy-haul-fluid.toml", case=case).with_overrides(COMMON)


def rear_fill_95(ds) -> float:
    """Lumped run: time from the command (the first rise of brake_command) until the rear
    braked vehicle's cylinder fill first reaches 95 % of its final value, s."""
    t = ds.time.values
    cmd = ds.brake_command.values
    t_cmd = t[int(np.argmax(cmd > 0.0))]
    fill = ds.brake_cylinder.values
    rear = int(np.flatnonzero(np.isfinite(fill[-1]) & (fill[-1] > 0.0))[-1])
    k = int(np.argmax(fill[:, rear] >= 0.95 * fill[-1, rear]))
    return float(t[k] - t_cmd)


def facts(ds) -> dict:
    mx, mn = ds.max_coupler_force.values, ds.min_coupler_force.values
    jt, jc = int(np.argmax(mx)), int(np.argmin(mn))
    stop = stopping(ds)
    out = {"tension_kN": mx[jt] / 1e3, "tension_coupler": jt + 1,
           "tension_t": float(ds.time_max_coupler_force[jt]),
           "compression_kN": -mn[jc] / 1e3, "compression_coupler": jc + 1,
           "compression_t": float(ds.time_min_coupler_force[jc]),
           "stop_m": stop["stopping_distance_m"] if stop else math.nan,
           "stop_s": stop["stopping_time_s"] if stop else math.nan}
    b = fluid_brake_summary(ds)
    if b is not None:
        out["rear_95_s"] = b["last_cylinder_95_s"]
        out["propagation"] = b["end_to_end_speed_m_s"]
        out["vent_front"] = b["vent_front_speed_m_s"]
        out["vent_s"] = b["vent_time_s"]
        out["rear_arrival_s"] = b["arrival_s"][-1]
        out["rear_bar"] = b["last_cylinder_final_Pa"] / 1e5
    else:
        out["rear_95_s"] = rear_fill_95(ds)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=None)
    args = ap.parse_args(argv)
    runs = {
        "lumped, remote venting": lambda: lumped_case(True),
        "fluid (AAR), remote venting": lambda: fluid_case("emergency-remote"),
        "lumped, lead only": lambda: lumped_case(False),
        "fluid (AAR), lead only": lambda: fluid_case("emergency-lead"),
        "lumped x1.21 force, lead only": lambda: lumped_case(False, 1.207),
        "lumped calibrated (aar), remote venting": lambda: lumped_twin(
            fluid_case("emergency-remote")),
        "lumped calibrated (aar), lead only": lambda: lumped_twin(fluid_case("emergency-lead")),
    }
    results = {}
    for label, make in runs.items():
        path = (args.results / (label.replace(" ", "_").replace(",", "") + ".nc")
                if args.results else None)
        if path is not None and path.exists():
            results[label] = xr.load_dataset(path)
        else:
            print(f"running {label}", flush=True)
            results[label] = ltdsim.simulate(make())
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                save_result(results[label], path)
    print("| run | largest tension, kN (coupler, s) | largest compression, kN (coupler, s) "
          "| stopping distance, m (time, s) | rear cylinder at 95 %, s after the command |")
    print("|---|---|---|---|---|")
    for label, ds in results.items():
        f = facts(ds)
        print(f"| {label} | {f['tension_kN']:.0f} ({f['tension_coupler']}, "
              f"{f['tension_t']:.1f}) | {f['compression_kN']:.0f} ({f['compression_coupler']}, "
              f"{f['compression_t']:.1f}) | {f['stop_m']:.0f} ({f['stop_s']:.1f}) | "
              f"{f['rear_95_s']:.1f} |")
        if "propagation" in f:
            print(f"|   (fluid: propagation {f['propagation']:.0f} m/s end to end, 0.3 bar drop "
                  f"at the rear {f['rear_arrival_s']:.2f} s; vent front {f['vent_front']:.0f} m/s, "
                  f"rear below 1 bar {f['vent_s']:.2f} s; rear cylinder {f['rear_bar']:.2f} bar) "
                  "|||||")

    fig, axes = plt.subplots(2, 2, figsize=(WIDTH, 8.5), constrained_layout=True)
    pairs = (("remote venting", "lumped, remote venting", "fluid (AAR), remote venting"),
             ("lead only", "lumped, lead only", "fluid (AAR), lead only"))
    for ax, (what, lum, flu) in zip(axes[0], pairs):
        for label, colour in ((lum, "tab:blue"), (flu, "tab:red")):
            ds = results[label]
            j = ds.coupler.values + 1
            ax.plot(j, ds.max_coupler_force.values / 1e3, color=colour, lw=1.0,
                    label=f"{label.split(',')[0]}: tension")
            ax.plot(j, ds.min_coupler_force.values / 1e3, color=colour, lw=1.0, ls="--",
                    label=f"{label.split(',')[0]}: compression")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel("coupler (1 = behind the lead)")
        ax.set_ylabel("largest force over the stop [kN]\n(+ tension, - compression)")
        ax.set_title(f"emergency, {what}: peak coupler forces along the train")
        ax.legend(loc="best", fontsize=8.5)
    ax = axes[1, 0]
    for label, colour in (("lumped, remote venting", "tab:blue"),
                          ("fluid (AAR), remote venting", "tab:red")):
        ds = results[label]
        t = ds.time.values
        for i, ls in ((2, "-"), (109, "--"), (213, ":")):
            ax.plot(t, ds.brake_force.values[:, i] / 1e3, color=colour, ls=ls, lw=1.0,
                    label=f"{label.split(',')[0]}, vehicle {i + 1}")
    ax.set_xlim(0.0, 25.0)
    ax.set_ylim(0.0, 1.45 * ax.get_ylim()[1])  # room for the legend above the curves
    ax.set_xlabel("time [s] (emergency at 2 s)")
    ax.set_ylabel("brake force of one wagon [kN]")
    ax.set_title("wagon brake force, remote venting: front, behind the remote, rear\n"
                 "(vehicles 3 and 110 coincide: both consists vent at once)")
    ax.legend(loc="upper left", fontsize=8.5, ncol=2)
    ax = axes[1, 1]
    for label, ds in results.items():
        ax.plot(ds.time.values, ds.velocity.values[:, 0], lw=1.0, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("lead speed [m/s]")
    ax.set_title("lead vehicle's speed")
    ax.legend(loc="upper right", fontsize=8.0)
    fig.suptitle("heavy-haul train (214 vehicles), emergency from 18 m/s: lumped against "
                 "fluid brake")
    _save(fig, FIGURES / "fluid_brake_comparison.png")
    print(f"figure written to {FIGURES / 'fluid_brake_comparison.png'}")


if __name__ == "__main__":
    main()
