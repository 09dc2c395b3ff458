"""Benchmark: what the curving indicators add to a run.

The 214-vehicle distributed-power train braking through the S curve
(scenarios/heavy-haul-s-curve.toml, 90 s, records every 0.25 s) is simulated without
``[curving]``; then, in the same process and in interleaved rounds (the order
alternating), the run is timed by CPU time (``time.process_time``, which the machine's
load moves less than wall time) and the curving pass (``ltdsim.results.safety.add_curving``) on
its records is timed the same way. Per round the ratio curving / run; the median of
those ratios against the target of at most 20 %. The indicators are computed after the
run from the recorded positions, speeds and coupler forces, so their cost scales with
the number of records and vehicles, not with the solver's steps.

The kernel is compiled (or loaded from the cache) by a short run before the first
round. Prints a table and writes it to benchmarks/results/bench_curving.md and .json.

Usage: python benchmarks/bench_curving.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from _results import publish

import ltdsim
from ltdsim.results.safety import add_curving

HERE = Path(__file__).resolve().parent
SCENARIO = HERE.parent / "scenarios" / "heavy-haul-s-curve.toml"
TARGET = 0.20  # curving pass / run, CPU time, at most


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    sc = ltdsim.load_scenario(SCENARIO)
    plain = sc.model_copy(update={"curving": None})
    print("compiling / loading the kernel ...", file=sys.stderr, flush=True)
    ltdsim.simulate(plain.with_overrides({"solver.t_end": 1.0}))
    runs, passes, ratios = [], [], []
    ds = None
    for k in range(args.rounds):
        order = ("run", "curving") if k % 2 == 0 else ("curving", "run")
        for what in order:
            if what == "run" or ds is None:
                t0 = time.process_time()
                ds = ltdsim.simulate(plain)
                runs.append(time.process_time() - t0)
                if what == "run":
                    continue
            t0 = time.process_time()
            add_curving(ds, sc)
            passes.append(time.process_time() - t0)
        ratios.append(passes[-1] / runs[-1])
        print(f"round {k + 1}/{args.rounds}: run {runs[-1]:.2f} s CPU, curving "
              f"{passes[-1]:.3f} s CPU ({100 * ratios[-1]:.1f} %)", file=sys.stderr, flush=True)
    med = statistics.median(ratios)
    n_rec, n_veh = ds.sizes["time"], ds.sizes["vehicle"]
    rows = [("scenario", SCENARIO.name),
            ("records x vehicles", f"{n_rec} x {n_veh}"),
            ("run, median CPU [s]", f"{statistics.median(runs):.2f}"),
            ("curving pass, median CPU [s]", f"{statistics.median(passes):.3f}"),
            ("curving / run, median of the rounds' ratios [%]", f"{100 * med:.1f}"),
            ("target [%]", f"at most {100 * TARGET:.0f}"),
            ("verdict", "met" if med <= TARGET else "NOT met")]
    publish(HERE / "results", "bench_curving",
            "Curving indicators after the run against the run, CPU time, {stamp}; "
            f"{args.rounds} interleaved rounds", rows,
            result={"runs_cpu_s": runs, "curving_cpu_s": passes, "ratios": ratios,
                    "median_ratio": med, "target": TARGET})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
