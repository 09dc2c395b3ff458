"""CPU-feature benchmark: ltdsim's kernels compiled with numba's default code for this
CPU (setting A) against the same with every AVX-512 feature switched off (setting B).

Setting B sets ``NUMBA_CPU_FEATURES`` to this host's features as llvmlite reports them
(``llvmlite.binding.get_host_cpu_features()``) with every ``avx512*`` feature turned
to ``-``; the CPU name stays the host's. Each setting gets its own fresh
``NUMBA_CACHE_DIR`` under /tmp: one child process per setting compiles the kernels
first (its CPU seconds are reported), then in each round one child per setting (the
order alternating) loads them from that cache and runs, for each case, one warm-up
``simulate()`` and ``--runs`` timed ones, reporting the CPU time of each
(``time.process_time`` of the child). Per case and round the ratio B / A of the
children's medians; the table gives the median of those ratios. The cases:

  1. the force-mode base train of bench_kernel.py (case LHHL, ``FORCE_PROFILE``,
     ode3 at 1e-4 s, 270 s);
  2. the study case LHHL in speed mode (scenarios/paper.toml, ode3 at 1e-4 s,
     ``--study-seconds``, 270 s by default);
  3. the heavy-haul train (scenarios/heavy-haul.toml, bs23, its first
     ``--heavy-seconds``, 120 s by default).

The coupler forces of A and B (first round) are compared value by value.
Prints a table, also written to benchmarks/results/bench_cpu_features.md and .json.

Usage: python benchmarks/bench_cpu_features.py [--rounds 5] [--runs 2]
       [--study-seconds 270] [--heavy-seconds 120]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import llvmlite.binding as llvm
import numpy as np
from _results import publish

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SRC = ROOT / "src"

CASES = {
    "force": "force-mode base train (LHHL couplers, ode3, dt 1e-4 s, 270 s)",
    "study": "study case LHHL, speed mode (ode3, dt 1e-4 s, {study:g} s)",
    "heavy": "heavy-haul train, bs23, first {heavy:g} s",
}

_CHILD = r"""
import json, sys, time
from pathlib import Path
import numpy as np
sys.path.insert(0, {here!r})
import ltdsim
from bench_kernel import force_case
root = Path({root!r})
mode, study_s, heavy_s, runs, save = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
lhhl = ltdsim.load_scenario(root / "scenarios" / "paper.toml", case="LHHL")
cases = {{
    "force": force_case(lhhl),
    "study": lhhl.with_overrides({{"solver.t_end": study_s}}),
    "heavy": ltdsim.load_scenario(root / "scenarios" / "heavy-haul.toml").with_overrides(
        {{"solver.t_end": heavy_s}}),
}}
out = {{}}
if mode == "compile":
    c0 = time.process_time()
    ltdsim.simulate(cases["study"].with_overrides({{"solver.t_end": 0.01}}))
    c1 = time.process_time()
    ltdsim.simulate(cases["heavy"].with_overrides({{"solver.t_end": 0.5}}))
    c2 = time.process_time()
    out = {{"fixed_step_s": c1 - c0, "adaptive_s": c2 - c1}}
else:
    forces = {{}}
    for name, sc in cases.items():
        ds = ltdsim.simulate(sc)  # warm-up: kernels from the cache, fresh output memory
        forces[name] = ds.coupler_force.values
        cpu = []
        for _ in range(runs):
            c0 = time.process_time()
            ltdsim.simulate(sc)
            cpu.append(time.process_time() - c0)
        out[name] = cpu
        print(f"  {{name}}: {{['%.2f' % c for c in cpu]}} CPU s", file=sys.stderr, flush=True)
    if save:
        np.savez(save, **forces)
