"""Draft-gear benchmark: the base scenario with friction gears against the simplified
coupler (same process, interleaved rounds, medians), and the model reduction's wall time.

With ``--instructions SECONDS`` it also counts, with valgrind's callgrind, the
instructions the kernel executes (inside numba's dispatcher call) over the first
SECONDS of the study case with each coupler, a measure the shared machine's load does
not move, and the conditional branches its simulated branch predictor
(``--branch-sim=yes``) guesses wrong: this machine's hardware counters cannot be read
(``perf stat`` is not supported here), and a mispredicted branch costs some 15-20
cycles, so two codes with the same instructions can differ in time by them. The
simulated predictor is a simple one (a table of two-bit counters), not the CPU's:
its counts compare codes, they do not give the hardware's rate. Under valgrind numba sees another CPU (valgrind runs no AVX-512) and would
compile the kernels again, for an hour; so each case is first run natively with its
kernels compiled for a fixed CPU (``NUMBA_CPU_NAME=haswell``: AVX2, which valgrind
runs) into a fresh cache of its own, from which the counted child loads them. The
counts are of that haswell code, not of the code numba makes for this machine.

Usage: python benchmarks/bench_draftgear.py [--repeats 5] [--no-reduce]
       [--instructions SECONDS]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import publish

import ltdsim
from ltdsim.engine.lowering import lower
from ltdsim.analysis.reduction import reduce_gear
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


_COUNT = r"""
import os, subprocess, sys
import ltdsim
preset, seconds, counted = sys.argv[1], float(sys.argv[2]), sys.argv[3] == "1"
sc = ltdsim.load_scenario(sys.argv[4], case="LHHL")
if preset != "simplified":
    sc = sc.with_overrides({"couplers.default": {"preset": preset}})
sc = sc.with_overrides({"solver.t_end": seconds})
ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))  # compile or load
if counted:
    subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], check=True,
                   capture_output=True)
ltdsim.simulate(sc)
if counted:
    subprocess.run(["callgrind_control", "-i", "off", str(os.getpid())], check=True,
                   capture_output=True)
"""


def _instructions(cases, seconds: float) -> dict:
    """Callgrind's counts of the kernel over the first ``seconds`` of the study case,
    per case: ``{event: count}`` with instructions ``Ir``, conditional branches ``Bc``
    and their simulated mispredictions ``Bcm`` (see the module text)."""
    if shutil.which("valgrind") is None:
        raise SystemExit("--instructions: valgrind is not installed")
    work = Path(tempfile.mkdtemp(prefix="ltdsim-draftgear-"))
    env = dict(os.environ, NUMBA_CPU_NAME="haswell", NUMBA_CPU_FEATURES="",
               NUMBA_CACHE_DIR=str(work / "cache"))
    counts = {}
    try:
        for name in cases:
            args = [name, str(seconds)]
            subprocess.run([sys.executable, "-c", _COUNT, *args, "0", str(PAPER)], env=env,
                           check=True, capture_output=True)  # compile into the cache
            out = work / f"callgrind-{name}.out"
            proc = subprocess.run(
                ["valgrind", "--tool=callgrind", "--branch-sim=yes", "--instr-atstart=no",
                 "--toggle-collect=*call_cfunc*", f"--callgrind-out-file={out}",
                 sys.executable, "-c", _COUNT, *args, "1", str(PAPER)],
                env=env, capture_output=True, text=True)
            if proc.returncode != 0:
                raise SystemExit(f"callgrind of {name} failed:\n{proc.stderr[-2000:]}")
            text = out.read_text()
            events = re.search(r"^events: (.*)$", text, re.M).group(1).split()
            totals = re.search(r"^totals: (.*)$", text, re.M).group(1).split()
            counts[name] = dict(zip(events, (int(t) for t in totals)))
            print(f"  {name}: {counts[name]['Ir'] / 1e9:.3f} G instructions, "
                  f"{counts[name]['Bcm'] / 1e6:.2f} M mispredicted branches", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return counts


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--no-reduce", action="store_true",
                    help="skip the model reductions (only the coupler timings)")
    ap.add_argument("--instructions", type=float, default=0.0, metavar="SECONDS",
                    help="also count the kernel's instructions (callgrind) over the first "
                         "SECONDS of the study case with each coupler (0: no count)")
    args = ap.parse_args(argv)
    if args.instructions < 0.0 or args.instructions > 270.0:
        raise SystemExit(f"--instructions: {args.instructions:g} s is outside 0-270 s "
                         "(the study case's length)")

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
    if args.instructions > 0.0:
        print(f"counting instructions over the first {args.instructions:g} s (callgrind)",
              flush=True)
        counts = _instructions(scenarios, args.instructions)
        # coupler evaluations in those seconds: 3 stages (ode3) per step, every coupler
        n_eval = 3 * round(args.instructions / base.solver.dt) * (len(lower(base).cpl))
        for name, count in counts.items():
            label = "simplified coupler (LHHL)" if name == "simplified" else name
            rows.append((f"{label}, instructions in {args.instructions:g} s",
                         f"{count['Ir'] / 1e9:.3f} G",
                         f"{count['Ir'] / counts['simplified']['Ir']:.2f}x"))
        for name, count in counts.items():
            label = "simplified coupler (LHHL)" if name == "simplified" else name
            rows.append((f"{label}, mispredicted branches in {args.instructions:g} s",
                         f"{count['Bcm'] / 1e6:.1f} M",
                         f"{count['Bcm'] / n_eval:.2f} per coupler evaluation"))
        results["instructions"] = {k: c["Ir"] for k, c in counts.items()}
        results["callgrind"] = counts
        results["coupler_evaluations"] = n_eval
        results["instructions_seconds"] = args.instructions
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
            f"medians over the rounds"
            + ("" if args.instructions <= 0.0 else
               "; instructions and mispredicted conditional branches counted by "
               "callgrind (its simulated branch predictor) in the kernel compiled for "
               "haswell")
            , rows,
            columns=("quantity", "value", "ratio / note"), result=results)
    return results


if __name__ == "__main__":
    main()
