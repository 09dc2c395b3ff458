"""Regression check for kernel refactors: every result variable, bit for bit.

``save OUT.npz`` simulates every shipped scenario and each of its cases for 10 s at the
scenario's own settings, the study case LHHL over its full 270 s, and a few variants
that reach the other code paths (friction-wedge and table gears under ode3, bs23 and
rk4 on the paper train, a controller sampled every 10 steps; the heavy-haul cases bring
bs23 with air brakes and friction gears), and stores every data variable and
coordinate of each result. ``compare OUT.npz`` runs the same list with the code on
``PYTHONPATH`` and reports, per run, whether every array is bitwise equal (NaN equal to
NaN at the same place) and the largest difference where it is not. Exit status 1 when
any data array (variable or coordinate) differs; changed attributes (the scenario's
JSON gaining new default keys, a new attribute) are listed apart and do not fail a
run.

Made for refactors that must not change a single bit (a reordering of floating-point
operations shows up here as differences of a few ulp). The run facts ``wall_time_s``
and ``compile_time_s`` are not compared.

``--fade-rate`` runs every scenario whose couplers are the simplified coupler with
``fade = "rate"``, the reading that was the only one before the key came: with it a
comparison against code from before then checks that nothing else changed.

Usage: python benchmarks/check_bit_identical.py save|compare FILE.npz [--quick]
       [--fade-rate]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import ltdsim

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"
SECONDS = 10.0


def _rate_fade(sc):
    """``sc`` with its default simplified couplers (and any simplified overrides) read
    with the rate fade; other scenarios unchanged."""
    if sc.couplers is None:
        return sc
    keys = {}
    if sc.couplers.default.model == "simplified":
        keys["couplers.default.fade"] = "rate"
    if not keys:
        return sc
    return sc.with_overrides(keys)


def runs(quick: bool = False, fade_rate: bool = False):
    """``(label, scenario)`` for every run of the check."""
    out = []
    for path in sorted(SCEN.glob("*.toml")):
        if "sweep" in path.name:  # a sweep file, not a scenario
            continue
        base = ltdsim.load_scenario(path)
        if fade_rate:
            base = _rate_fade(base)
        names = [None] + sorted(base.cases)
        for case in names:
            sc = base if case is None else base.with_case(case)
            t_end = min(SECONDS, sc.solver.t_end)
            out.append((f"{path.stem}[{case or 'base'}] {t_end:g} s",
                        sc.with_overrides({"solver.t_end": t_end})))
    paper = ltdsim.load_scenario(SCEN / "paper.toml", case="LHHL")
    if fade_rate:
        paper = _rate_fade(paper)
    if not quick:
        out.append(("paper[LHHL] 270 s", paper))
    for preset in ("friction-wedge-high", "mt-2"):
        out.append((f"paper[LHHL] {preset} ode3 2 s", paper.with_overrides(
            {"couplers.default": {"preset": preset}, "solver.t_end": 2.0})))
    out.append(("paper[LHHL] bs23 10 s", paper.with_overrides(
        {"solver.method": "bs23", "solver.t_end": 10.0})))
    out.append(("paper[LHHL] PID sampled every 10 steps 10 s", paper.with_overrides(
        {"driver.pid.ts": 1e-3, "solver.t_end": 10.0})))
    out.append(("paper[LHHL] bs23 PID ts 1e-3 10 s", paper.with_overrides(
        {"solver.method": "bs23", "driver.pid.ts": 1e-3, "solver.t_end": 10.0})))
    out.append(("paper[LHHL] rk4 5 s", paper.with_overrides(
        {"solver.method": "rk4", "solver.t_end": 5.0})))
    return out


def arrays(ds) -> dict[str, np.ndarray]:
    d = {f"var:{k}": np.asarray(v.values) for k, v in ds.data_vars.items()}
    d.update({f"coord:{k}": np.asarray(v.values) for k, v in ds.coords.items()})
    d.update({f"attr:{k}": np.asarray(v) for k, v in ds.attrs.items()
              if k not in ("wall_time_s", "compile_time_s")})
    return d


def same(a: np.ndarray, b: np.ndarray) -> tuple[bool, float]:
    if a.shape != b.shape or a.dtype != b.dtype:
        return False, np.inf
    if a.dtype.kind in "fc":
        a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
        eq = (a.view(np.uint8) == b.view(np.uint8)).all() if a.size else True
        if eq:
            return True, 0.0
        with np.errstate(invalid="ignore"):
            diff = np.abs(a - b)
        return False, float(np.nanmax(diff)) if np.isfinite(diff).any() else np.inf
    return bool(np.array_equal(a, b)), 0.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("save", "compare"))
    ap.add_argument("file", type=Path)
    ap.add_argument("--quick", action="store_true", help="leave out the 270 s run")
    ap.add_argument("--fade-rate", action="store_true",
                    help="simplified couplers with fade = \"rate\" (compare with code "
                         "from before that key)")
    args = ap.parse_args(argv)
    print(f"ltdsim from {Path(ltdsim.__file__).parent}", flush=True)
    ref = dict(np.load(args.file, allow_pickle=False)) if args.mode == "compare" else None
    store, bad = {}, 0
    for label, sc in runs(args.quick, args.fade_rate):
        t0 = time.process_time()
        ds = ltdsim.simulate(sc)
        took = time.process_time() - t0
        arr = {f"{label}|{k}": v for k, v in arrays(ds).items()}
        if ref is None:
            store.update(arr)
            print(f"saved    {label}: {len(arr)} arrays ({took:.1f} s CPU)", flush=True)
            continue
        diffs = []
        for k, v in arr.items():
            if k not in ref:
                diffs.append(f"{k.split('|')[1]} new")
                continue
            ok, dmax = same(v, ref[k])
            if not ok:
                diffs.append(f"{k.split('|')[1]} (max |diff| {dmax:.3g})")
        missing = [k for k in ref if k.startswith(f"{label}|") and k not in arr]
        diffs += [f"{k.split('|')[1]} missing" for k in missing]
        # results are the data (variables, coordinates); attributes (the scenario's JSON
        # with new default keys, a new attribute) are listed apart and do not fail a run
        data = [d for d in diffs if not d.startswith("attr:")]
        attrs = [d for d in diffs if d.startswith("attr:")]
        bad += bool(data)
        verdict = "DIFFERS  " if data else "IDENTICAL"
        print(f"{verdict} {label}: {len(arr)} arrays"
              + ("" if not data else ": " + "; ".join(data))
              + ("" if not attrs else " [attributes changed: " + "; ".join(attrs) + "]")
              + f" ({took:.1f} s CPU)", flush=True)
    if ref is None:
        np.savez_compressed(args.file, **store)
        return 0
    print("all data bit-identical" if not bad else f"{bad} run(s) differ in their data")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
