"""Where the fixed-step kernel's instructions go per step (simplified couplers, ode3).

The kernel is one compiled function (numba inlines the force laws, the controller and
the recording into it), so callgrind cannot name its parts. The split is found by
difference instead: the same compiled kernel runs variants of the study's base case
(LHHL, 2 s at dt 1e-4: 20000 steps) that change one thing each, and callgrind counts
the instructions of each run (``valgrind --tool=callgrind``, counted only inside
numba's dispatcher call, as in bench_kernel_instructions.py; instruction counts do not
move with the machine's load):

* the method's stages: euler (1), heun (2), ode3 (3), rk4 (4); a straight line through
  the four counts gives the instructions per force evaluation (one stage) and per step
  outside them (the step's fixed work: loop, controller sample, peaks, records);
* the recording: every 1 ms (as the study's sweep records) against every 0.1 s;
* the train's length: 10 vehicles (9 couplers) against 20 (19), for the cost per vehicle
  and coupler in one force evaluation.

Under valgrind numba sees another CPU and compiles the kernel once more (minutes).
Writes benchmarks/results/bench_kernel_split.md and .json.

Usage: python benchmarks/bench_kernel_split.py [--cache DIR]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _results import publish

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

_RUN = r"""
import os, subprocess, sys
import ltdsim
from ltdsim.scenario import Scenario
base = ltdsim.load_scenario("scenarios/paper.toml", case="LHHL").with_overrides(
    {"solver.t_end": 2.0})
d = base.to_dict()
d["vehicles"] += [dict(d["vehicles"][-1]) for _ in range(10)]  # 9 -> 19 wagons
variants = {
    "ode3": base,
    "records every 0.1 s": base.with_overrides({"solver.output_interval": 0.1}),
    "euler": base.with_overrides({"solver.method": "euler"}),
    "heun": base.with_overrides({"solver.method": "heun"}),
    "rk4": base.with_overrides({"solver.method": "rk4"}),
    "20 vehicles": Scenario.from_dict(d, "20 vehicles"),
}
for sc in variants.values():  # compile (or load) outside the count
    ltdsim.simulate(sc.with_overrides({"solver.t_end": sc.solver.output_interval}))
pid = str(os.getpid())
for i, (name, sc) in enumerate(variants.items()):
    subprocess.run(["callgrind_control", "-z", pid], check=True, capture_output=True)
    subprocess.run(["callgrind_control", "-i", "on", pid], check=True, capture_output=True)
    ds = ltdsim.simulate(sc)
    subprocess.run(["callgrind_control", "-i", "off", pid], check=True, capture_output=True)
    subprocess.run(["callgrind_control", f"--dump=v{i}", pid], check=True, capture_output=True)
    print("VARIANT", i, ds.attrs["steps"], ds.sizes["vehicle"], ds.sizes["time"], name,
          flush=True)
"""


def _counts(work: Path, cache: Path) -> dict[str, dict]:
    out = work / "split.cg"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no",
           "--toggle-collect=*call_cfunc*", f"--callgrind-out-file={out}",
           sys.executable, "-c", _RUN]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"the counted run failed:\n{proc.stderr[-3000:]}")
    runs = {}
    for line in proc.stdout.splitlines():
        if line.startswith("VARIANT "):
            _, i, steps, vehicles, samples, name = line.split(" ", 5)
            dump = Path(f"{out}.{int(i) + 1}").read_text()
            runs[name] = {"instructions": int(re.search(r"^totals: (\d+)", dump, re.M).group(1)),
                          "steps": int(steps), "vehicles": int(vehicles),
                          "samples": int(samples)}
    return runs


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--cache", type=Path, default=None,
                    help="numba cache folder of kernels compiled under valgrind (default: a "
                         "fresh one, compiled in the run)")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind is not installed")
    work = Path(tempfile.mkdtemp(prefix="ltdsim-kernel-split-"))
    try:
        runs = _counts(work, args.cache or work / "cache")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    per_step = {k: v["instructions"] / v["steps"] for k, v in runs.items()}
    stages = np.array([1, 2, 3, 4])
    counts = np.array([per_step[m] for m in ("euler", "heun", "ode3", "rk4")])
    per_stage, fixed = np.polyfit(stages, counts, 1)
    worst = float(np.max(np.abs(np.polyval([per_stage, fixed], stages) - counts)))
    step = per_step["ode3"]
    samples = runs["ode3"]["samples"] - runs["records every 0.1 s"]["samples"]
    records = (per_step["ode3"] - per_step["records every 0.1 s"]) * runs["ode3"]["steps"]
    per_record_step = records / runs["ode3"]["steps"]
    extra = runs["20 vehicles"]["vehicles"] - runs["ode3"]["vehicles"]
    per_vehicle_stage = (per_step["20 vehicles"] - step) / 3 / extra
    n = runs["ode3"]["vehicles"]
    train_stage = per_stage - n * per_vehicle_stage
    rows = [
        ("ode3 step, 10 vehicles, recording every 1 ms", f"{step:.0f}", "100%"),
        ("  3 force evaluations (stages), all of their work", f"{3 * per_stage:.0f}",
         f"{3 * per_stage / step:.0%}"),
        ("    of which grows with the train (10 vehicles and couplers x 3 x "
         f"{per_vehicle_stage:.0f})", f"{3 * n * per_vehicle_stage:.0f}",
         f"{3 * n * per_vehicle_stage / step:.0%}"),
        ("    of which per evaluation, not per vehicle (traction, driver, 3 x "
         f"{train_stage:.0f})", f"{3 * train_stage:.0f}", f"{3 * train_stage / step:.0%}"),
        ("  the step outside the evaluations (loop, records, peaks)", f"{fixed:.0f}",
         f"{fixed / step:.0%}"),
        ("    of which recording every 1 ms (" + f"{records / samples:.0f} per sample)",
         f"{per_record_step:.0f}", f"{per_record_step / step:.0%}"),
        ("euler / heun / ode3 / rk4 per step",
         " / ".join(f"{c:.0f}" for c in counts), f"line fit within {worst:.0f}"),
        ("20 vehicles (19 couplers), ode3 per step", f"{per_step['20 vehicles']:.0f}",
         f"{per_step['20 vehicles'] / step:.2f}x"),
    ]
    publish(args.out, "bench_kernel_split",
            "Fixed-step kernel's instructions per step (callgrind), {stamp}; base case "
            "LHHL (simplified couplers), 2 s at dt 1e-4, split by difference between "
            "variants run by the same compiled kernel", rows,
            columns=("part", "instructions per step", "share"),
            result={"runs": runs, "per_stage": per_stage, "fixed_per_step": fixed,
                    "per_vehicle_and_coupler_per_stage": per_vehicle_stage,
                    "per_evaluation_not_per_vehicle": train_stage,
                    "recording_per_step": per_record_step})
    return runs


if __name__ == "__main__":
    main()
