"""Make-up study benchmark: the heavy-haul line's study (scenarios/makeup/
heavy-haul-makeup.toml, 200 make-ups x 2 manoeuvres of the 2 + 210 + 2 vehicle train,
400 runs) on this machine's cores, and what it would take on a 64-core Dask cluster.

The reference is one run of each manoeuvre (the first make-up's), simulated alone in
this process with its kernel loaded: ``--rounds`` rounds before the study and as many
after it (the machine's load drifts), medians. The study runs with the makeup command's
executor (``--workers`` local processes, or the workers of ``--scheduler``) into a fresh
folder; each case record carries its own wall time. From these:

* the study's wall time and the sum of its runs' times;
* the parallel efficiency on this machine: sum of the runs' times / (wall x workers);
* each run's time in the study against the reference run alone (the contention of
  running beside the others on shared cores);
* the extrapolation to 64 workers: the runs' summed time over 64, or, if larger, the
  longest run, plus the time the study spent outside its runs here (planning, the
  workers' start, the page), which does not shrink with more workers.

Prints and writes benchmarks/results/bench_makeup.md and .json.

Usage: python benchmarks/bench_makeup.py [--makeups 200] [--workers 2] [--rounds 2]
       [--scheduler tcp://HOST:PORT]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

import ltdsim
from ltdsim.makeup import run as mrun
from ltdsim.makeup.study import load_study

HERE = Path(__file__).resolve().parent
STUDY = HERE.parent / "scenarios" / "makeup" / "heavy-haul-makeup.toml"
CLUSTER_WORKERS = 64


def _one_run(plan: mrun.Plan, k: int) -> float:
    """Wall seconds of the first make-up's manoeuvre ``k`` simulated alone."""
    case = plan.sweep.cases[k]
    sc = plan.sweep.scenario(case)
    t0 = time.perf_counter()
    ltdsim.simulate(sc)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--makeups", type=int, default=200, help="make-ups to draw (the study's 200)")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--rounds", type=int, default=2, help="reference rounds before and after")
    ap.add_argument("--scheduler", default=None, help="a Dask scheduler's address")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args()

    study = load_study(STUDY)
    if args.makeups != study.spec.makeups:
        study = dataclasses.replace(study, spec=study.spec.model_copy(
            update={"makeups": args.makeups}))
    t_plan = time.perf_counter()
    plan = mrun.plan_of(study)
    t_plan = time.perf_counter() - t_plan
    mans = [m.name for m in study.spec.manoeuvres]
    n_runs = len(plan.sweep.cases)
    print(f"{n_runs} runs ({args.makeups} make-ups x {len(mans)} manoeuvres); planned in "
          f"{t_plan:.1f} s", flush=True)

    print("reference runs (alone, kernel loaded) ...", flush=True)
    for k in range(len(mans)):  # load (or compile) each manoeuvre's kernel once
        _one_run(plan, k)
    ref: dict[str, list[float]] = {m: [] for m in mans}

    def rounds() -> None:
        for _ in range(args.rounds):
            for k, m in enumerate(mans):
                ref[m].append(_one_run(plan, k))
                print(f"  {m}: {ref[m][-1]:.1f} s", flush=True)

    rounds()
    out = Path(tempfile.mkdtemp(prefix="ltdsim-bench-makeup-"))
    done = [0]

    def progress(i: int, n: int, case_id: str) -> None:
        done[0] = i
        if i == n or i % 20 == 0:
            print(f"  study: {i}/{n} runs, {time.perf_counter() - t0:.0f} s", flush=True)

    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    try:
        mrun.run_plan(plan, out, scheduler=args.scheduler, workers=args.workers,
                      progress=progress)
        wall = time.perf_counter() - t0
        load1 = os.getloadavg()[0]
        times = {m: [] for m in mans}
        for f in (out / "cases").glob("*.json"):
            rec = json.loads(f.read_text())
            if rec.get("status") != "ok":
                continue
            cid = f.stem
            m = next(x for x in mans if cid.endswith("-" + x))
            times[m].append(float(rec["summary"]["wall_time_s"]))
    finally:
        shutil.rmtree(out, ignore_errors=True)
    rounds()

    workers = args.workers if args.scheduler is None else None
    all_t = [t for v in times.values() for t in v]
    total = sum(all_t)
    rows = [("runs finished", f"{len(all_t)}/{n_runs}"),
            ("study wall time, s", f"{wall:.0f}"),
            ("sum of the runs' wall times, s", f"{total:.0f}")]
    if workers:
        rows.append((f"parallel efficiency on {workers} workers: sum / (wall x workers), -",
                     f"{total / (wall * workers):.2f}"))
    for m in mans:
        r = statistics.median(ref[m])
        s = statistics.median(times[m]) if times[m] else math.nan
        rows += [(f"{m}: reference run alone, median of {len(ref[m])}, s", f"{r:.2f}"),
                 (f"{m}: run in the study, median of {len(times[m])}, s", f"{s:.2f}"),
                 (f"{m}: ratio study run / reference run, -", f"{s / r:.2f}")]
    outside = max(0.0, wall - total / (workers or 1)) if workers else math.nan
    longest = max(all_t) if all_t else math.nan
    t64 = max(total / CLUSTER_WORKERS, longest) + (outside if workers else 0.0) + t_plan
    rows += [("time outside the runs here: wall - sum / workers, s", f"{outside:.0f}"),
             ("planning (draws, every case checked), s", f"{t_plan:.1f}"),
             ("longest run, s", f"{longest:.1f}"),
             (f"extrapolated wall on {CLUSTER_WORKERS} workers: max(sum / {CLUSTER_WORKERS}, "
              "longest) + outside + planning, s", f"{t64:.0f}")]
    title = (f"Make-up study benchmark, {{stamp}}; {STUDY.name}: {args.makeups} make-ups x "
             f"{len(mans)} manoeuvres of the 214-vehicle train on "
             + (f"{workers} local processes" if workers else f"the scheduler {args.scheduler}")
             + f"; reference: each manoeuvre's first run alone in this process, medians of "
             f"{2 * args.rounds} rounds ({args.rounds} before and {args.rounds} after the "
             f"study); load average {load0:.1f} at the start, {load1:.1f} at the end")
    publish(args.out, "bench_makeup", title, rows,
            result={"runs": n_runs, "wall_s": wall, "sum_s": total, "reference_s": ref,
                    "run_s": times, "t64_s": t64, "planning_s": t_plan})


if __name__ == "__main__":
    sys.exit(main())
