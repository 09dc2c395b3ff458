"""Sweep benchmark: the study's 16 cases (270 s, dt 1e-4, ode3) on all local cores.

Runs the sweep twice into fresh folders: once to load (or compile) the kernels, once
timed (wall time, and the CPU time of this process and of the worker processes, which
the machine's other load moves less). The reference is the study's own Simulink time
for the same cases (a published number, not a run here).

Then splits one case's work, measured in this process with the kernel loaded (CPU
seconds, medians over ``--cases`` cases): a fresh worker's start (a new Python
process importing ltdsim, and loading the kernel from numba's cache), the scenario's
validation and lowering, the kernel, the dataset and the case record's numbers
(summary, phase norms), writing the case's file, and the sweep's summary table.
Prints and writes benchmarks/results/bench_sweep.md.

Usage: python benchmarks/bench_sweep.py [--cases 4]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

from ltdsim import sweep as sw

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"
STUDY_SECONDS_PER_CASE = 854.7

_WORKER_START = r"""
import resource, sys, time
c0 = time.process_time()
import ltdsim
from ltdsim import sweep  # what a worker imports to run a case
import ltdsim.phases, ltdsim.summary
c1 = time.process_time()
sc = ltdsim.load_scenario(sys.argv[1], case="LHHL").with_overrides({"solver.t_end": 1e-3})
ltdsim.simulate(sc)  # loads the kernel from numba's cache
c2 = time.process_time()
print(c1 - c0, c2 - c1)
"""


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _worker_start() -> tuple[float, float]:
    """CPU seconds of a fresh process's imports and of its kernel load from the cache."""
    out = subprocess.run([sys.executable, "-c", _WORKER_START, str(PAPER)], check=True,
                         capture_output=True, text=True, env=os.environ).stdout.split()
    return float(out[0]), float(out[1])


def _parts(spec, n_cases: int, out: Path) -> dict[str, float]:
    """Median CPU seconds of each part of a case's work, in this process."""
    from ltdsim.io import atomic_path, sealed_json
    from ltdsim.phases import phase_norms
    from ltdsim.scenario import Scenario
    from ltdsim.simulate import _dataset, _integrate, check_memory, lower, simulate

    simulate(spec.scenario(spec.cases[0]).with_overrides({"solver.t_end": 1e-3}))  # load
    parts: dict[str, list[float]] = {}

    def timed(name, fn):
        c0 = time.process_time()
        r = fn()
        parts.setdefault(name, []).append(time.process_time() - c0)
        return r

    (out / "cases").mkdir(parents=True, exist_ok=True)
    for case in spec.cases[:n_cases]:
        sc0 = spec.scenario(case)
        d = timed("case's scenario built and fingerprinted (main process)",
                  lambda: (sc0.to_dict(), sw.fingerprint(sc0)))[0]
        sc = timed("scenario validated again in the worker (from_dict)",
                   lambda: Scenario.from_dict(d, "bench"))
        low = timed("memory check and lowering", lambda: (check_memory(sc), lower(sc))[1])
        rec = timed("kernel (270 s, 2.7 M steps, recording every 1 ms)",
                    lambda: _integrate(low, sc, None, 100))
        ds = timed("dataset from the records", lambda: _dataset(sc, low, rec, 1.0, 0.0))
        timed("case summary (peaks, RMS error, travel check)", lambda: sw.case_summary(ds))
        timed("phase norms", lambda: phase_norms(ds, sc))
        record = sw.run_case(d, case.id)

        def write():
            with atomic_path(sw.case_path(out, case.id)) as tmp:
                tmp.write_text(sealed_json(dict(record, fingerprint="x",
                                                overrides=case.overrides)))
        timed("case file written (main process)", write)
    return {k: statistics.median(v) for k, v in parts.items()}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=4, help="cases timed for the split")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    spec = sw.load_sweep(PAPER)
    tmp = Path(tempfile.mkdtemp(prefix="ltdsim-bench-sweep-"))
    try:
        t0 = time.perf_counter()
        sw.run_sweep(spec, tmp / "warm")
        warm = time.perf_counter() - t0
        c_self, c_kids = time.process_time(), _children_cpu()
        t0 = time.perf_counter()
        summary = sw.run_sweep(spec, tmp / "timed")
        wall = time.perf_counter() - t0
        cpu_main = time.process_time() - c_self
        cpu_workers = _children_cpu() - c_kids  # the pool's workers, joined at its end
        c0 = time.process_time()
        sw.summary_table(tmp / "timed", spec)
        cpu_summary = time.process_time() - c0
        parts = _parts(spec, args.cases, tmp / "parts")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    imports, load = _worker_start()
    n = len(spec.cases)
    cores = os.cpu_count()
    ok = int((summary.status == "ok").sum())
    rows = [
        (f"{n} cases, {cores} local processes, wall s", f"{wall:.1f}"),
        ("  CPU s of the workers (all cases)", f"{cpu_workers:.1f}"),
        ("  CPU s of the main process", f"{cpu_main:.1f}"),
        ("first sweep (kernels loaded, or compiled if not cached), wall s", f"{warm:.1f}"),
        ("cases finished", f"{ok}/{n}"),
        ("study (Simulink), s for the same 16 cases", f"{n * STUDY_SECONDS_PER_CASE:.0f}"),
        ("ratio study / ltdsim", f"{n * STUDY_SECONDS_PER_CASE / wall:.0f}x"),
        ("split, CPU s: worker start, imports (once per worker)", f"{imports:.2f}"),
        ("split, CPU s: worker start, kernel load from the cache (once per worker)",
         f"{load:.2f}"),
    ]
    rows += [(f"split, CPU s per case: {k}", f"{v:.3f}") for k, v in parts.items()]
    rows.append(("split, CPU s: summary table of the 16 cases (main process)",
                 f"{cpu_summary:.2f}"))
    publish(args.out, "bench_sweep",
            "Sweep benchmark, {stamp}; the study's 16 cases, 270 s at dt 1e-4 with ode3; "
            "the split's parts are medians over " + str(args.cases) + " cases in one "
            "process", rows,
            result={"wall_s": wall, "warm_s": warm, "cases": n, "ok": ok,
                    "cpu_workers_s": cpu_workers, "cpu_main_s": cpu_main,
                    "worker_imports_cpu_s": imports, "worker_kernel_load_cpu_s": load,
                    "parts_cpu_s": parts, "summary_table_cpu_s": cpu_summary})
    return {"wall_s": wall}


if __name__ == "__main__":
    main()
