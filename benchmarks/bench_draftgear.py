"""Draft-gear benchmark: the base scenario with friction gears against the simplified
coupler (same process, interleaved rounds, medians), and the model reduction's wall time.

Usage: python benchmarks/bench_draftgear.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from _results import publish

import ltdsim
from ltdsim.reduce import reduce_gear
from ltdsim.scenario import CouplerParams

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"


def _interleaved_times(scenarios: dict, repeats: int) -> tuple[dict, dict]:
    """Kernel wall seconds and whole-run CPU seconds (this process's
    ``time.process_time``: the kernel is single-threaded, so load on the other core
    moves it less than the wall time) per case of each scenario, run in rounds (one of
    each per round), so that a change in the shared machine's load hits all of them
    alike; the first run of each also pays for compilation and fresh memory and is
    dropped."""
    times = {name: [] for name in scenarios}
    cpu = {name: [] for name in scenarios}
    for name, sc in scenarios.items():
        ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))  # compile / load
        ltdsim.simulate(sc)
    for _ in range(repeats):
        for name, sc in scenarios.items():
            c0 = time.process_time()
            times[name].append(ltdsim.simulate(sc).attrs["wall_time_s"])
            cpu[name].append(time.process_time() - c0)
    return times, cpu


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--no-reduce", action="store_true",
                    help="skip the model reductions (only the coupler timings)")
    args = ap.parse_args(argv)

    base = ltdsim.load_scenario(PAPER, case="LHHL")
    steps = base.solver.n_steps
    rows = []
    presets = ("friction-wedge-high", "friction-wedge-low")
    scenarios = {"simplified": base}
    scenarios.update({p: base.with_overrides({"couplers.default": {"preset": p}})
                      for p in presets})
    times, cpu = _interleaved_times(scenarios, args.repeats)
    simplified = statistics.median(times["simplified"])
    simplified_cpu = statistics.median(cpu["simplified"])
    rows.append(("simplified coupler (LHHL), kernel wall s per case", f"{simplified:.2f}",
                 "1.0x"))
    rows.append(("simplified coupler (LHHL), run CPU s per case", f"{simplified_cpu:.2f}",
                 "1.0x"))
    ratios = {}
    for preset in presets:
        # the ratio within each round, then the median over the rounds
        ratio = statistics.median(t / s for t, s in zip(times[preset], times["simplified"]))
        ratio_cpu = statistics.median(t / s for t, s in zip(cpu[preset], cpu["simplified"]))
        ratios[f"{preset}_ratio"] = ratio
        ratios[f"{preset}_cpu_ratio"] = ratio_cpu
        rows.append((f"{preset}, kernel wall s per case",
                     f"{statistics.median(times[preset]):.2f}", f"{ratio:.2f}x"))
        rows.append((f"{preset}, run CPU s per case",
                     f"{statistics.median(cpu[preset]):.2f}", f"{ratio_cpu:.2f}x"))
    results = {"simplified_s": simplified, "simplified_cpu_s": simplified_cpu, "steps": steps,
               **ratios, "kernel_s": times, "cpu_s": cpu}
    for preset in (() if args.no_reduce else presets):
        t0 = time.perf_counter()
        r = reduce_gear(CouplerParams(preset=preset), workers=-1)
        wall = time.perf_counter() - t0
        rows.append((f"reduce {preset} (2 workers), wall s", f"{wall:.1f}",
                     f"fit {r.fit_percent:.1f} %, {r.evaluations} evaluations"))
        results[f"reduce_{preset}_s"] = wall
        results[f"reduce_{preset}_fit"] = r.fit_percent

    results["rows"] = [list(r) for r in rows]
    publish(args.out, "bench_draftgear",
            f"Draft-gear benchmark, {{stamp}}; base scenario 270 s at dt 1e-4 with ode3, "
            f"{args.repeats} rounds of one run each after a warm-up; ratios within a round, "
            f"medians over the rounds", rows,
            columns=("quantity", "value", "ratio / note"), result=results)
    return results


if __name__ == "__main__":
    main()
