"""Profile where bs23's step is limited on the heavy-haul trip.

Runs scenarios/heavy-haul.toml with a copy of :func:`ltdsim.engine.kernel.run_adaptive` that
records, for every attempted step, the time (s), the step tried (s), the error norm
(max over the state of |error| / (atol + rtol |y|)), the state element that set that
maximum, and whether the step was accepted and whether it was cut to land on a target
(record, controller sample, brake command). The copy is made from the kernel's own
source (two lines added), so it steps exactly as the library does.

Prints, for the windows asked for (default: the first 600 s, where the train starts
and the slack runs in, and the stop from 10000 s to 10300 s, where dynamic and air
brakes act), which kind of state (vehicle positions, vehicle speeds, gear force
states, wedge-gear plate displacements, traction lags, brake fills) set the error on
accepted and on rejected steps, the couplers and vehicles that set it most often, and
the step sizes by limiting kind (histogram over decades). Writes the tables to
benchmarks/results/profile_steps.md and .json.

Usage: python benchmarks/profile_steps.py [--t-end 600] [--case emergency] [--window 0:600 ...]
                                          [--set solver.rtol=1e-3 ...]
"""

from __future__ import annotations

import argparse
import inspect
import json
import time
from pathlib import Path

import numpy as np
from numba import njit

import ltdsim
from ltdsim.engine import kernel
from ltdsim.engine.couplers import REGISTRY
from ltdsim.results.io import atomic_path

from _results import machine

HERE = Path(__file__).resolve().parent
HEAVY = HERE.parent / "scenarios" / "heavy-haul.toml"
COLS = 5  # t, h_try, err, q, flags (1 accepted, 2 hit a target)


def patched_run_adaptive(edits, name):
    """``kernel.run_adaptive`` compiled from its own source with ``edits`` applied (pairs
    of old and new text, each old text found exactly once); ``name`` is the function the
    edited source defines."""
    src = inspect.getsource(kernel.run_adaptive.py_func)
    src = src[src.index("def run_adaptive"):]
    for old, new in edits:
        assert src.count(old) == 1, old
        src = src.replace(old, new)
    ns = dict(vars(kernel))
    exec(compile(src, kernel.__file__, "exec"), ns)
    return njit(_nrt=False)(ns[name])


def _profiling_kernel():
    """``run_adaptive`` with a step log: the same source plus the log's writes."""
    edits = [
        ("def run_adaptive(y, ctl, stepper, r_start, r_stop, ad, tr, cp, dr, w, out):",
         "def run_adaptive_prof(y, ctl, stepper, r_start, r_stop, ad, tr, cp, dr, w, out, "
         "log, count):"),
        ("        err = np.inf\n        if total", "        err = np.inf\n        qmax = -1\n        if total"),
        ("                e = abs(e) / sc\n                if e > err:\n                    err = e\n",
         "                e = abs(e) / sc\n                if e > err:\n                    err = e\n"
         "                    qmax = q\n"),
        # (the gears' internal forces and plates, whose errors run_adaptive takes apart)
        ("abs(ynew[q])))\n                if e > err:\n                    err = e\n",
         "abs(ynew[q])))\n                if e > err:\n                    err = e\n"
         "                    qmax = q\n"),
        # (a gear's plates, whose error run_adaptive takes with its internal force's)
        ("                    if e > err:\n                        err = e\n",
         "                    if e > err:\n                        err = e\n"
         "                        qmax = qp\n"),
        ("        if err <= 1.0:\n            t = t_new\n",
         "        i_log = count[0]\n"
         "        if i_log < log.shape[0]:\n"
         "            log[i_log, 0] = t\n            log[i_log, 1] = h_try\n"
         "            log[i_log, 2] = err\n            log[i_log, 3] = qmax\n"
         "            log[i_log, 4] = (1.0 if err <= 1.0 else 0.0) + (2.0 if hit else 0.0)\n"
         "        count[0] += 1\n"
         "        if err <= 1.0:\n            t = t_new\n"),
    ]
    return patched_run_adaptive(edits, "run_adaptive_prof")


