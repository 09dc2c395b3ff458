"""Try ideas for fewer bs23 steps on the heavy-haul trip, against the library's kernel in
the same process.

Each idea is a variant of the adaptive run: tolerances scaled per state kind (applied
to the lowered scenario's ``atol``), and/or other constants of the step-size
controller (a copy of :func:`ltdsim.engine.kernel.run_adaptive` made from its source with the
constants read from an argument, compiled apart, so the library's kernel stays the
reference). Runs the reference and every variant over the first
``--t-end`` seconds of scenarios/heavy-haul.toml in interleaved rounds and reports, per
variant, accepted and rejected steps, the median CPU time (time.process_time: the
machine is shared and loaded, so wall time drifts) and its ratio to the reference's,
and the couplers' peak forces against fixed-step ode3 at 1e-4 s and 5e-5 s (the
accuracy checks of tests/engine/test_heavy_haul.py: peaks averaged over the train within 2 %,
the single largest tension and compression within 2 % plus the spread that halving
the fixed step produces). The fixed-step runs are cached in /tmp (they take minutes).

The atol factors apply on top of the library's own weights (lowering.py: since the
speeds' ``SPEED_SCALE`` of 10, "speed atol x3" means 30 x atol; the tables in
benchmarks/results/try_step_ideas_*.md dated 2026-11-30 were measured before it, with
the speeds at 1 x atol). Writes benchmarks/results/try_step_ideas_<case>_<t>s.md and
.json.

Usage: python benchmarks/try_step_ideas.py [--t-end 600] [--case emergency] [--rounds 3]
                                           [--only NAME ...]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import ltdsim
from ltdsim.engine import kernel

from _results import publish
from profile_steps import patched_run_adaptive, state_labels

HERE = Path(__file__).resolve().parent
HEAVY = HERE.parent / "scenarios" / "heavy-haul.toml"
SIM = sys.modules["ltdsim.results.simulate"]

#: the step-size controller's constants, read from an array by the variant kernel:
#: safety factor, PI exponents alpha and beta (fac = safety err^(-alpha/3)
#: err_prev^(beta/3)), no growth right after a rejection (1) or growth allowed (0),
#: safety factor after a rejection. The library's: (0.9, 0.7, 0.4, 1, 0.9)
LIBRARY = (0.9, 0.7, 0.4, 1.0, 0.9)
#: the ideas: name -> (atol factor per state kind, controller constants or None for the
#: library's kernel itself)
IDEAS: dict[str, tuple[dict[str, float], tuple | None]] = {
    "reference": ({}, None),
    "speeds at 1 x atol (before SPEED_SCALE)": ({"speed": 0.1}, None),
    "controller copy (library constants)": ({}, LIBRARY),
    "gear force atol x3": ({"gear force": 3.0}, None),
    "gear force atol x10": ({"gear force": 10.0}, None),
    "plate displacement atol x10": ({"plate displacement": 10.0}, None),
    "speed atol x3": ({"speed": 3.0}, None),
    "speed atol x10": ({"speed": 10.0}, None),
    "speed atol x30": ({"speed": 30.0}, None),
    "position atol x10": ({"position": 10.0}, None),
    "gear force atol x10, speed atol x3": ({"gear force": 10.0, "speed": 3.0}, None),
    "gear force atol x30": ({"gear force": 30.0}, None),
    "safety 0.8": ({}, (0.8, 0.7, 0.4, 1.0, 0.8)),
    "growth right after rejection": ({}, (0.9, 0.7, 0.4, 0.0, 0.9)),
    "I controller (alpha 1, beta 0)": ({}, (0.9, 1.0, 0.0, 1.0, 0.9)),
    "PI alpha 0.6 beta 0.2": ({}, (0.9, 0.6, 0.2, 1.0, 0.9)),
}

PI_LINE = 'fac = 0.9 * err ** (-0.7 / 3.0) * max(sp["last_error"], 1e-4) ** (0.4 / 3.0)'
EDITS = [
    ("def run_adaptive(y, ctl, stepper, r_start, r_stop, ad, tr, cp, dr, w, out):",
     "def run_adaptive_cfg(y, ctl, stepper, r_start, r_stop, ad, tr, cp, dr, w, out, cfg):"),
    (PI_LINE, 'fac = cfg[0] * err ** (-cfg[1] / 3.0) * max(sp["last_error"], 1e-4) '
              '** (cfg[2] / 3.0)'),
    ('if sp["last_rejected"]:', 'if sp["last_rejected"] and cfg[3] > 0.0:'),
    ("max(0.2, 0.9 * err ** (-1.0 / 3.0))", "max(0.2, cfg[4] * err ** (-1.0 / 3.0))"),
]


def cfg_kernel():
    """``run_adaptive`` with the controller's constants as an argument."""
    return patched_run_adaptive(EDITS, "run_adaptive_cfg")


def variant_kernel(cfg, compiled):
    if cfg is None:
        return kernel.run_adaptive
    arr = np.array(cfg, dtype=float)

    def run_adaptive(*args):
        return compiled(*args, arr)

    return run_adaptive


def run_variant(sc, kinds, scale, kern):
    kinds = np.array(kinds)
    orig_lower, orig_kern = SIM.lower, kernel.run_adaptive

    def lower(s):
        low = orig_lower(s)
        for k, f in scale.items():
            low.atol[kinds == k] *= f
        return low

    SIM.lower = lower
    kernel.run_adaptive = kern
    try:
        t0 = time.process_time()
        ds = ltdsim.simulate(sc)
        cpu = time.process_time() - t0
    finally:
        SIM.lower, kernel.run_adaptive = orig_lower, orig_kern
    return cpu, ds


