"""Warm-kernel benchmark in instructions: this version against a reference commit.

On this shared machine (a virtual machine with other work on it) the CPU seconds of
one 1-2 s kernel run move by ±20 % from run to run, more than the few per cent a
change to the kernel can make. valgrind's callgrind counts the instructions the
compiled kernels execute instead, which load does not move: each case is run once per
version under ``valgrind --tool=callgrind`` with instrumentation switched on only after
the kernel is compiled and warm, and counted only inside numba's dispatcher call
(``call_cfunc``: the kernel and its argument checks).

Cases: the base scenario (simplified couplers, fixed-step ode3, 2 s), the same with the
friction-wedge gear (1 s), and with ``--heavy`` the heavy-haul train (adaptive bs23 with
air brakes, 20 s). Under valgrind numba sees another CPU and compiles the kernels again
(for both versions alike), so a run takes minutes, the reference's most.

Each version runs from a fresh ``git clone`` (HEAD and ``--reference``), with the
installed environment (``PYTHONPATH`` at the clone's ``src``). Writes
benchmarks/results/bench_kernel_instructions.md and .json.

Usage: python benchmarks/bench_kernel_instructions.py [--reference REV] [--heavy]
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from _results import publish

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
REFERENCE = "ccf4c4a"  # the last commit before the first-run work (see bench_first_run.py)

_CASE = r"""
import os, subprocess, sys
import ltdsim
kind = sys.argv[1]
sc = ltdsim.load_scenario("scenarios/paper.toml", case="LHHL")
if kind == "simplified":
    sc = sc.with_overrides({"solver.t_end": 2.0})
elif kind == "energy":
    sc = sc.with_overrides({"solver.t_end": 2.0, "solver.energy": True})
elif kind == "wedge":
    sc = sc.with_overrides({"couplers.default": {"preset": "friction-wedge-high"},
                            "solver.t_end": 1.0})
else:
    sc = ltdsim.load_scenario("scenarios/heavy-haul.toml").with_overrides(
        {"solver.t_end": 20.0})
ltdsim.simulate(sc.with_overrides({"solver.t_end": sc.solver.output_interval}))  # compile
pid = str(os.getpid())
subprocess.run(["callgrind_control", "-i", "on", pid], check=True, capture_output=True)
ltdsim.simulate(sc)
subprocess.run(["callgrind_control", "-i", "off", pid], check=True, capture_output=True)
"""

CASES = {"simplified": "base scenario, simplified couplers, ode3, 2 s",
         "energy": "the same with the energy accounted (solver.energy = true)",
         "wedge": "base scenario, friction-wedge-high gears, ode3, 1 s",
         "heavy": "heavy-haul train, bs23, air brakes, 20 s"}


def _count(clone: Path, cache: Path, case: str, work: Path) -> int:
    out = work / f"callgrind-{clone.name}-{case}.out"
    env = dict(os.environ, PYTHONPATH=str(clone / "src"), NUMBA_CACHE_DIR=str(cache))
    cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no",
           "--toggle-collect=*call_cfunc*", f"--callgrind-out-file={out}",
           sys.executable, "-c", _CASE, case]
    proc = subprocess.run(cmd, cwd=clone, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{case} in {clone} failed:\n{proc.stderr[-3000:]}")
    return int(re.search(r"^totals: (\d+)", out.read_text(), re.M).group(1))


def _version(rev: str, tag: str, cases, work: Path) -> dict:
    clone = work / f"clone-{tag}"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
    subprocess.run(["git", "-C", str(clone), "checkout", "--quiet", rev], check=True)
    cache = Path(tempfile.mkdtemp(prefix=f"cache-{tag}-", dir=work))
    return {case: _count(clone, cache, case, work) for case in cases}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", default=REFERENCE, help="git revision to compare with")
    ap.add_argument("--heavy", action="store_true", help="also the heavy-haul case (slow)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind is not installed")
    cases = [c for c in CASES if c != "heavy" or args.heavy]
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True, check=True).stdout.strip()
    revs = {"ref": args.reference, "new": head}
    work = Path(tempfile.mkdtemp(prefix="ltdsim-instructions-"))
    try:
        with cf.ThreadPoolExecutor(2) as pool:  # the two versions side by side
            futs = {tag: pool.submit(_version, rev, tag, cases, work)
                    for tag, rev in revs.items()}
            counts = {tag: f.result() for tag, f in futs.items()}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    rows = []
    for case in cases:
        ref, new = counts["ref"][case], counts["new"][case]
        rows.append((CASES[case], f"{ref / 1e6:.1f} M", f"{new / 1e6:.1f} M",
                     f"{new / ref:.3f}"))
    publish(args.out, "bench_kernel_instructions",
            f"Warm-kernel instructions (callgrind), {{stamp}}; reference {revs['ref']}, "
            f"new {revs['new']}", rows,
            columns=("case", f"reference {revs['ref']}", f"new {revs['new']}", "new / reference"),
            result={"revisions": revs, "instructions": counts})
    return counts


if __name__ == "__main__":
    main()
