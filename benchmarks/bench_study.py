"""Study benchmark: `ltdsim study scenarios/paper.toml` end to end into a fresh folder.

Prints and writes benchmarks/results/bench_study.md. Kernels come from numba's cache
if an earlier run filled it (the first run on a machine also compiles).

Usage: python benchmarks/bench_study.py
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import resource
import shutil
import tempfile
import time
from pathlib import Path

from ltdsim.io import atomic_path
from ltdsim.study import run_study

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
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    machine = f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
    w = max(len(r[0]) for r in rows)
    lines = [f"Study benchmark, {stamp} ({machine})", "", f"| {'quantity':<{w}} | value |",
             f"|{'-' * (w + 2)}|-------|"] + [f"| {a:<{w}} | {b} |" for a, b in rows]
    text = "\n".join(lines)
    print(text)
    (HERE / "results").mkdir(parents=True, exist_ok=True)
    with atomic_path(HERE / "results" / "bench_study.md") as f:
        f.write_text(text + "\n")
    return {"wall_s": wall}


if __name__ == "__main__":
    main()
