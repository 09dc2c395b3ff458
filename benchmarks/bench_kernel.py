"""Kernel benchmark: the study's base scenario against a hand-written numba kernel and a
plain SciPy right-hand side.

Runs, in one process:
  * the in-run reference: the base train (case LHHL's simplified couplers) driven in
    force mode by :data:`FORCE_PROFILE`, 270 s, ode3 at dt = 1e-4 s, coupler forces
    recorded every 1 ms, once by the whole ``ltdsim.simulate()`` (lowering, kernel, the
    xarray result) recording the coupler forces only (``solver.record``, as the
    reference does), once by ``simulate()`` recording every variable, and once by the
    plain hand-written numba kernel of benchmarks/reference_kernel.py; all compiled
    and warmed first, then in interleaved rounds (the order reversed every other round),
    CPU time of this process (``time.process_time``) and wall time, medians; the coupler
    forces are compared value by value;
  * ltdsim: the base scenario, case LHHL (speed mode), 270 s, after compilation, several
    times (median);
  * SciPy: the same model as a NumPy right-hand side (benchmarks/reference_rhs.py) under
    ``solve_ivp(method="RK23", rtol=1e-6)`` over the first seconds only;
  * the study case with the induction drive (scenarios/paper-induction.toml: the same
    train, profile and PID, ode3 at 1e-4 s, 270 s) against the traction-curve study case
    (paper.toml, case LHHL), both whole ``simulate()`` runs warmed first, in interleaved
    rounds (the order alternating), CPU time of this process, each round's ratio, medians
    (the issue's target: at most 2x);
  * the study case LHHL with ``solver.energy = true`` against the same without, both
    warmed first, in interleaved rounds, CPU time, each round's ratio, medians (the
    issue's target: at most 1.05);
  * with ``--baseline REV`` (default: the commit before the engine's redesign), the
    study case LHHL by this version and by ``REV`` (a fresh clone), each in child
    processes, rounds interleaved, CPU time of the child's runs, medians;
and prints a table, also written to benchmarks/results/bench_kernel.md and .json.
Timings are ratios within this run; the machine is shared, so absolute seconds vary.

Usage: python benchmarks/bench_kernel.py [--repeats 7] [--rounds 11] [--scipy-window 2.0]
       [--baseline REV | --baseline ""]
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import reference_kernel
import numpy as np
from _results import publish
from scipy.integrate import solve_ivp

import ltdsim
from reference_rhs import make_rhs

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PAPER = ROOT / "scenarios" / "paper.toml"
PAPER_DRIVE = ROOT / "scenarios" / "paper-induction.toml"
STUDY_SECONDS_PER_CASE = 854.7  # the study's Simulink time per case (paper §5)
#: the commit before issue 14's engine redesign landed its later steps: the study case's
#: time there is the baseline the redesign must not exceed
BASELINE = "598d50a"
#: traction demand of the force-mode case, [time s, force N]: from rest to the study's
#: full 863 kN within 10 s, held, eased to cruise, a dynamic-brake application of 300 kN
#: around the study's deceleration phase (120-130 s), cruise again; the traction curve
#: (force, power and adhesion limits) clips it, as in ltdsim
FORCE_PROFILE = [[0.0, 0.0], [5.0, 0.0], [15.0, 8.63e5], [40.0, 8.63e5], [50.0, 1.5e5],
                 [115.0, 1.5e5], [125.0, -3.0e5], [135.0, -3.0e5], [140.0, 1.5e5],
                 [270.0, 1.5e5]]


def force_case(sc):
    """Scenario ``sc`` driven in force mode by :data:`FORCE_PROFILE`."""
    return sc.with_overrides({"driver.mode": "force", "driver.force_profile": FORCE_PROFILE})


def forces_only(sc):
    """Scenario ``sc`` recording the coupler forces only (``solver.record``): the
    reference kernel's recording, for a like-for-like comparison."""
    return sc.with_overrides({"solver.record": ["coupler_force"]})


