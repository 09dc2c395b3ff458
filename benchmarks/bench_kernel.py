"""Kernel benchmark: the study's base scenario against a plain SciPy right-hand side.

Runs, in one process:
  * ltdsim: the base scenario, case LHHL, 270 s, ode3 at dt = 1e-4 s, 10 vehicles,
    after compilation, several times (median);
  * SciPy: the same model as a NumPy right-hand side (ltdsim.reference) under
    ``solve_ivp(method="RK23", rtol=1e-6)`` over the first seconds only;
and prints a table, also written to benchmarks/results/bench_kernel.md and .json.
Timings are ratios within this run; the machine is shared, so absolute seconds vary.

Usage: python benchmarks/bench_kernel.py [--repeats 7] [--scipy-window 2.0]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
from _results import publish
from scipy.integrate import solve_ivp

import ltdsim
from ltdsim.reference import make_rhs

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"
STUDY_SECONDS_PER_CASE = 854.7  # the study's Simulink time per case (paper §5)


def _time_ltdsim(sc, repeats: int):
    walls, kernels = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        ds = ltdsim.simulate(sc)
        walls.append(time.perf_counter() - t0)
        kernels.append(ds.attrs["wall_time_s"])
    return walls, kernels, ds


def _time_scipy(sc, window: float, repeats: int, **options):
    f, y0 = make_rhs(sc)
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = solve_ivp(f, (0.0, window), y0, method="RK23", rtol=1e-6, atol=1e-9, **options)
        walls.append(time.perf_counter() - t0)
    assert sol.success, sol.message
    return walls, sol


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--scipy-window", type=float, default=2.0, help="simulated seconds, s")
    ap.add_argument("--scipy-repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    sc = ltdsim.load_scenario(PAPER, case="LHHL")
    n = sc.n_vehicles
    steps = sc.solver.n_steps
    t_sim = steps * sc.solver.dt

    t0 = time.perf_counter()
    ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))
    warm = time.perf_counter() - t0  # compile, or load from numba's cache

    # the first cases in a fresh process also pay for page-faulting fresh output memory
    cold_walls, _, _ = _time_ltdsim(sc, 2)
    walls, kernels, ds = _time_ltdsim(sc, args.repeats)
    wall = statistics.median(walls)
    kern = statistics.median(kernels)
    tracemalloc.start()
    _time_ltdsim(sc, 1)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    sp_walls, sol = _time_scipy(sc, args.scipy_window, args.scipy_repeats)
    sp = statistics.median(sp_walls)
    sp_per_sim_s = sp / args.scipy_window
    lt_per_sim_s = wall / t_sim
    # like for like: SciPy held to the study's step, and cost per right-hand side
    fixed_window = 0.2
    fx_walls, fx_sol = _time_scipy(sc, fixed_window, args.scipy_repeats,
                                   max_step=sc.solver.dt, first_step=sc.solver.dt)
    fx_per_sim_s = statistics.median(fx_walls) / fixed_window
    stages = 3  # ode3 right-hand sides per step
    lt_per_rhs = kern / (steps * stages)
    sp_per_rhs = sp / sol.nfev

    rows = [
        ("ltdsim: seconds per case (270 s, dt 1e-4, ode3, all outputs)", f"{wall:.3f}"),
        ("ltdsim: seconds for the first case in a fresh process", f"{cold_walls[0]:.3f}"),
        ("ltdsim: of which compiled kernel, s", f"{kern:.3f}"),
        ("ltdsim: vehicle-steps per second (kernel)", f"{n * steps / kern / 1e6:.1f} M"),
        (f"ltdsim: vehicle-steps per second (kernel, fastest of the {len(kernels)} runs: the "
         f"machine is shared)", f"{n * steps / min(kernels) / 1e6:.1f} M"),
        ("ltdsim: vehicle-steps per second (whole case)", f"{n * steps / wall / 1e6:.1f} M"),
        ("ltdsim: faster than real time", f"{t_sim / wall:.0f}x"),
        ("ltdsim: peak memory of one case (tracemalloc)", f"{peak / 2**20:.0f} MiB"),
        ("ltdsim: first call (compile or cache load), s", f"{warm:.2f}"),
        (f"scipy solve_ivp RK23 rtol 1e-6: seconds per simulated second "
         f"(first {args.scipy_window:g} s)", f"{sp_per_sim_s:.2f}"),
        ("scipy: right-hand-side evaluations per simulated second",
         f"{sol.nfev / args.scipy_window:.0f}"),
        ("ratio scipy / ltdsim per simulated second (scipy adaptive)",
         f"{sp_per_sim_s / lt_per_sim_s:.0f}x"),
        (f"ratio scipy / ltdsim per simulated second, scipy held to max_step = dt "
         f"(first {fixed_window:g} s)", f"{fx_per_sim_s / lt_per_sim_s:.0f}x"),
        ("ratio scipy / ltdsim per right-hand-side evaluation",
         f"{sp_per_rhs / lt_per_rhs:.0f}x"),
        ("ratio study (Simulink, 854.7 s per case) / ltdsim", f"{STUDY_SECONDS_PER_CASE / wall:.0f}x"),
    ]
    print(f"process peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB",
          file=sys.stderr)
    result = {
        "vehicles": n, "steps": steps,
        "seconds_per_case": wall, "kernel_seconds": kern, "cold_walls": cold_walls,
        "walls": walls, "kernels": kernels,
        "vehicle_steps_per_s": n * steps / kern,
        "vehicle_steps_per_s_fastest": n * steps / min(kernels), "peak_bytes": peak, "first_call_s": warm,
        "scipy_window_s": args.scipy_window, "scipy_walls": sp_walls, "scipy_nfev": int(sol.nfev),
        "ratio_scipy": sp_per_sim_s / lt_per_sim_s,
        "ratio_scipy_same_step": fx_per_sim_s / lt_per_sim_s,
        "ratio_scipy_per_rhs": sp_per_rhs / lt_per_rhs,
        "rms_speed_error_m_s": float(np.sqrt(np.mean(ds.speed_error.values ** 2))),
    }
    publish(args.out, "bench_kernel",
            f"Kernel benchmark, {{stamp}}; medians of {len(walls)} ltdsim runs after 2 "
            f"warm-up runs, and of {len(sp_walls)} scipy runs", rows, result=result)
    return result


if __name__ == "__main__":
    main()
