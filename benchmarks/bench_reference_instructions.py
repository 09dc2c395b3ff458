"""Instructions of the whole ``simulate()`` against the hand-written reference kernel.

The CPU seconds of bench_kernel.py move with the load of this shared machine; the
instructions executed do not. This runs the force-mode case of bench_kernel.py (the
base train, simplified couplers, ode3 at 1e-4 s, coupler forces at 1 ms) over
``--seconds`` of simulated time, once through ``ltdsim.simulate()`` (recording the
coupler forces only, ``solver.record``, as the reference does) and once through
benchmarks/reference_kernel.py, in one process under valgrind's callgrind with
instrumentation on only around each call, and splits each count into the compiled
kernel (numba's ``call_cfunc``), numba's typing of the arguments at each call
(``Dispatcher_call`` less the kernel) and the Python around them (lowering, buffers,
the xarray result; the reference's reading of the scenario).

valgrind does not run AVX-512 code, which numba would generate for this machine, and
under valgrind numba would see another CPU and compile again (for minutes). So both
kernels are compiled for one fixed CPU (``NUMBA_CPU_NAME=haswell``, AVX2, and a fixed
feature list) into a fresh cache folder by a run outside valgrind, and valgrind's run
loads them from there. The counts are for that code, not for the AVX-512 code the
ordinary runs execute: a ratio, not a time.

Writes benchmarks/results/bench_reference_instructions.md and .json.

Usage: python benchmarks/bench_reference_instructions.py [--seconds 1.0]
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

from _results import publish

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CPU = "haswell"
#: features of the host that valgrind 3.19 cannot run or that haswell lacks (prefixes)
_DROP = ("avx512", "amx", "avx10", "avxvnni", "avxifma", "avxneconvert", "vaes",
         "vpclmulqdq", "gfni", "sha", "shstk", "serialize", "tsxldtrk", "cldemote", "movdir",
         "wbnoinvd", "clwb", "clflushopt", "rdpid", "pku", "adx", "rdseed", "xsavec",
         "xsaves", "prfchw", "invpcid", "fsgsbase", "enqcmd", "uintr", "usermsr", "waitpkg",
         "widekl", "kl", "hreset", "ptwrite", "pconfig", "sgx", "raoint", "cmpccxadd",
         "prefetchi", "sm3", "sm4", "sha512", "egpr", "ndd", "ccmp", "cf", "nf", "ppx",
         "push2pop2", "zu", "movrs")

_CHILD = r"""
import os, subprocess, sys
sys.path.insert(0, sys.argv[1])
import ltdsim, reference_kernel
from bench_kernel import force_case, forces_only
# (simulate() records the coupler forces only, as the reference kernel does)
sc = forces_only(force_case(ltdsim.load_scenario(sys.argv[2], case="LHHL"))).with_overrides(
    {"solver.t_end": float(sys.argv[3])})
ltdsim.simulate(sc)  # load both kernels, warm
reference_kernel.simulate(sc)
if len(sys.argv) > 4:
    pid = str(os.getpid())
    def control(*a):
        subprocess.run(["callgrind_control", *a, pid], check=True, capture_output=True)
    for name, run in (("simulate", ltdsim.simulate), ("reference", reference_kernel.simulate)):
        control("-i", "on")
        run(sc)
        control("-i", "off")
        control("-d", name)
"""


def _features() -> str:
    import llvmlite.binding as ll

    return ",".join(("+" if on and not k.startswith(_DROP) else "-") + k
                    for k, on in sorted(ll.get_host_cpu_features().items()))


def _inclusive(path: Path, function: str) -> int:
    """Inclusive instructions of the first function whose name contains ``function``."""
    out = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100",
                          str(path)], capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        if function in line:
            return int(line.split()[0].replace(",", ""))
    return 0


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated time, s")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind is not installed")
    work = Path(tempfile.mkdtemp(prefix="ltdsim-ref-instructions-"))
    env = dict(os.environ, NUMBA_CPU_NAME=CPU, NUMBA_CPU_FEATURES=_features(),
               NUMBA_CACHE_DIR=str(work / "cache"))
    child = [sys.executable, "-c", _CHILD, str(HERE), str(ROOT / "scenarios" / "paper.toml"),
             str(args.seconds)]
    try:
        print(f"compiling both kernels for {CPU} (minutes on a cold cache)", file=sys.stderr,
              flush=True)
        subprocess.run(child, env=env, check=True, cwd=work)
        print("counting under callgrind (minutes)", file=sys.stderr, flush=True)
        out = work / "cg.out"
        proc = subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no",
                               f"--callgrind-out-file={out}", *child, "count"],
                              env=env, cwd=work, capture_output=True, text=True)
        if proc.returncode != 0:
            raise SystemExit(f"callgrind run failed:\n{proc.stderr[-3000:]}")
        counts = {}
        for part, name in ((1, "simulate"), (2, "reference")):
            path = Path(f"{out}.{part}")
            total = int(re.search(r"^totals: (\d+)", path.read_text(), re.M).group(1))
            dispatch = _inclusive(path, "Dispatcher_call")
            kernel = _inclusive(path, "call_cfunc")
            counts[name] = {"total": total, "kernel": kernel, "typing": dispatch - kernel,
                            "python": total - dispatch}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    s, r = counts["simulate"], counts["reference"]
    steps = round(args.seconds / 1e-4)
    rows = [
        ("whole call, instructions", f"{s['total'] / 1e6:.1f} M", f"{r['total'] / 1e6:.1f} M",
         f"{s['total'] / r['total']:.3f}"),
        ("of which compiled kernel", f"{s['kernel'] / 1e6:.1f} M", f"{r['kernel'] / 1e6:.1f} M",
         f"{s['kernel'] / r['kernel']:.3f}"),
        ("of which numba's typing of the arguments", f"{s['typing'] / 1e6:.2f} M",
         f"{r['typing'] / 1e6:.2f} M", ""),
        ("of which Python (lowering, buffers, result)", f"{s['python'] / 1e6:.1f} M",
         f"{r['python'] / 1e6:.1f} M", ""),
        ("compiled kernel, instructions per step", f"{s['kernel'] / steps:.0f}",
         f"{r['kernel'] / steps:.0f}", f"{s['kernel'] / r['kernel']:.3f}"),
    ]
    publish(args.out, "bench_reference_instructions",
            f"simulate() against the hand-written reference kernel in instructions "
            f"(callgrind, kernels compiled for {CPU}), {{stamp}}; force-mode base train, "
            f"{args.seconds:g} s at dt 1e-4 with ode3", rows,
            columns=("quantity", "simulate()", "reference kernel", "simulate / reference"),
            result={"seconds": args.seconds, "cpu": CPU, "instructions": counts})
    return counts


if __name__ == "__main__":
    main()