def state_labels(sc) -> tuple[list[str], list[str]]:
    """Per state element of ``sc``'s bs23 run: its kind and the coupler or vehicle it
    belongs to (counted from 1)."""
    n = sc.n_vehicles
    kinds = ["position"] * n + ["speed"] * n
    owner = [f"vehicle {i + 1}" for i in range(n)] * 2
    names = {"force": "gear force", "x": "plate displacement", "v": "plate speed"}
    for j in range(n - 1):
        c = sc.coupler(j)
        for s in REGISTRY[c.model].states(c):
            kinds.append(names[s])
            owner.append(f"coupler {j + 1}")
    for k, loco in enumerate(sc.consists()):
        tau = loco.time_constant if loco.time_constant is not None else \
            sc.traction.time_constant
        if tau > 0.0:
            kinds.append("traction lag")
            owner.append(f"consist {k + 1}")
    for i, v in enumerate(sc.vehicles):
        if v.brake is not None:
            kinds.append("brake fill")
            owner.append(f"vehicle {i + 1}")
    return kinds, owner


def profile(sc, max_log: int):
    """Run ``sc`` with the logging kernel: ``(log, result, cpu_s)``."""
    prof = _profiling_kernel()
    log = np.zeros((max_log, COLS))
    count = np.zeros(1, dtype=np.int64)
    orig = kernel.run_adaptive

    def logged(*args):
        return prof(*args, log, count)

    kernel.run_adaptive = logged
    try:
        ltdsim.simulate(sc.with_overrides({"solver.t_end": 1.0}))  # compile the copy
        count[0] = 0
        t0 = time.process_time()
        ds = ltdsim.simulate(sc)
        cpu = time.process_time() - t0
    finally:
        kernel.run_adaptive = orig
    if count[0] > max_log:
        raise SystemExit(f"--max-log {max_log} too small for {count[0]} steps")
    return log[:count[0]].copy(), ds, cpu


EDGES = np.array([1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1])


def window_tables(log, kinds, owner, t0, t1):
    """Tables for the steps that start in ``[t0, t1)``."""
    kinds = np.array(kinds)
    owner = np.array(owner)
    sel = (log[:, 0] >= t0) & (log[:, 0] < t1) & (log[:, 3] >= 0)
    lg = log[sel]
    acc = (lg[:, 4].astype(int) & 1) == 1
    hit = (lg[:, 4].astype(int) & 2) == 2
    q = lg[:, 3].astype(int)
    k = kinds[q]
    out = {"window_s": [t0, t1], "accepted": int(acc.sum()), "rejected": int((~acc).sum()),
           "hit_target": int((acc & hit).sum())}
    by_kind = {}
    for name in dict.fromkeys(kinds):
        a = acc & (k == name)
        r = ~acc & (k == name)
        if not (a.any() or r.any()):
            continue
        free = a & ~hit
        by_kind[name] = {
            "accepted": int(a.sum()), "rejected": int(r.sum()),
            "accepted_free": int(free.sum()),
            "median_h_ms": float(np.median(lg[free, 1]) * 1e3) if free.any() else float("nan"),
            "hist_h": np.histogram(lg[free, 1], bins=EDGES)[0].tolist(),
        }
    out["by_kind"] = by_kind
    # which couplers / vehicles set it most often (accepted, rejected)
    for label, m in (("top_accepted", acc & ~hit), ("top_rejected", ~acc)):
        keys, counts = np.unique(np.char.add(np.char.add(k[m], " @ "), owner[q[m]]),
                                 return_counts=True)
        order = np.argsort(-counts)[:12]
        out[label] = [[str(keys[i]), int(counts[i])] for i in order]
    # where along the train (coupler/vehicle number) the rejections fall, by tenths
    idx = np.array([int(o.split()[-1]) for o in owner[q[~acc]]]) if (~acc).any() else np.zeros(0)
    out["rejected_along_train"] = np.histogram(idx, bins=np.linspace(1, 215, 11))[0].tolist()
    return out


