"""Sweep benchmark: the study's 16 cases (270 s, dt 1e-4, ode3) on all local cores.

Runs the sweep twice into fresh folders: once to load (or compile) the kernels in the
workers, once timed. Prints and writes benchmarks/results/bench_sweep.md.

Usage: python benchmarks/bench_sweep.py
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

from _results import publish

from ltdsim import sweep as sw

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"
STUDY_SECONDS_PER_CASE = 854.7


def main() -> dict:
    spec = sw.load_sweep(PAPER)
    tmp = Path(tempfile.mkdtemp(prefix="ltdsim-bench-sweep-"))
    try:
        t0 = time.perf_counter()
        sw.run_sweep(spec, tmp / "warm")
        warm = time.perf_counter() - t0
        t0 = time.perf_counter()
        summary = sw.run_sweep(spec, tmp / "timed")
        wall = time.perf_counter() - t0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    n = len(spec.cases)
    cores = os.cpu_count()
    ok = int((summary.status == "ok").sum())
    rows = [
        (f"{n} cases, {cores} local processes, wall s", f"{wall:.1f}"),
        ("first sweep in a fresh cache folder (kernels loaded or compiled), wall s", f"{warm:.1f}"),
        ("cases finished", f"{ok}/{n}"),
        ("study (Simulink), s for the same 16 cases", f"{n * STUDY_SECONDS_PER_CASE:.0f}"),
        ("ratio study / ltdsim", f"{n * STUDY_SECONDS_PER_CASE / wall:.0f}x"),
    ]
    publish(HERE / "results", "bench_sweep",
            "Sweep benchmark, {stamp}; the study's 16 cases, 270 s at dt 1e-4 with ode3", rows,
            result={"wall_s": wall, "warm_s": warm, "cases": n, "ok": ok})
    return {"wall_s": wall}


if __name__ == "__main__":
    main()
