"""Prototype: a kernel taking named structures against the same kernel taking positional
arrays (issue 14, point 1: measure before converting ltdsim.engine.kernel).

Two versions of one small train kernel, written with the same arithmetic in the same
order: a chain of vehicles with Davis resistance, a grade table, nonlinear couplers with
slack and damping, a sampled PI speed controller, Runge-Kutta stages from a tableau,
records and peak forces; the right-hand side and the recorder are compiled once and
inlined by LLVM (``forceinline=True``) and the kernels compiled without NRT, as in
ltdsim.engine.kernel.

* positional: 22 positional arguments; controller state a float vector read by index
  constants, the signal vector by literal index;
* named: the tableau, train, driver, work buffers and outputs each a ``namedtuple`` of
  arrays; controller state and signals as fields of numpy structured (record) arrays
  (``st.adem``, ``sig.traction``).

Measured, each in the order given:
1. compile from an empty numba cache, each version in its own child process with its
   own fresh ``NUMBA_CACHE_DIR``: the child's CPU time (``resource.getrusage``) for the
   first call, and that a second child loads it from the cache (numba's cache hits);
2. warm run time, in this process: interleaved rounds (positional, named, named,
   positional, ...), CPU time of each call (``time.process_time``, which load on the
   other core does not add to), medians and the median of the per-round ratios;
3. that both versions give bitwise identical records;
4. the instructions each version executes for a run (valgrind's callgrind, inside
   numba's dispatcher call only), which load does not move. Under valgrind numba sees
   another CPU and compiles afresh, so this part takes minutes.

Writes benchmarks/results/bench_named_structs.md and .json.

Usage: python benchmarks/bench_named_structs.py [--rounds 15] [--steps 200000]
       [--callgrind-steps 20000]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _named_structs_proto import CALLS, KERNELS, call_named, call_pos, case

HERE = Path(__file__).resolve().parent


def _timing(rounds: int, steps: int) -> None:
    """Child process: warm CPU time of each version over interleaved rounds, and whether
    both give identical results; printed as JSON."""
    c = case(steps)
    for f in CALLS.values():
        f(c, steps=10)  # compile
    cpu = {k: [] for k in CALLS}
    for rnd in range(rounds):
        order = list(CALLS) if rnd % 2 == 0 else list(CALLS)[::-1]
        for which in order:
            t0 = time.process_time()
            CALLS[which](c)
            cpu[which].append(time.process_time() - t0)
    yp, op = call_pos(c)
    yn, on = call_named(c)
    identical = all(np.array_equal(a, b) for a, b in zip((yp, *op), (yn, *on)))
    print(json.dumps({"cpu": cpu, "identical": identical}))


def _count_child(which: str, steps: int) -> None:
    """Child process under callgrind: compile, then one run of ``steps`` steps."""
    c = case(steps)
    CALLS[which](c, steps=10)
    CALLS[which](c)


def _instructions(which: str, steps: int, tmp: str) -> int:
    """Instructions one version executes inside numba's dispatcher call (``call_cfunc``:
    the compiled kernel and its argument unboxing), counted by callgrind; compiling is
    Python code outside it and not counted."""
    out = os.path.join(tmp, f"callgrind-{which}.out")
    env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, f"vg-{which}"))
    subprocess.run(["valgrind", "--tool=callgrind", "--toggle-collect=*call_cfunc*",
                    f"--callgrind-out-file={out}", sys.executable, __file__, "--child",
                    "count", "--which", which, "--steps", str(steps)],
                   env=env, capture_output=True, text=True, check=True)
    with open(out) as fh:
        for line in fh:
            if line.startswith("totals:"):
                return int(line.split()[1])
    raise RuntimeError(f"no totals in {out}")


def _child(which: str) -> None:
    """Child process: first call of one version; print its CPU time and cache hits."""
    c = case(10)
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    CALLS[which](c)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
    hits = sum(KERNELS[which].stats.cache_hits.values())
    print(json.dumps({"cpu": cpu, "wall": wall, "hits": hits}))


def _first_call(which: str, cache: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    proc = subprocess.run([sys.executable, __file__, "--child", which], env=env,
                          capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--compiles", type=int, default=3, help="cold compiles per version")
    ap.add_argument("--child")
    ap.add_argument("--which")
    ap.add_argument("--callgrind-steps", type=int, default=20_000,
                    help="steps of the callgrind count (0: no count)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    if args.child == "count":
        return _count_child(args.which, args.steps)
    if args.child == "time":
        return _timing(args.rounds, args.steps)
    if args.child:
        return _child(args.child)
    from _results import publish

    # 1. cold compiles (fresh cache each), then a load from that cache, interleaved
    cold = {k: [] for k in CALLS}
    load = {k: [] for k in CALLS}
    hits = {k: [] for k in CALLS}
    with tempfile.TemporaryDirectory(prefix="bench-named-") as tmp:
        for rnd in range(args.compiles):
            order = list(CALLS) if rnd % 2 == 0 else list(CALLS)[::-1]
            for which in order:
                cache = os.path.join(tmp, f"{which}-{rnd}")
                first = _first_call(which, cache)
                second = _first_call(which, cache)
                cold[which].append(first["cpu"])
                load[which].append(second["cpu"])
                hits[which].append((first["hits"], second["hits"]))
                print(f"compile round {rnd}: {which}: cold {first['cpu']:.2f} s CPU, "
                      f"cached {second['cpu']:.2f} s CPU, cache hits {first['hits']} then "
                      f"{second['hits']}", flush=True)
        # 2. warm timing and 3. identity, in a child with its own cache
        env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "timing"))
        proc = subprocess.run([sys.executable, __file__, "--child", "time", "--rounds",
                               str(args.rounds), "--steps", str(args.steps)], env=env,
                              capture_output=True, text=True, check=True)
        timing = json.loads(proc.stdout.strip().splitlines()[-1])
        # 4. instructions (callgrind), both versions at once on the two cores
        counts = {}
        if args.callgrind_steps:
            import concurrent.futures as cf

            with cf.ThreadPoolExecutor(2) as ex:
                futs = {k: ex.submit(_instructions, k, args.callgrind_steps, tmp)
                        for k in CALLS}
                counts = {k: f.result() for k, f in futs.items()}
    cpu, identical = timing["cpu"], timing["identical"]
    c = case(10)
    med = {k: statistics.median(v) for k, v in cpu.items()}
    per_round = [n / p for n, p in zip(cpu["named"], cpu["positional"])]
    ratio = statistics.median(per_round)
    vsteps = c["n"] * args.steps
    rows = [
        ("warm run, positional: CPU s per run (median)", f"{med['positional']:.4f}"),
        ("warm run, named: CPU s per run (median)", f"{med['named']:.4f}"),
        ("ratio named / positional, median of per-round ratios", f"{ratio:.3f}"),
        ("ratio named / positional, per-round range",
         f"{min(per_round):.3f} to {max(per_round):.3f}"),
        ("vehicle-steps per CPU second, positional / named",
         f"{vsteps / med['positional'] / 1e6:.1f} M / {vsteps / med['named'] / 1e6:.1f} M"),
        *([("instructions per step, positional / named (callgrind, "
            f"{args.callgrind_steps} steps)",
            f"{counts['positional'] / args.callgrind_steps:.0f} / "
            f"{counts['named'] / args.callgrind_steps:.0f}"),
           ("ratio of instructions named / positional",
            f"{counts['named'] / counts['positional']:.4f}")] if counts else []),
        ("cold compile, positional: CPU s (median)", f"{statistics.median(cold['positional']):.2f}"),
        ("cold compile, named: CPU s (median)", f"{statistics.median(cold['named']):.2f}"),
        ("load from numba's cache, positional: CPU s (median)",
         f"{statistics.median(load['positional']):.2f}"),
        ("load from numba's cache, named: CPU s (median)",
         f"{statistics.median(load['named']):.2f}"),
        ("named kernel served from the cache in a new process (cache hits > 0)",
         "yes" if all(h[1] > 0 for h in hits["named"]) else "NO"),
        ("records and final state bitwise identical", "yes" if identical else "NO"),
    ]
    result = {"rounds": args.rounds, "steps": args.steps, "vehicles": c["n"],
              "cpu_s": cpu, "ratio_median": ratio, "cold_compile_cpu_s": cold,
              "cache_load_cpu_s": load, "cache_hits": hits, "identical": identical,
              "callgrind_steps": args.callgrind_steps, "instructions": counts}
    publish(args.out, "bench_named_structs",
            f"Named structures across the compiled boundary, prototype, {{stamp}}; ode3, "
            f"{c['n']} vehicles, {args.steps} steps per run, {args.rounds} interleaved "
            f"rounds (CPU time, time.process_time), {args.compiles} cold compiles per "
            "version (child CPU time, fresh NUMBA_CACHE_DIR each)", rows, result=result)
    return result


if __name__ == "__main__":
    main()
