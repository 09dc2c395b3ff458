"""Benchmark: couplings held at their slack edge (``solver.hold_speed``) on the heavy-haul
train with its shipped rigid end of the slack.

A friction gear's force steps from none to its released force (99 kN for the shipped
set) the instant the slack closes. Where a coupling is pressed against its edge by less
than that, the exact solution keeps it there, carrying the force that holds its two sides
together; a time-stepping solution touches and leaves the edge over and over, and the
coupling's force alternates between none and the preload. Its recorded peak is then the
preload, whatever it carries. This benchmark measures, on the two windows of
benchmarks/bench_peak_sensitivity.py (the 60 s emergency, 20 s of cruise at 18 m/s):

- the fixed-step reference (ode3 at 5e-5 s) and the envelope of four more runs with one
  wagon 0.1 mm/s faster each (bench_peak_sensitivity's ensemble; its runs are kept in
  the same folder);
- how many of the reference's peaks are the preload itself (within 0.1 %: a chattering
  coupling's), and over the last half of the window the share of the reference's steps
  at which such a coupling exerts no force (a chattering coupling's share in its slack);
- bs23 with and without ``hold_speed = 3e-3`` m/s, at the scenario's tolerances, ten
  times tighter, and with ``speed_atol = 1e-5`` m/s: its steps, its holds, its peaks
  beyond 1.05 times the preload (where the gear carries, so that the fixed step's peak
  is a peak) more than 2 % off the reference, and all its peaks more than 2 % outside the
  envelope (counted as bench_peak_sensitivity counts them).

The step counts are the measure of cost (CPU seconds are printed too, from this one
process; the machine is shared). Prints a table and writes it to
benchmarks/results/bench_held_edges.md and .json.

Usage: python benchmarks/bench_held_edges.py [--windows cruise emergency] [--hold 3e-3]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _results import publish
from bench_heavy_haul import ENDS, HEAVY, _released_forces, beyond_preload
from bench_peak_sensitivity import CACHE, WINDOWS, cached, envelope_width, outside

import ltdsim
from ltdsim._provenance import code_hash

HERE = Path(__file__).resolve().parent
#: the reference's step, s, and the ensemble (bench_peak_sensitivity's defaults)
DT = 5e-5
DELTA = 1e-4  # m/s
MEMBERS = 4
#: a peak within this share of the preload is the preload (a chattering coupling's)
AT_PRELOAD = 1e-3
#: bs23's runs: label and overrides (the scenario's tolerances are rtol 1e-3, atol 1e-4)
RUNS = (("scenario's tolerances", {}),
        ("rtol 1e-4, atol 1e-5", {"solver.rtol": 1e-4, "solver.atol": 1e-5}),
        ("speed_atol 1e-5 m/s", {"solver.speed_atol": 1e-5}))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", nargs="+", choices=tuple(WINDOWS), default=list(WINDOWS))
    ap.add_argument("--hold", type=float, default=3e-3,
                    help="solver.hold_speed of the held runs, m/s")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    if not 0.0 < args.hold <= 0.1:
        ap.error("--hold must lie within 0 and 0.1 m/s (solver.hold_speed's range)")
    base = ltdsim.load_scenario(HEAVY)
    n = base.n_vehicles
    members = [round((k + 0.5) * n / MEMBERS) for k in range(MEMBERS)]
    floor = _released_forces(base)
    print(f"{len(args.windows)} windows, {1 + MEMBERS} fixed-step runs and "
          f"{2 * len(RUNS)} bs23 runs each; estimate "
          f"{sum(WINDOWS[w][1]['solver.t_end'] for w in args.windows) / DT * (1 + MEMBERS) * n * 0.3e-6 / 60:.0f} min "
          "(the fixed-step runs, unless kept from before)", flush=True)
    short = base.with_overrides({"solver.t_end": 0.5})
    ltdsim.simulate(short)  # (compile or load both kernels before anything is timed)
    ltdsim.simulate(short.with_overrides({"solver.method": "ode3", "solver.dt": DT}))
    code = code_hash()
    t_start = time.perf_counter()
    rows, result = [], {"dt": DT, "delta_m_per_s": DELTA, "hold_speed": args.hold,
                        "members_vehicles": [m + 1 for m in members], "windows": {}}
    for window in args.windows:
        case, ov = WINDOWS[window]
        sc = ltdsim.load_scenario(HEAVY, case=case).with_overrides({**ov, **ENDS["rigid"]})
        t_end = float(sc.solver.t_end)

        def fixed_run(what, s, _w=window):
            got = cached(CACHE, code, s, lambda: ltdsim.simulate(s))
            print(f"  [{time.perf_counter() - t_start:6.0f} s] {_w}: {what} "
                  f"({got['cpu_s']:.0f} s CPU{', kept from before' if got['kept'] else ''})",
                  flush=True)
            return got["mx"], got["mn"]

        fixed = sc.with_overrides({"solver.method": "ode3", "solver.dt": DT})
        ref = fixed_run(f"ode3 {DT:g} s", fixed)
        ens = [ref]
        ov_member = {k: x for k, x in ov.items() if k != "initial.speed"}
        for m in members:
            v = np.full(n, sc.initial.speed)
            v[m] += DELTA
            member = ltdsim.load_scenario(HEAVY, case=case).with_overrides(
                {**ov_member, **ENDS["rigid"], "solver.method": "ode3", "solver.dt": DT,
                 "initial.velocities": v.tolist()})
            ens.append(fixed_run(f"vehicle {m + 1} +{DELTA:g} m/s", member))
        width = envelope_width(ens, ref, floor)
        at_preload = int((np.abs(ref[0] - floor) <= AT_PRELOAD * floor).sum()
                         + (np.abs(-ref[1] - floor) <= AT_PRELOAD * floor).sum())
        # the chatter itself, over the window's second half, from a fixed-step run that
        # records every step (of the couplings whose peaks are the preload)
        late = fixed.with_overrides({"solver.output_interval": DT,
                                     "solver.record": ["coupler_force"]})
        ds = ltdsim.simulate(late)
        f = ds.coupler_force.values[ds.time.values > 0.5 * t_end]
        chat = (np.abs(ref[0] - floor) <= AT_PRELOAD * floor)
        share0 = float((f[:, chat] == 0.0).mean()) if chat.any() else float("nan")
        del ds, f
        entry = {"envelope": width, "peaks_at_preload": at_preload,
                 "chattering_share_in_slack": share0, "bs23": {}}
        rows += [
            (f"{window}: ode3 {DT:g} s, peaks that are the preload (within "
             f"{AT_PRELOAD * 100:g} %)", f"{at_preload} of {2 * (n - 1)}; those couplings "
                                         f"exert no force at {share0 * 100:.0f} % of the "
                                         f"steps of the window's second half"),
            (f"{window}: envelope of {len(ens)} runs, widest tension / compression",
             f"{width['widest_tension'] * 100:.1f} % / {width['widest_compression'] * 100:.1f} %; "
             f"{width['wider']} peaks spread > 2 %"),
        ]
        for label, extra in RUNS:
            for hold in (None, args.hold):
                s = sc.with_overrides({**extra, **({"solver.hold_speed": hold} if hold else {})})
                c0 = time.process_time()
                ds = ltdsim.simulate(s)
                cpu = time.process_time() - c0
                run = (ds.max_coupler_force.values, ds.min_coupler_force.values)
                beyond = beyond_preload(run, ref, floor)
                out = outside(run, ens, ref, floor)
                key = f"{label}{', held' if hold else ''}"
                steps = (int(ds.attrs["steps"]), int(ds.attrs["rejected_steps"]))
                entry["bs23"][key] = {"steps": steps, "cpu_s": cpu,
                                      "holds": int(ds.attrs.get("edge_holds", 0)),
                                      "beyond_preload": beyond, "outside": out}
                print(f"  [{time.perf_counter() - t_start:6.0f} s] {window}: bs23 {key}: "
                      f"{steps[0]:,} + {steps[1]:,} steps", flush=True)
                held = f"hold_speed {hold:g} m/s, {entry['bs23'][key]['holds']:,} holds" \
                    if hold else "no hold"
                rows.append((
                    f"{window}: bs23 {label}, {held} ({steps[0]:,} + {steps[1]:,} steps, "
                    f"{cpu:.1f} s CPU)",
                    f"beyond the preload: {beyond['off']} of {beyond['peaks']} peaks > 2 % "
                    f"off the reference (worst {beyond['worst'] * 100:.1f} %); all peaks: "
                    f"{out['outside']} > 2 % outside the envelope"))
        result["windows"][window] = entry
    publish(args.out, "bench_held_edges",
            f"Couplings held at their slack edge, heavy-haul train, rigid end, {{stamp}}; "
            f"reference ode3 at {DT:g} s, ensemble members raise vehicle "
            + ", ".join(str(m + 1) for m in members) + f" by {DELTA * 1e3:g} mm/s",
            rows, result=result)
    return result


if __name__ == "__main__":
    main()
