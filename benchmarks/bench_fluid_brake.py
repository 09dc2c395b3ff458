"""Benchmark: the cost of the fluid-dynamic air brake.

1. The 214-vehicle heavy-haul trip (scenarios/heavy-haul.toml, lumped brake) against
   the same trip with the fluid brake (scenarios/heavy-haul-fluid.toml: the same train,
   line, driver and solver with ``brake.model = "fluid"``), in the same process, in
   interleaved rounds (the order alternating), timed by CPU time
   (``time.process_time``, which the machine's load moves less than wall time); per
   round the ratio fluid / lumped, and the median of those ratios against the target
   of at most 1.5x. ``--t-end`` shortens the trip (the table says what ran).
2. The 50-wagon UIC freight train's emergency stop (scenarios/uic-freight.toml, fluid
   brake, uic-g distributors): simulated seconds per CPU second (median over the
   rounds) against the target of at least 100x faster than real time; beside it, in the
   same rounds, the same stop with the lumped brake (what the fluid brake costs) and
   with the fluid brake but the study's simplified coupler in place of the friction
   gear that stands in for the wagons' buffers (what the gears cost).

Both kernels are compiled (or loaded from the cache) by a short run of each scenario
before the first round. Prints a table and writes it to
benchmarks/results/bench_fluid_brake.md and .json.

Usage: python benchmarks/bench_fluid_brake.py [--rounds 3] [--t-end 10800]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from _results import publish

import ltdsim
from ltdsim.results.summary import fluid_brake_summary, stopping

HERE = Path(__file__).resolve().parent
SCEN = HERE.parent / "scenarios"
TRIP_RATIO_TARGET = 1.5  # fluid / lumped CPU time for the heavy-haul trip, at most
REALTIME_TARGET = 100.0  # simulated / CPU seconds for the 50-wagon stop, at least
#: the study's simplified coupler (scenarios/short-train.toml's, 10 mm slack as the
#: uic-freight gears): a cheap coupler, to show what the friction gears cost
SIMPLIFIED = {"model": "simplified", "slack": 0.01, "damping": 999.8706, "k1": 8.265776e6,
              "k2": 1.856364e6, "k3": 3.4748e6, "v_c": 0.6}


def _progress(label: str):
    """A progress callback for ltdsim.simulate that prints a line to stderr at every
    further tenth of the simulated time (the runs take minutes; output may go to a log)."""
    shown = [0]

    def report(t: float, t_end: float) -> None:
        tenth = int(10.0 * t / t_end) if t_end > 0 else 10
        if tenth > shown[0]:
            shown[0] = tenth
            print(f"    {label}: {t:.0f} of {t_end:.0f} s simulated", file=sys.stderr, flush=True)

    return report


def _timed(sc, label: str):
    """Run ``sc``; returns (result, CPU s, wall s) and says so on stderr."""
    c0, w0 = time.process_time(), time.perf_counter()
    ds = ltdsim.simulate(sc, progress=_progress(label))
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    print(f"  {label}: {cpu:.1f} CPU s, {wall:.1f} s wall, {ds.attrs['steps']:,} steps",
          file=sys.stderr, flush=True)
    return ds, cpu, wall


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=None,
                    help="simulate the first T s of the heavy-haul trip (default: all)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    lumped = ltdsim.load_scenario(SCEN / "heavy-haul.toml")
    fluid = ltdsim.load_scenario(SCEN / "heavy-haul-fluid.toml")
    if args.t_end:
        lumped = lumped.with_overrides({"solver.t_end": args.t_end})
        fluid = fluid.with_overrides({"solver.t_end": args.t_end})
    uic = ltdsim.load_scenario(SCEN / "uic-freight.toml")
    uic_variants = {
        "uic": uic,
        "uic_lumped": uic.with_overrides({"brake.model": "lumped"}),
        "uic_simplified": uic.with_overrides({"couplers.default": SIMPLIFIED}),
    }
    t_trip = lumped.solver.t_end

    print("compiling or loading the kernels", file=sys.stderr, flush=True)
    for sc in (lumped, fluid, *uic_variants.values()):
        ltdsim.simulate(sc.with_overrides({"solver.t_end": 1.0}))

    keys = ("lumped", "fluid", *uic_variants)
    cpu = {k: [] for k in keys}
    wall = {k: [] for k in keys}
    ratios = []
    last = {}
    for r in range(args.rounds):
        print(f"round {r + 1} of {args.rounds}", file=sys.stderr, flush=True)
        order = ("lumped", "fluid") if r % 2 == 0 else ("fluid", "lumped")
        for key in order:
            sc = lumped if key == "lumped" else fluid
            last[key], c, w = _timed(sc, f"heavy-haul trip, {key} brake, {t_trip:.0f} s")
            cpu[key].append(c)
            wall[key].append(w)
        ratios.append(cpu["fluid"][-1] / cpu["lumped"][-1])
        for key, sc in uic_variants.items():
            last[key], c, w = _timed(sc, f"uic-freight emergency stop ({key}), "
                                         f"{uic.solver.t_end:.0f} s")
            cpu[key].append(c)
            wall[key].append(w)
        result = _publish(args, r + 1, t_trip, uic, cpu, wall, ratios, last)
    return result


def _publish(args, rounds, t_trip, uic, cpu, wall, ratios, last) -> dict:
    """The table of the ``rounds`` rounds done so far, printed and written (after every
    round, so that a run stopped early leaves the rounds it finished)."""
    med = {k: statistics.median(v) for k, v in cpu.items()}
    ratio = statistics.median(ratios)
    realtime = uic.solver.t_end / med["uic"]
    stop = stopping(last["uic"])
    brake_hh = fluid_brake_summary(last["fluid"])
    brake_uic = fluid_brake_summary(last["uic"])
    steps = {k: last[k].attrs["steps"] for k in last}

    def peaks(ds):
        return (f"{ds.max_coupler_force.values.max() / 1e3:.0f} kN / "
                f"{-ds.min_coupler_force.values.min() / 1e3:.0f} kN")

    trip = "the whole 3-hour trip" if t_trip >= 10800 else f"the trip's first {t_trip:.0f} s"
    rows = [
        ("heavy-haul: what ran", f"{trip}, 214 vehicles, bs23, lumped then fluid brake "
                                 f"(order alternating), {rounds} of {args.rounds} rounds"),
        ("heavy-haul, lumped brake: CPU time (median)", f"{med['lumped']:.1f} s "
                                                        f"({steps['lumped']:,} steps)"),
        ("heavy-haul, fluid brake: CPU time (median)", f"{med['fluid']:.1f} s "
                                                       f"({steps['fluid']:,} steps)"),
        ("heavy-haul: fluid / lumped CPU time (median of the rounds' ratios)",
         f"{ratio:.2f}x (rounds {', '.join(f'{x:.2f}' for x in ratios)}; target <= "
         f"{TRIP_RATIO_TARGET:g}x)"),
        ("heavy-haul: largest tension / compression, lumped", peaks(last["lumped"])),
        ("heavy-haul: largest tension / compression, fluid", peaks(last["fluid"])),
        ("uic-freight (loco + 50 wagons, uic-g): emergency stop, CPU time (median)",
         f"{med['uic']:.2f} s for {uic.solver.t_end:.0f} s simulated "
         f"({steps['uic']:,} steps)"),
        ("uic-freight: faster than real time (simulated / CPU s)",
         f"{realtime:.0f}x (target >= {REALTIME_TARGET:.0f}x)"),
        ("uic-freight with the lumped brake: CPU time; faster than real time",
         f"{med['uic_lumped']:.2f} s ({steps['uic_lumped']:,} steps); "
         f"{uic.solver.t_end / med['uic_lumped']:.0f}x"),
        ("uic-freight, fluid brake, the study's simplified coupler: CPU time; faster than "
         "real time", f"{med['uic_simplified']:.2f} s ({steps['uic_simplified']:,} steps); "
                      f"{uic.solver.t_end / med['uic_simplified']:.0f}x"),
    ]
    if stop is not None:
        rows.append(("uic-freight: stopping distance and time",
                     f"{stop['stopping_distance_m']:.0f} m, {stop['stopping_time_s']:.1f} s "
                     f"from {stop['speed_m_s'] * 3.6:.0f} km/h"))
    if brake_uic is not None:
        rows.append(("uic-freight: emergency propagation (0.3 bar drop) end to end, and the "
                     "slope along the train; rear cylinder at 95 %",
                     f"{brake_uic['end_to_end_speed_m_s']:.0f} m/s, "
                     f"{brake_uic['propagation_speed_m_s']:.0f} m/s; "
                     f"{brake_uic['last_cylinder_95_s']:.1f} s after the command"))
    if brake_hh is not None:
        rows.append(("heavy-haul trip, fluid: first application (0.3 bar drop) end to end; "
                     "slope along the train (fit RMS)",
                     (f"{brake_hh['end_to_end_speed_m_s']:.0f} m/s"
                      if np.isfinite(brake_hh['end_to_end_speed_m_s']) else
                      f"not reached (the pipe at vehicle {brake_hh['farthest_vehicle'] + 1}, "
                      f"the farthest from a brake-control point, did not fall 0.3 bar within "
                      f"the application; {brake_hh['vehicles_reached']} vehicles reached)")
                     + f" at {brake_hh['command_time_s']:.0f} s; "
                       f"{brake_hh['propagation_speed_m_s']:.0f} m/s "
                       f"({brake_hh['propagation_fit_rms_s']:.2f} s)"))
    result = {"trip_s": t_trip, "rounds": rounds, "cpu_s": cpu, "wall_s": wall,
              "ratios": ratios, "ratio_median": ratio, "uic_realtime_factor": realtime,
              "uic_lumped_realtime_factor": uic.solver.t_end / med["uic_lumped"],
              "uic_simplified_realtime_factor": uic.solver.t_end / med["uic_simplified"],
              "steps": steps, "trip_ratio_target_met": ratio <= TRIP_RATIO_TARGET,
              "realtime_target_met": realtime >= REALTIME_TARGET}
    publish(args.out, "bench_fluid_brake",
            "Fluid-brake benchmark, {stamp}; CPU time (time.process_time), medians of "
            f"{rounds} interleaved round{'s' if rounds > 1 else ''}", rows, result=result)
    return result


if __name__ == "__main__":
    main()