def render(res) -> list[str]:
    lines = []
    for w in res["windows"]:
        t0, t1 = w["window_s"]
        lines += [f"### steps starting in {t0:g}-{t1:g} s: {w['accepted']:,} accepted "
                  f"({w['hit_target']:,} cut to land on a record, sample or command), "
                  f"{w['rejected']:,} rejected", "",
                  "| state kind setting the error max | accepted | rejected | accepted, "
                  "not cut: median step, ms | its steps in [1e-6,1e-5,1e-4,1e-3,1e-2,1e-1] s |",
                  "|---|---|---|---|---|"]
        for name, d in w["by_kind"].items():
            lines.append(f"| {name} | {d['accepted']:,} | {d['rejected']:,} | "
                         f"{d['median_h_ms']:.3f} | {' / '.join(f'{x:,}' for x in d['hist_h'])} |")
        lines += ["", "most frequent (kind @ owner) on accepted steps not cut to a target: "
                  + "; ".join(f"{a} {b:,}" for a, b in w["top_accepted"]),
                  "", "most frequent on rejected steps: "
                  + "; ".join(f"{a} {b:,}" for a, b in w["top_rejected"]),
                  "", "rejected steps along the train (owner number 1-214 in tenths): "
                  + " / ".join(str(x) for x in w["rejected_along_train"]), ""]
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=600.0, help="simulated time, s")
    ap.add_argument("--window", action="append", default=None,
                    help="T0:T1 in s (repeatable); default 0:600 and 10000:10300")
    ap.add_argument("--case", default=None, help="a case of the scenario (e.g. emergency)")
    ap.add_argument("--set", action="append", default=[], help="scenario override key=value")
    ap.add_argument("--max-log", type=int, default=8_000_000)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--name", default="profile_steps")
    args = ap.parse_args(argv)
    sc = ltdsim.load_scenario(HEAVY, case=args.case)
    over = {"solver.t_end": args.t_end}
    for kv in args.set:
        key, val = kv.split("=", 1)
        over[key] = json.loads(val)
    sc = sc.with_overrides(over)
    kinds, owner = state_labels(sc)
    log, ds, cpu = profile(sc, args.max_log)
    assert int(log[:, 3].max()) < len(kinds)
    wins = args.window or ["0:600", "10000:10300"]
    res = {"case": args.case, "t_end_s": args.t_end, "overrides": over, "cpu_s": cpu,
           "steps": int(ds.attrs["steps"]), "rejected": int(ds.attrs["rejected_steps"]),
           "max_tension_N": float(ds.max_coupler_force.max()),
           "max_compression_N": float(ds.min_coupler_force.min()),
           "windows": []}
    for wdef in wins:
        t0, t1 = (float(x) for x in wdef.split(":"))
        if t0 < args.t_end:
            res["windows"].append(window_tables(log, kinds, owner, t0, min(t1, args.t_end)))
    head = (f"bs23 step profile of the heavy-haul scenario (case {args.case or 'base'}) "
            f"over {args.t_end:g} s "
            f"(overrides {over}): {res['steps']:,} accepted, {res['rejected']:,} rejected, "
            f"CPU {cpu:.1f} s (time.process_time, logging kernel); peaks "
            f"{res['max_tension_N'] / 1e3:.0f} kN / {res['max_compression_N'] / 1e3:.0f} kN")
    lines = [head, ""] + render(res)
    print("\n".join(lines))
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / f"{args.name}.md") as tmp:
        tmp.write_text(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} ({machine()})\n\n"
                       + "\n".join(lines) + "\n")
    with atomic_path(args.out / f"{args.name}.json") as tmp:
        tmp.write_text(json.dumps(res, indent=1))
    np.save(Path("/tmp") / f"{args.name}_log.npy", log)
    return res


if __name__ == "__main__":
    main()