def fixed_reference(sc, t_end, case, half=True):
    out = {}
    for dt in (1e-4, 5e-5):
        if dt == 5e-5 and not half:
            out[dt] = out[1e-4]  # (the spread from halving the step not measured: 0)
            continue
        path = Path("/tmp") / f"ltdsim_heavy_{case}_fixed_{t_end:g}_{dt:g}.npz"
        if not path.exists():
            print(f"fixed-step ode3 at {dt:g} s over {t_end:g} s (cached in {path}) ...",
                  flush=True)
            ds = ltdsim.simulate(sc.with_overrides({"solver.method": "ode3",
                                                    "solver.dt": dt}))
            np.savez(path, mx=ds.max_coupler_force.values, mn=ds.min_coupler_force.values)
        z = np.load(path)
        out[dt] = (z["mx"], z["mn"])
    return out


def accuracy(ds, ref):
    (mx, mn), (mx2, mn2) = ref[1e-4], ref[5e-5]
    gx, gn = ds.max_coupler_force.values, ds.min_coupler_force.values
    mean_t = gx.mean() / mx.mean() - 1.0
    mean_c = gn.mean() / mn.mean() - 1.0
    top_t = (gx.max() - mx.max()) / abs(mx.max())
    top_c = (gn.min() - mn.min()) / abs(mn.min())
    lim_t = 0.02 + abs(mx2.max() - mx.max()) / abs(mx.max())
    lim_c = 0.02 + abs(mn2.min() - mn.min()) / abs(mn.min())
    ok = abs(mean_t) <= 0.02 and abs(mean_c) <= 0.02 and abs(top_t) <= lim_t \
        and abs(top_c) <= lim_c
    return dict(mean_tension=mean_t, mean_compression=mean_c, top_tension=top_t,
                top_compression=top_c, top_tension_allowed=lim_t,
                top_compression_allowed=lim_c, max_tension_N=float(gx.max()),
                max_compression_N=float(gn.min()), ok=bool(ok))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=600.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--case", default=None, help="a case of the scenario (e.g. emergency)")
    ap.add_argument("--only", action="append", default=None)
    ap.add_argument("--no-half", action="store_true",
                    help="skip fixed-step ode3 at 5e-5 s (the spread is then taken as 0)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    sc = ltdsim.load_scenario(HEAVY, case=args.case).with_overrides(
        {"solver.t_end": args.t_end})
    kinds, _ = state_labels(sc)
    names = ["reference"] + [k for k in IDEAS if k != "reference"
                             and (args.only is None or k in args.only)]
    ref = fixed_reference(sc, args.t_end, args.case or "base", not args.no_half)
    kerns = {}
    compiled = cfg_kernel() if any(IDEAS[k][1] is not None for k in names) else None
    for name in names:
        print(f"compile or load {name} ...", flush=True)
        kerns[name] = variant_kernel(IDEAS[name][1], compiled)
        run_variant(sc.with_overrides({"solver.t_end": 0.5}), kinds, IDEAS[name][0],
                    kerns[name])
    cpu = {k: [] for k in names}
    facts = {}
    for rnd in range(args.rounds):
        for name in names:
            c, ds = run_variant(sc, kinds, IDEAS[name][0], kerns[name])
            cpu[name].append(c)
            facts[name] = dict(steps=int(ds.attrs["steps"]),
                               rejected=int(ds.attrs["rejected_steps"]), **accuracy(ds, ref))
            print(f"round {rnd + 1} {name}: {c:.1f} s CPU, {facts[name]['steps']:,} + "
                  f"{facts[name]['rejected']:,}", flush=True)
    r0 = statistics.median(cpu["reference"])
    rows = []
    for name in names:
        f = facts[name]
        med = statistics.median(cpu[name])
        f["cpu_s"] = cpu[name]
        f["cpu_ratio"] = med / r0
        rows.append((name, f"{f['steps']:,}", f"{f['rejected']:,}", f"{med:.1f}",
                     f"{med / r0:.3f}",
                     f"{f['mean_tension'] * 100:+.2f} / {f['mean_compression'] * 100:+.2f}",
                     f"{f['max_tension_N'] / 1e3:.0f} ({f['top_tension'] * 100:+.1f}, "
                     f"allowed {f['top_tension_allowed'] * 100:.1f})",
                     f"{f['max_compression_N'] / 1e3:.0f} ({f['top_compression'] * 100:+.1f}, "
                     f"allowed {f['top_compression_allowed'] * 100:.1f})",
                     "yes" if f["ok"] else "NO"))
    (mx, mn), (mx2, mn2) = ref[1e-4], ref[5e-5]
    title = (f"bs23 step ideas on the heavy-haul scenario (case {args.case or 'base'}) over "
             f"{args.t_end:g} s, {{stamp}}; "
             f"CPU time (time.process_time) medians of {args.rounds} interleaved rounds; "
             f"fixed-step ode3 peaks: 1e-4 s {mx.max() / 1e3:.0f} / {mn.min() / 1e3:.0f} kN, "
             f"5e-5 s {mx2.max() / 1e3:.0f} / {mn2.min() / 1e3:.0f} kN")
    publish(args.out, f"try_step_ideas_{args.case or 'base'}_{args.t_end:g}s", title, rows,
            columns=("idea", "accepted", "rejected", "CPU s", "CPU / reference",
                     "mean peak tension / compression vs ode3 1e-4, %",
                     "largest tension, kN (vs ode3, %)", "largest compression, kN (vs ode3, %)",
                     "accuracy checks hold"),
            result={"case": args.case, "t_end_s": args.t_end, "ideas": facts})


if __name__ == "__main__":
    main()
