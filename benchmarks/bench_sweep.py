"""Sweep benchmark: the study's 16 cases (270 s, dt 1e-4, ode3) on all local cores.

Runs the sweep twice into fresh folders: once to load (or compile) the kernels, once
timed (wall time, and the CPU time of this process and of the worker processes, which
the machine's other load moves less). The reference is the study's own Simulink time
for the same cases (a published number, not a run here).

Then the sweep as a user starts it, from a fresh Python process (as ``ltdsim sweep``
does: read the scenario, run the cases), with the workers forked from that process (on
Linux, what ltdsim does) and, for comparison, spawned (what it does elsewhere, and did
everywhere before), in ``--rounds`` interleaved rounds: wall time and the CPU time of
the process and its workers, medians. The same again with every case cut to 5 s
simulated (``--short-rounds`` rounds), where the workers' start is most of the work:
the kernel's CPU time, which the machine's load moves by several seconds over 16 full
cases, no longer hides the difference.

Then splits one case's work, measured in this process with the kernel loaded (CPU
seconds, medians over ``--cases`` cases): a fresh worker's start (a new Python
process importing ltdsim, and loading the kernel from numba's cache), the scenario's
validation and lowering, the kernel, the dataset and the case record's numbers
(summary, phase norms), writing the case's file, and the sweep's summary table.
Prints and writes benchmarks/results/bench_sweep.md.

Usage: python benchmarks/bench_sweep.py [--cases 4] [--rounds 2] [--short-rounds 3]
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

from ltdsim.sweep import core as sw

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"
STUDY_SECONDS_PER_CASE = 854.7

_WORKER_START = r"""
import resource, sys, time
c0 = time.process_time()
import ltdsim
from ltdsim.sweep import core as sweep  # what a worker imports to run a case
import ltdsim.analysis.phases, ltdsim.results.summary
c1 = time.process_time()
sc = ltdsim.load_scenario(sys.argv[1], case="LHHL").with_overrides({"solver.t_end": 1e-3})
ltdsim.simulate(sc)  # loads the kernel from numba's cache
c2 = time.process_time()
print(c1 - c0, c2 - c1)
"""


_FORK_PREP = r"""
import sys, time
from ltdsim.sweep import core as sw
spec = sw.load_sweep(sys.argv[1])  # (the main process reads the cases in any case)
c0 = time.process_time()
sw.warm_cases(spec, list(spec.cases), load=True)  # what run_sweep does before it forks
sw.rehearse(spec.scenario(spec.cases[0]))
print(time.process_time() - c0)
"""

_FRESH_SWEEP = r"""
import sys, tempfile
from ltdsim.sweep import core as sw
if sys.argv[2] == "spawn":
    sw.fork_possible = lambda: False  # the workers start as they do where fork is not used
spec = sw.load_sweep(sys.argv[1])
if sys.argv[3] != "full":
    spec = sw.with_overrides(spec, {"solver.t_end": float(sys.argv[3])})
summary = sw.run_sweep(spec, tempfile.mkdtemp(prefix="ltdsim-bench-sweep-fresh-"))
assert (summary.status == "ok").all(), summary
"""


def _fresh_sweep(start: str, t_end: str = "full") -> tuple[float, float]:
    """Wall and CPU seconds (the process and its workers) of the 16 cases run from a new
    Python process whose workers are forked or spawned (``start``), each case ``t_end``
    seconds long ("full": as the scenario says)."""
    c0 = _children_cpu()
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", _FRESH_SWEEP, str(PAPER), start, t_end],
                   check=True, env=os.environ)
    return time.perf_counter() - t0, _children_cpu() - c0


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _worker_start() -> tuple[float, float]:
    """CPU seconds of a fresh process's imports and of its kernel load from the cache."""
    out = subprocess.run([sys.executable, "-c", _WORKER_START, str(PAPER)], check=True,
                         capture_output=True, text=True, env=os.environ).stdout.split()
    return float(out[0]), float(out[1])


def _fork_preparation() -> float:
    """CPU seconds the main process of a fresh sweep spends before forking its workers:
    loading the kernels and rehearsing a case (imports on first use)."""
    out = subprocess.run([sys.executable, "-c", _FORK_PREP, str(PAPER)], check=True,
                         capture_output=True, text=True, env=os.environ).stdout.split()
    return float(out[-1])


