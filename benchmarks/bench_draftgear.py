"""Draft-gear benchmark: the base scenario with friction gears against the simplified
coupler (same process, medians), and the model reduction's wall time.

Usage: python benchmarks/bench_draftgear.py [--repeats 3]
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


def _case_times(sc, repeats):
    ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))  # compile / load
    kernels = []
    for _ in range(repeats + 1):
        kernels.append(ltdsim.simulate(sc).attrs["wall_time_s"])
    return statistics.median(kernels[1:])  # the first also pays for fresh memory


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    base = ltdsim.load_scenario(PAPER, case="LHHL")
    steps = base.solver.n_steps
    rows = []
    simplified = _case_times(base, args.repeats)
    rows.append(("simplified coupler (LHHL), kernel s per case", f"{simplified:.2f}", "1.0x"))
    for preset in ("friction-wedge-high", "friction-wedge-low"):
        sc = base.with_overrides({"couplers.default": {"preset": preset}})
        t = _case_times(sc, args.repeats)
        rows.append((f"{preset}, kernel s per case", f"{t:.2f}", f"{t / simplified:.1f}x"))
    results = {"simplified_s": simplified, "steps": steps}
    for preset in ("friction-wedge-high", "friction-wedge-low"):
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
            f"medians of {args.repeats} runs after a warm-up", rows,
            columns=("quantity", "value", "ratio / note"), result=results)
    return results


if __name__ == "__main__":
    main()