def _clocks():
    return time.process_time(), time.perf_counter()


def _against_reference(sc, rounds: int) -> dict:
    """``simulate()`` of ``sc`` recording the coupler forces only (``simulate``, the
    reference kernel's recording) and recording every variable (``simulate, all``)
    against the hand-written kernel (``reference``): CPU and wall seconds of each,
    ``rounds`` interleaved rounds after a warm-up of all three (the order reversed every
    other round), and the largest difference of their coupler forces."""
    ref_force = reference_kernel.simulate(sc)  # compile (or load) and warm all three
    ltdsim.simulate(sc)
    ds = ltdsim.simulate(forces_only(sc))
    sim_force = ds.coupler_force.values
    if sim_force.shape != ref_force.shape:
        raise SystemExit(f"records differ: simulate {sim_force.shape}, reference "
                         f"{ref_force.shape}")
    diff = float(np.max(np.abs(sim_force - ref_force)))
    runs = {"reference": lambda: reference_kernel.simulate(sc),
            "simulate": lambda: ltdsim.simulate(forces_only(sc)),
            "simulate, all": lambda: ltdsim.simulate(sc)}
    times = {k: {"cpu": [], "wall": []} for k in runs}
    for r in range(rounds):
        for name in (list(runs) if r % 2 == 0 else list(runs)[::-1]):
            c0, w0 = _clocks()
            runs[name]()
            c1, w1 = _clocks()
            times[name]["cpu"].append(c1 - c0)
            times[name]["wall"].append(w1 - w0)
        print(f"reference round {r + 1}/{rounds} done", file=sys.stderr, flush=True)
    return {"max_force_difference_N": diff, "values_compared": int(sim_force.size),
            "max_abs_force_N": float(np.max(np.abs(ref_force))), "times": times}


def _paired(first, second, rounds: int, what: str) -> dict:
    """CPU, wall and user-CPU seconds of ``simulate(first)`` and ``simulate(second)``: a
    warm-up of both, then ``rounds`` interleaved rounds (the order alternating), each run
    after a garbage collection and with the collector off while it runs; each round's
    ratio second / first of CPU time (``times["round ratios"]``) and of user CPU time
    (``times["round ratios, user"]``)."""
    ltdsim.simulate(first)
    ltdsim.simulate(second)
    runs = {"first": first, "second": second}
    times = {k: {"cpu": [], "wall": [], "user": []} for k in runs}
    for r in range(rounds):
        for name in (("first", "second") if r % 2 == 0 else ("second", "first")):
            # each run starts from the same state: the previous run's result collected
            # now (not by a cyclic collection inside the next run's timing), none during
            gc.collect()
            gc.disable()
            try:
                u0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
                c0, w0 = _clocks()
                ltdsim.simulate(runs[name])
                c1, w1 = _clocks()
                u1 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
            finally:
                gc.enable()
            times[name]["cpu"].append(c1 - c0)
            times[name]["wall"].append(w1 - w0)
            times[name]["user"].append(u1 - u0)
        print(f"{what} round {r + 1}/{rounds} done", file=sys.stderr, flush=True)
    times["round ratios"] = [a / b for a, b in zip(times["second"]["cpu"],
                                                   times["first"]["cpu"])]
    times["round ratios, user"] = [a / b for a, b in zip(times["second"]["user"],
                                                         times["first"]["user"])]
    return times