def _parts(spec, n_cases: int, out: Path) -> dict[str, float]:
    """Median CPU seconds of each part of a case's work, in this process."""
    from ltdsim.results.io import atomic_path, sealed_json
    from ltdsim.analysis.phases import phase_norms
    from ltdsim.scenario import Scenario
    from ltdsim.engine.lowering import lower
    from ltdsim.engine.run import check_memory, integrate as _integrate
    from ltdsim.results.simulate import _dataset, simulate

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
        timed("case summary (peaks, RMS error, travel check)", lambda: sw.case_summary(ds, sc))
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
    ap.add_argument("--rounds", type=int, default=2,
                    help="interleaved rounds of the fresh-process sweeps (forked, spawned)")
    ap.add_argument("--short-rounds", type=int, default=3,
                    help="interleaved rounds of the fresh-process sweeps of 5 s cases")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
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
    fork_prep = _fork_preparation()
    fresh = {"fork": [], "spawn": [], "fork 5 s": [], "spawn 5 s": []}
    for rounds, t_end, tag in ((args.rounds, "full", ""), (args.short_rounds, "5", " 5 s")):
        for r in range(rounds):
            for start in ("fork", "spawn") if r % 2 == 0 else ("spawn", "fork"):
                fresh[start + tag].append(_fresh_sweep(start, t_end))
    fresh_med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
                 for k, v in fresh.items()}
    n = len(spec.cases)
    cores = os.cpu_count()
    ok = int((summary.status == "ok").sum())
    rows = [
        (f"{n} cases, {cores} local processes, wall s", f"{wall:.1f}"),
        ("  CPU s of the workers (all cases)", f"{cpu_workers:.1f}"),
        ("  CPU s of the main process", f"{cpu_main:.1f}"),
        ("first sweep (kernels loaded, or compiled if not cached), wall s", f"{warm:.1f}"),
        ("cases finished", f"{ok}/{n}"),
        (f"{n} cases from a fresh process, workers forked (Linux), wall s",
         f"{fresh_med['fork'][0]:.1f}"),
        ("  CPU s of the process and its workers", f"{fresh_med['fork'][1]:.1f}"),
        (f"{n} cases from a fresh process, workers spawned (elsewhere), wall s",
         f"{fresh_med['spawn'][0]:.1f}"),
        ("  CPU s of the process and its workers", f"{fresh_med['spawn'][1]:.1f}"),
        (f"{n} cases of 5 s from a fresh process, workers forked, wall s",
         f"{fresh_med['fork 5 s'][0]:.1f}"),
        ("  CPU s of the process and its workers", f"{fresh_med['fork 5 s'][1]:.1f}"),
        (f"{n} cases of 5 s from a fresh process, workers spawned, wall s",
         f"{fresh_med['spawn 5 s'][0]:.1f}"),
        ("  CPU s of the process and its workers", f"{fresh_med['spawn 5 s'][1]:.1f}"),
        ("study (Simulink), s for the same 16 cases", f"{n * STUDY_SECONDS_PER_CASE:.0f}"),
        ("ratio study / ltdsim", f"{n * STUDY_SECONDS_PER_CASE / wall:.0f}x"),
        ("split, CPU s: spawned worker's start, imports (once per worker)", f"{imports:.2f}"),
        ("split, CPU s: spawned worker's start, kernel load from the cache (once per worker)",
         f"{load:.2f}"),
        ("split, CPU s: before forking, kernel load and a rehearsed case (main process, "
         "once)", f"{fork_prep:.2f}"),
    ]
    rows += [(f"split, CPU s per case: {k}", f"{v:.3f}") for k, v in parts.items()]
    rows.append(("split, CPU s: summary table of the 16 cases (main process)",
                 f"{cpu_summary:.2f}"))
    publish(args.out, "bench_sweep",
            "Sweep benchmark, {stamp}; the study's 16 cases, 270 s at dt 1e-4 with ode3; "
            "the split's parts are medians over " + str(args.cases) + " cases in one "
            "process; fresh-process sweeps: medians of " + str(args.rounds) + " (5 s "
            "cases: " + str(args.short_rounds) + ") interleaved rounds; load average "
            + f"{load0:.1f} before the run, {os.getloadavg()[0]:.1f} after", rows,
            result={"wall_s": wall, "warm_s": warm, "cases": n, "ok": ok,
                    "cpu_workers_s": cpu_workers, "cpu_main_s": cpu_main,
                    "worker_imports_cpu_s": imports, "worker_kernel_load_cpu_s": load,
                    "fork_preparation_cpu_s": fork_prep,
                    "fresh_process_wall_cpu_s": fresh,
                    "parts_cpu_s": parts, "summary_table_cpu_s": cpu_summary})
    return {"wall_s": wall}


if __name__ == "__main__":
    main()
