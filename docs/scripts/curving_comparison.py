"""Render docs/figures/curving_s_curve.png and print the tables of docs/curving.md: the
214-vehicle distributed-power train braking dynamically through the 300 m S curve
(scenarios/heavy-haul-s-curve.toml) with the remote locomotives synchronised (the base)
and still pushing (case remote-pushing); and ``ltdsim curve-limit`` for the pairs that
matter there.

    PYTHONPATH=src python docs/scripts/curving_comparison.py [--results DIR]

With ``--results DIR`` the runs are saved there as netCDF and read back on the next call
instead of run again.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import xarray as xr

import ltdsim
from ltdsim.results.safety import curve_limit
from ltdsim.results.io import save_result
from ltdsim.viz.plotting import WIDTH, _save, plt

ROOT = Path(__file__).resolve().parents[2]   # the repository
FIGURES = ROOT / "docs" / "figures"
SCENARIO = ROOT / "scenarios" / "heavy-haul-s-curve.toml"
CASES = {"remotes synchronised": None, "remotes pushing": "remote-pushing"}
GROUPS = [("wagons 3-107 (between the consists)", 2, 107),
          ("remote locomotives 108-109", 107, 109),
          ("wagons 110-214 (behind the remotes)", 109, 214)]


def run(label: str, case: str | None, results: Path | None) -> xr.Dataset:
    path = results / f"s-curve-{case or 'base'}.nc" if results else None
    if path is not None and path.is_file():
        return xr.load_dataset(path)
    print(f"running: {label} ...", flush=True)
    ds = ltdsim.simulate(ltdsim.load_scenario(SCENARIO, case=case))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        save_result(ds, path)
    return ds


def rows(label: str, ds: xr.Dataset) -> list[str]:
    lv = ds.wheel_l_over_v.values
    ratio = ds.wheelset_lateral_force.values / ds.prudhomme_limit.values[None, :]
    f = ds.coupler_force.values
    t = ds.time.values
    out = []
    for name, lo, hi in GROUPS:
        sl = lv[:, lo:hi]
        k, i = np.unravel_index(int(np.argmax(sl)), sl.shape)
        cl = f[:, max(lo - 1, 0):hi]
        out.append(f"| {label} | {name} | {sl.max():.3f} (vehicle {lo + i + 1}, {t[k]:.1f} s, "
                   f"{ds.position.values[k, lo + i]:.0f} m) | {ratio[:, lo:hi].max():.2f} | "
                   f"{-cl.min() / 1e3:.0f} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=None)
    args = ap.parse_args(argv)
    runs = {label: run(label, case, args.results) for label, case in CASES.items()}
    print("| run | vehicles | max wheel L/V (where, when, chainage) | max wheelset force / "
          "Prud'homme | max buff in their couplers [kN] |")
    print("|---|---|---|---|---|")
    for label, ds in runs.items():
        print("\n".join(rows(label, ds)))
    sc = ltdsim.load_scenario(SCENARIO)
    c = sc.curving
    print("\n| coupler (vehicles) | radius [m] | cant [mm] | speed [m/s] | L/V at no force | "
          "max steady buff, Nadal [kN] | max steady buff, Prud'homme [kN] |")
    print("|---|---|---|---|---|---|---|")
    for k in (60, 107):
        for speed in (10.8, 15.0):
            lim = curve_limit(sc.vehicles[k - 1], sc.vehicles[k], 300.0, 0.06, speed,
                              c.flange_angle, c.flange_friction, c.leading_share,
                              sc.track.rail_spacing, sc.track.gravity, c.prudhomme_alpha)
            print(f"| {k} ({sc.vehicles[k - 1].name} - {sc.vehicles[k].name}) | 300 | 60 | "
                  f"{speed:g} | {lim.l_over_v_at_zero:.3f} | {lim.buff_force / 1e3:.0f} | "
                  f"{lim.buff_force_prudhomme / 1e3:.0f} |")
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(WIDTH, 7.5), sharex=True)
    for (label, ds), colour in zip(runs.items(), ("tab:blue", "tab:red")):
        n = ds.sizes["vehicle"]
        veh = np.arange(1, n + 1)
        a1.plot(veh, ds.wheel_l_over_v.max("time"), color=colour, lw=1.0, label=label)
        a2.plot(np.arange(1, n) + 0.5, -ds.coupler_force.min("time") / 1e3, color=colour,
                lw=1.0, label=label)
    nadal = float(runs["remotes synchronised"].nadal_limit)
    a1.axhline(nadal, color="k", ls="--", lw=0.8, label=f"Nadal's limit {nadal:.2f}")
    a1.set_ylabel("max wheel L/V over the run [-]")
    a1.legend(loc="upper left")
    a1.set_title("the 214-vehicle DP train braking through the 300 m S curve")
    a2.set_ylabel("max buff force [kN]")
    a2.set_xlabel("vehicle (1 = lead); couplers between their vehicles")
    a2.legend(loc="upper left")
    for ax in (a1, a2):
        ax.axvspan(107.5, 109.5, color="0.85", lw=0)
    lo, hi = a2.get_ylim()
    a2.text(110.5, lo + 0.03 * (hi - lo), "remote locomotives", ha="left", va="bottom")
    fig.tight_layout()
    _save(fig, FIGURES / "curving_s_curve.png")
    print(f"figure written to {FIGURES / 'curving_s_curve.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
