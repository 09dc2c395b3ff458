"""Accuracy check: bs23 against the fixed step where couplers chatter at their slack edges.

Runs the heavy-haul train (scenarios/heavy-haul.toml) cruising at 18 m/s for ``--t-end``
seconds from couplers stretched at the start (the couplers between the consists then
drift in and out of their slack, each touch on the gear's preload lasting about one
bs23 step), under fixed-step ode3 at 1e-4 s (the reference) and 5e-5 s (how far the
fixed step itself is converged), and under bs23 at the scenario's tolerances, at
tolerances ten times tighter, and with its step capped at 1 ms and at 0.1 ms. For each
run: the steps, the couplers' peak tensions and compressions averaged over the train
(% against the reference), the train's largest tension (%), and the largest difference
of a single coupler's peak (kN). Prints the table and writes
benchmarks/results/check_slack_chatter.md and .json (docs/heavy-haul.md, "Where bs23 and
the fixed step part").

Usage: python benchmarks/check_slack_chatter.py [--t-end 20]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _results import publish

import ltdsim

HERE = Path(__file__).resolve().parent
HEAVY = HERE.parent / "scenarios" / "heavy-haul.toml"

RUNS = [
    ("ode3 at 1e-4 s (reference)", {"solver.method": "ode3", "solver.dt": 1e-4}),
    ("ode3 at 5e-5 s", {"solver.method": "ode3", "solver.dt": 5e-5}),
    ("bs23, the scenario's tolerances (rtol 1e-3, atol 1e-4)", {}),
    ("bs23, rtol 1e-4, atol 1e-5", {"solver.rtol": 1e-4, "solver.atol": 1e-5}),
    ("bs23, steps at most 1 ms", {"solver.max_step": 1e-3}),
    ("bs23, steps at most 0.1 ms", {"solver.max_step": 1e-4}),
]


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=20.0, help="simulated time, s")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    base = ltdsim.load_scenario(HEAVY).with_overrides({
        "initial.speed": 18.0, "driver.speed_profile": [[0.0, 18.0]],
        "initial.couplers": "stretched", "solver.t_end": args.t_end})
    peaks, rows, result = {}, [], {"t_end_s": args.t_end, "runs": {}}
    for label, ov in RUNS:
        c0 = time.process_time()
        ds = ltdsim.simulate(base.with_overrides(ov))
        cpu = time.process_time() - c0
        steps, rejected = ds.attrs["steps"], ds.attrs["rejected_steps"]
        peaks[label] = (ds.max_coupler_force.values, ds.min_coupler_force.values)
        print(f"{label}: {steps:,} + {rejected:,} steps, {cpu:.1f} s of CPU", flush=True)
        result["runs"][label] = {"steps": int(steps), "rejected": int(rejected),
                                 "cpu_s": cpu}
    mx0, mn0 = peaks[RUNS[0][0]]
    for label, _ in RUNS:
        mx, mn = peaks[label]
        r = result["runs"][label]
        r.update(mean_tension=mx.mean() / mx0.mean() - 1.0,
                 mean_compression=mn.mean() / mn0.mean() - 1.0,
                 top_tension=mx.max() / mx0.max() - 1.0,
                 worst_coupler_n=float(np.max(np.abs(np.r_[mx - mx0, mn - mn0]))))
        rows.append((label, f"{r['steps']:,} + {r['rejected']:,}",
                     f"{r['mean_tension'] * 100:+.2f} % / {r['mean_compression'] * 100:+.2f} %",
                     f"{r['top_tension'] * 100:+.2f} %", f"{r['worst_coupler_n'] / 1e3:.1f}"))
    publish(args.out, "check_slack_chatter",
            f"Slack chatter check, {{stamp}}; heavy-haul train cruising at 18 m/s from "
            f"stretched couplers, {args.t_end:g} s; against ode3 at 1e-4 s (largest tension "
            f"{mx0.max() / 1e3:.1f} kN, mean peak tension {mx0.mean() / 1e3:.1f} kN, mean peak "
            f"compression {mn0.mean() / 1e3:.2f} kN)", rows,
            columns=("run", "accepted + rejected steps",
                     "peak tension / compression averaged over the train",
                     "largest tension", "worst single coupler, kN"),
            result=result)
    return result


if __name__ == "__main__":
    main()