def _paired_rows(times: dict, first: str, second: str, target: str) -> list:
    """Table rows of :func:`_paired`'s ``times``: each run's median CPU (wall) seconds
    and the ratio second / first, median of the rounds' ratios and of the medians."""
    c1, c2 = (statistics.median(times[k]["cpu"]) for k in ("first", "second"))
    w1, w2 = (statistics.median(times[k]["wall"]) for k in ("first", "second"))
    n = len(times["round ratios"])
    return [(f"{first}, CPU s (wall s)", f"{c1:.3f} ({w1:.3f})"),
            (f"{second}, CPU s (wall s)", f"{c2:.3f} ({w2:.3f})"),
            (f"ratio, CPU, median of the {n} rounds' ratios ({target})",
             f"{statistics.median(times['round ratios']):.3f}"),
            ("ratio, CPU, of the medians", f"{c2 / c1:.3f}"),
            # (the kernel's own time: on this machine the system time of a run jumps
            # by 0.1-0.3 s from one run to the next with the same page faults, a cost of
            # the host's memory management, not of the code; user time leaves it out)
            (f"ratio, user CPU, median of the {n} rounds' ratios ({target})",
             f"{statistics.median(times['round ratios, user']):.3f}")]


_CHILD = r"""
import json, sys, time
import ltdsim
sc = ltdsim.load_scenario(sys.argv[1], case="LHHL")
ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))  # compile or load
ltdsim.simulate(sc)  # warm (fresh output memory)
import resource
cpu, user = [], []
for _ in range(int(sys.argv[2])):
    u0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
    c0 = time.process_time()
    ltdsim.simulate(sc)
    cpu.append(time.process_time() - c0)
    user.append(resource.getrusage(resource.RUSAGE_SELF).ru_utime - u0)
print(json.dumps([cpu, user]))
"""