import numba.core.config as cfg
out["cpu_features_seen"] = cfg.CPU_FEATURES
print(json.dumps(out))
"""


def features_without_avx512() -> tuple[str, list[str]]:
    """This host's CPU features in ``NUMBA_CPU_FEATURES`` form (``+feat,-feat,...``) with
    every ``avx512*`` feature disabled, and the list of those that were enabled."""
    feats = llvm.get_host_cpu_features()
    dropped = sorted(k for k, on in feats.items() if on and k.startswith("avx512"))
    text = ",".join(("+" if on and not k.startswith("avx512") else "-") + k
                    for k, on in sorted(feats.items()))
    return text, dropped


def _child(setting: dict, args, mode: str, save: str = "") -> dict:
    env = dict(os.environ, PYTHONPATH=str(SRC), NUMBA_CACHE_DIR=setting["cache"])
    env.pop("NUMBA_CPU_FEATURES", None)
    env.pop("NUMBA_CPU_NAME", None)
    if setting["features"]:
        env["NUMBA_CPU_FEATURES"] = setting["features"]
    code = _CHILD.format(here=str(HERE), root=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code, mode, str(args.study_seconds),
                          str(args.heavy_seconds), str(args.runs), save],
                         env=env, stdout=subprocess.PIPE, stderr=None, text=True, check=False)
    if out.returncode != 0:
        raise SystemExit(f"setting {setting['name']} ({mode}) failed, exit {out.returncode}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--runs", type=int, default=2, help="timed runs per case and child")
    ap.add_argument("--study-seconds", type=float, default=270.0, help="simulated s")
    ap.add_argument("--heavy-seconds", type=float, default=120.0, help="simulated s")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    feats, dropped = features_without_avx512()
    work = Path(tempfile.mkdtemp(prefix="ltdsim-bench-cpufeat-"))
    settings = {
        "A": {"name": "A (default)", "features": "", "cache": str(work / "cache-A")},
        "B": {"name": "B (no AVX-512)", "features": feats, "cache": str(work / "cache-B")},
    }
    t_start = time.perf_counter()
    try:
        compile_cpu = {}
        for key, s in settings.items():
            print(f"compiling, setting {s['name']} (fresh cache {s['cache']})",
                  file=sys.stderr, flush=True)
            compile_cpu[key] = _child(s, args, "compile")
            print(f"  fixed-step {compile_cpu[key]['fixed_step_s']:.1f} CPU s, adaptive "
                  f"{compile_cpu[key]['adaptive_s']:.1f} CPU s", file=sys.stderr, flush=True)
        if compile_cpu["B"]["cpu_features_seen"] != feats:
            raise SystemExit("setting B: numba did not take NUMBA_CPU_FEATURES")
        cpu = {k: {c: [] for c in CASES} for k in settings}
        ratios = {c: [] for c in CASES}
        saved = {}
        for r in range(args.rounds):
            order = list(settings) if r % 2 == 0 else list(settings)[::-1]
            for key in order:
                print(f"round {r + 1}/{args.rounds}: setting {settings[key]['name']} "
                      f"({time.perf_counter() - t_start:.0f} s elapsed)", file=sys.stderr,
                      flush=True)
                save = str(work / f"forces-{key}.npz") if r == 0 else ""
                got = _child(settings[key], args, "time", save)
                if save:
                    saved[key] = save
                for c in CASES:
                    cpu[key][c].append(statistics.median(got[c]))
            for c in CASES:
                ratios[c].append(cpu["B"][c][-1] / cpu["A"][c][-1])
        fa, fb = np.load(saved["A"]), np.load(saved["B"])
        diffs = {}
        for c in CASES:
            a, b = fa[c], fb[c]
            diffs[c] = {"values": int(a.size), "max_abs_force_N": float(np.max(np.abs(a))),
                        "max_diff_N": (float(np.max(np.abs(a - b))) if a.shape == b.shape
                                       else float("inf")),
                        "bit_identical": bool(a.shape == b.shape and np.array_equal(a, b))}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    elapsed = time.perf_counter() - t_start

    rows = []
    for c, label in CASES.items():
        label = label.format(study=args.study_seconds, heavy=args.heavy_seconds)
        ma, mb = statistics.median(cpu["A"][c]), statistics.median(cpu["B"][c])
        rq = ratios[c]
        d = diffs[c]
        same = ("0 (bit-identical)" if d["bit_identical"] else f"{d['max_diff_N']:.3g}")
        rows.append((label, f"{ma:.3f}", f"{mb:.3f}",
                     f"{statistics.median(rq):.3f} ({min(rq):.2f}-{max(rq):.2f})",
                     f"{same} ({d['values']:,} values)"))
    rows.append(("cold compile, fixed-step kernel then adaptive, CPU s",
                 f"{compile_cpu['A']['fixed_step_s']:.1f} + {compile_cpu['A']['adaptive_s']:.1f}",
                 f"{compile_cpu['B']['fixed_step_s']:.1f} + {compile_cpu['B']['adaptive_s']:.1f}",
                 "", ""))
    columns = ("case", "A default, CPU s", "B no AVX-512, CPU s",
               "B / A, median of rounds (range)", "largest coupler-force difference A - B, N")
    result = {
        "host_cpu": llvm.get_host_cpu_name(), "avx512_features_disabled": dropped,
        "numba_cpu_features_B": feats, "rounds": args.rounds, "runs_per_child": args.runs,
        "study_seconds": args.study_seconds, "heavy_seconds": args.heavy_seconds,
        "cpu_s": cpu, "ratio_B_over_A_per_round": ratios,
        "ratio_B_over_A_median": {c: statistics.median(v) for c, v in ratios.items()},
        "coupler_force_A_vs_B": diffs, "compile_cpu_s": compile_cpu, "elapsed_wall_s": elapsed,
    }
    publish(args.out, "bench_cpu_features",
            f"numba code with and without AVX-512, {{stamp}}; host CPU "
            f"{llvm.get_host_cpu_name()}, B = NUMBA_CPU_FEATURES with the host's features "
            f"less {len(dropped)} avx512* ones; {args.rounds} interleaved rounds of one child "
            f"process per setting, each a warm-up and {args.runs} timed simulate() per case, "
            "CPU time of the child (time.process_time), its median per case; B / A per "
            "round, median over the rounds; coupler forces of A and B compared from the "
            f"first round; whole benchmark {elapsed / 60:.1f} min wall",
            rows, columns=columns, result=result)
    return result


if __name__ == "__main__":
    main()
