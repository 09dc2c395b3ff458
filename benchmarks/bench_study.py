"""Study benchmark: `ltdsim study scenarios/paper.toml` end to end into a fresh folder.

Prints and writes benchmarks/results/bench_study.md. Kernels come from numba's cache
if an earlier run filled it (the first run on a machine also compiles).

Usage: python benchmarks/bench_study.py
"""

from __future__ import annotations

import resource
import shutil
import tempfile
import time
from pathlib import Path

from _results import publish

from ltdsim.study.stages import run_study

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"


def main() -> dict:
    out = Path(tempfile.mkdtemp(prefix="ltdsim-bench-study-"))
    stamps = {}
    t0 = time.perf_counter()
    try:
        run_study(PAPER, out, progress=lambda stage, msg: stamps.setdefault(
            stage, time.perf_counter() - t0))
        wall = time.perf_counter() - t0
        t1 = time.perf_counter()
        run_study(PAPER, out)  # everything cached
        rerun = time.perf_counter() - t1
    finally:
        shutil.rmtree(out, ignore_errors=True)
    order = list(stamps) + ["end"]
    times = list(stamps.values()) + [wall]
    rows = [(f"stage {a}", f"{t1_ - t0_:.1f}") for a, t0_, t1_ in zip(order, times, times[1:])]
    rows += [("whole study (16 cases, 270 s, dt 1e-4, ode3), wall s", f"{wall:.1f}"),
             ("second run, every stage cached, wall s", f"{rerun:.1f}"),
             ("peak memory of the main process, MiB",
              f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")]
    publish(HERE / "results", "bench_study", "Study benchmark, {stamp}", rows)
    return {"wall_s": wall}


if __name__ == "__main__":
    main()