def _against_baseline(rev: str, rounds: int, runs: int) -> dict:
    """CPU seconds of ``simulate()`` of the study case LHHL (270 s) by this version and by
    ``rev`` (each from its own scenarios/paper.toml): per round one child process of each
    (the order alternating), ``runs`` runs per child after a warm-up; returns each child's median per version and each round's
    ratio this version / baseline."""
    work = Path(tempfile.mkdtemp(prefix="ltdsim-bench-baseline-"))
    try:
        clone = work / "baseline"
        subprocess.run(["git", "clone", "--quiet", "--shared", str(ROOT), str(clone)],
                       check=True)
        subprocess.run(["git", "-C", str(clone), "checkout", "--quiet", rev], check=True)
        srcs = {"baseline": clone / "src", "this version": ROOT / "src"}
        # each version runs the study case from its own scenario file (a newer file may
        # hold keys an older version does not know, such as couplers' strength)
        papers = {"baseline": clone / "scenarios" / "paper.toml", "this version": PAPER}
        cpu = {k: [] for k in srcs}
        user = {k: [] for k in srcs}
        cpu["round ratios"] = []
        cpu["round ratios, user"] = []
        for r in range(rounds):
            for name in (list(srcs) if r % 2 == 0 else list(srcs)[::-1]):
                env = dict(os.environ, PYTHONPATH=str(srcs[name]))
                out = subprocess.run([sys.executable, "-c", _CHILD, str(papers[name]), str(runs)],
                                     env=env, capture_output=True, text=True)
                if out.returncode != 0:
                    raise SystemExit(f"{name} failed:\n{out.stderr[-2000:]}")
                got, got_user = json.loads(out.stdout.strip().splitlines()[-1])
                cpu[name].append(statistics.median(got))
                user[name].append(statistics.median(got_user))
                print(f"baseline round {r + 1}/{rounds}: {name} done", file=sys.stderr,
                      flush=True)
            cpu["round ratios"].append(cpu["this version"][-1] / cpu["baseline"][-1])
            cpu["round ratios, user"].append(user["this version"][-1] / user["baseline"][-1])
        return cpu
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _time_ltdsim(sc, repeats: int, cpus=None):
    walls, kernels = [], []
    for _ in range(repeats):
        c0, t0 = _clocks()
        ds = ltdsim.simulate(sc)
        c1, t1 = _clocks()
        walls.append(t1 - t0)
        if cpus is not None:
            cpus.append(c1 - c0)
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
    ap.add_argument("--rounds", type=int, default=11,
                    help="interleaved rounds of simulate() against the reference kernel")
    ap.add_argument("--drive-rounds", type=int, default=7,
                    help="interleaved rounds of the induction-drive case against the curve's")
    ap.add_argument("--energy-rounds", type=int, default=11,
                    help="interleaved rounds of the study case with the energy accounted "
                         "against without")
    ap.add_argument("--baseline", default=BASELINE,
                    help="git revision whose study-case time is the baseline ('' to skip)")
    ap.add_argument("--baseline-rounds", type=int, default=5)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    sc = ltdsim.load_scenario(PAPER, case="LHHL")
    ref = _against_reference(force_case(sc), args.rounds)
    rt = ref["times"]
    med = {k: {c: statistics.median(v[c]) for c in ("cpu", "wall")} for k, v in rt.items()}
    per_round = [a / b for a, b in zip(rt["simulate"]["cpu"], rt["reference"]["cpu"])]
    per_round_all = [a / b for a, b in zip(rt["simulate, all"]["cpu"],
                                           rt["reference"]["cpu"])]
    n = sc.n_vehicles
    steps = sc.solver.n_steps
    t_sim = steps * sc.solver.dt

    t0 = time.perf_counter()
    ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))
    warm = time.perf_counter() - t0  # compile, or load from numba's cache

    # the first cases in a fresh process also pay for page-faulting fresh output memory
    cold_walls, _, _ = _time_ltdsim(sc, 2)
    cpus = []
    walls, kernels, ds = _time_ltdsim(sc, args.repeats, cpus)
    cpu = statistics.median(cpus)
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
        ("force-mode case: largest |coupler force, simulate() - reference kernel|, N "
         f"(over {ref['values_compared']:,} values; largest |force| "
         f"{ref['max_abs_force_N'] / 1e3:.0f} kN)", f"{ref['max_force_difference_N']:.3g}"),
        ("force-mode case: reference kernel, CPU s (wall s)",
         f"{med['reference']['cpu']:.3f} ({med['reference']['wall']:.3f})"),
        ("force-mode case: whole simulate(), recording the coupler forces only "
         "(solver.record), CPU s (wall s)",
         f"{med['simulate']['cpu']:.3f} ({med['simulate']['wall']:.3f})"),
        (f"ratio simulate() / reference kernel, CPU, median of the {args.rounds} rounds' "
         "ratios (target <= 1.0)", f"{statistics.median(per_round):.3f}"),
        ("ratio simulate() / reference kernel, CPU, of the medians",
         f"{med['simulate']['cpu'] / med['reference']['cpu']:.3f}"),
        ("ratio simulate() / reference kernel, wall, of the medians",
         f"{med['simulate']['wall'] / med['reference']['wall']:.3f}"),
        ("force-mode case: whole simulate() recording every variable, CPU s (wall s)",
         f"{med['simulate, all']['cpu']:.3f} ({med['simulate, all']['wall']:.3f})"),
        (f"ratio simulate(), every variable / reference kernel, CPU, median of the "
         f"{args.rounds} rounds' ratios", f"{statistics.median(per_round_all):.3f}"),
        ("ltdsim: CPU seconds per case (270 s, dt 1e-4, ode3, all outputs)", f"{cpu:.3f}"),
        ("ltdsim: seconds per case (270 s, dt 1e-4, ode3, all outputs), wall", f"{wall:.3f}"),
        ("ltdsim: seconds for the first case in a fresh process", f"{cold_walls[0]:.3f}"),
        ("ltdsim: of which compiled kernel, wall s", f"{kern:.3f}"),
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
    drv = _paired(sc, ltdsim.load_scenario(PAPER_DRIVE), args.drive_rounds, "drive")
    rows += _paired_rows(drv, "study case LHHL (270 s, ode3 at 1e-4 s), traction curve, "
                         "whole simulate()", "the same with the induction drive "
                         "(paper-induction.toml)", "drive / curve, target <= 2.0")
    energy = _paired(sc, sc.with_overrides({"solver.energy": True}), args.energy_rounds,
                     "energy")
    rows += _paired_rows(energy, "study case LHHL, whole simulate()",
                         "the same with the energy accounted (solver.energy = true)",
                         "energy / plain, target <= 1.05")
    base = None
    if args.baseline:
        base = _against_baseline(args.baseline, args.baseline_rounds, 2)
        b0 = statistics.median(base["baseline"])
        b1 = statistics.median(base["this version"])
        rows += [
            (f"study case LHHL (speed mode, 270 s), whole simulate(), CPU s: baseline "
             f"{args.baseline}", f"{b0:.3f}"),
            ("study case LHHL, whole simulate(), CPU s: this version", f"{b1:.3f}"),
            (f"ratio this version / {args.baseline}, median of the rounds' ratios (target "
             "<= 1.0)", f"{statistics.median(base['round ratios']):.3f}"),
            (f"ratio this version / {args.baseline}, of the medians", f"{b1 / b0:.3f}"),
            (f"ratio this version / {args.baseline}, user CPU, median of the rounds' ratios",
             f"{statistics.median(base['round ratios, user']):.3f}"),
        ]
    print(f"process peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB",
          file=sys.stderr)
    result = {
        "vehicles": n, "steps": steps,
        "seconds_per_case": wall, "cpu_seconds_per_case": cpu, "cpus": cpus,
        "kernel_seconds": kern, "cold_walls": cold_walls,
        "walls": walls, "kernels": kernels,
        "vehicle_steps_per_s": n * steps / kern,
        "vehicle_steps_per_s_fastest": n * steps / min(kernels), "peak_bytes": peak, "first_call_s": warm,
        "scipy_window_s": args.scipy_window, "scipy_walls": sp_walls, "scipy_nfev": int(sol.nfev),
        "ratio_scipy": sp_per_sim_s / lt_per_sim_s,
        "ratio_scipy_same_step": fx_per_sim_s / lt_per_sim_s,
        "ratio_scipy_per_rhs": sp_per_rhs / lt_per_rhs,
        "rms_speed_error_m_s": float(np.sqrt(np.mean(ds.speed_error.values ** 2))),
        "force_case": {"profile": FORCE_PROFILE, **ref,
                       "ratio_cpu": statistics.median(per_round),
                       "ratio_cpu_of_medians": med["simulate"]["cpu"] / med["reference"]["cpu"],
                       "ratio_wall": med["simulate"]["wall"] / med["reference"]["wall"],
                       "ratio_cpu_per_round": per_round,
                       "ratio_cpu_all_variables": statistics.median(per_round_all),
                       "ratio_cpu_all_variables_per_round": per_round_all},
        "drive_case": {"cpu_s": drv, "ratio_cpu": statistics.median(drv["round ratios"])},
        "energy_case": {"cpu_s": energy,
                        "ratio_cpu": statistics.median(energy["round ratios"]),
                        "ratio_user_cpu": statistics.median(energy["round ratios, user"])},
        "baseline": None if base is None else {"revision": args.baseline, "cpu_s": base},
    }
    how = (f"; simulate() against the reference kernel: {args.rounds} interleaved rounds "
           "after a warm-up of both, CPU time of this process (time.process_time), each "
           "round's ratio, medians")
    how += (f"; induction-drive study case against the curve's: {args.drive_rounds} "
            "interleaved rounds after a warm-up of both, CPU time of this process, each "
            "round's ratio, medians; the study case with the energy accounted against "
            f"without: {args.energy_rounds} rounds the same way")
    if base is not None:
        how += (f"; study case against {args.baseline}: {args.baseline_rounds} rounds of one "
                "child process per version, 2 runs each, CPU time, each round's ratio, medians")
    publish(args.out, "bench_kernel",
            f"Kernel benchmark, {{stamp}}; medians of {len(walls)} ltdsim runs after 2 "
            f"warm-up runs, and of {len(sp_walls)} scipy runs{how}", rows, result=result)
    return result


if __name__ == "__main__":
    main()
