"""Do friction-gear results converge as the step halves? (issue 14, point 6)

The gears' relaxation time ``tracking_time`` is a property of the gear (default 0.4 ms,
docs/draftgear.md), no longer four solver steps, so halving ``solver.dt`` changes only the
integration error. This script measures that error, and how much the time constant
itself moves the results:

1. The study train (scenarios/paper.toml, base case) with the high friction gear
   (preset ``friction-wedge-high``) over its first 30 s, ode3 at dt = 2e-4, 1e-4, 5e-5,
   2.5e-5 and 1.25e-5 s: every coupler's largest tension and compression over every step
   (``max_coupler_force``, ``min_coupler_force``), the differences between successive
   steps and the observed order ``log2(diff1 / diff2)``; bs23 at its default tolerance
   against the finest fixed step. The speed controller is sampled every 2e-4 s in every
   run (the study's 1e-4 s is not a multiple of the coarsest step), so the discrete
   controller is the same model at every step.
2. Why the train's peaks do not converge at the method's order: how often each coupling
   leaves and re-enters its slack (its force steps between 0 and the gear's release
   force, about 99 kN for the high set, at each contact).
3. A case without slack crossings during the measurement, two 90 t wagons meeting at
   1.5 m/s through one gear (``ltdsim.analysis.gears.impact``), with ode3 from 4e-4 to 6.25e-6 s:
   the friction gear and, as a control, an undamped linear coupler (a smooth problem,
   where ode3 shows its third order).
4. The time constant itself: the impact and the train's largest tension for
   tracking_time from 5e-5 to 2e-3 s at a step far below each.

Usage: python benchmarks/study_dt_convergence.py [--out benchmarks/results]
Writes study_dt_convergence.md and .json there (tables also printed).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import machine  # noqa: E402

import ltdsim  # noqa: E402
from ltdsim.analysis.gears import impact  # noqa: E402
from ltdsim.results.io import atomic_path  # noqa: E402
from ltdsim.scenario import CouplerParams  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
STEPS = (2e-4, 1e-4, 5e-5, 2.5e-5, 1.25e-5)  # s, ode3
T_END = 30.0  # s
PID_TS = 2e-4  # s, the controller's sample time in every run (a multiple of every step)
IMPACT_STEPS = (4e-4, 2e-4, 1e-4, 5e-5, 2.5e-5, 1.25e-5, 6.25e-6)  # s
TAUS = (5e-5, 1e-4, 2e-4, 4e-4, 1e-3, 2e-3)  # s


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def train(overrides: dict):
    base = ltdsim.load_scenario(ROOT / "scenarios" / "paper.toml")
    ov = {"couplers.default": {"preset": "friction-wedge-high"}, "solver.t_end": T_END,
          "solver.output_interval": 1e-3, "driver.pid.ts": PID_TS}
    ov.update(overrides)
    sc = base.with_overrides(ov)
    t0 = time.process_time()
    ds = ltdsim.simulate(sc)
    return ds, time.process_time() - t0


def orders(values):
    """Successive differences and observed orders log2(d_k / d_k+1) of a sequence."""
    d = np.abs(np.diff(np.asarray(values, dtype=float)))
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.log2(d[:-1] / d[1:])
    return d, p


def fmt_order(p):
    return "n/a" if not np.isfinite(p) else f"{p:.2f}"


def table(head, columns, rows):
    lines = [head, "", "| " + " | ".join(columns) + " |",
             "|" + "|".join("-" * (len(c) + 2) for c in columns) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def slack_entries(force, t, windows):
    """Per coupler and time window: how often the force falls to 0 (the coupling
    enters its slack) from a nonzero value, on the recorded samples."""
    free = force == 0.0
    enter = free[1:] & ~free[:-1]
    out = []
    for a, b in windows:
        k = (t[1:] > a) & (t[1:] <= b)
        out.append(enter[k].sum(axis=0))
    return np.array(out)  # window x coupler


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = ap.parse_args()
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    result: dict = {"timestamp": stamp, "machine": machine()}
    parts = [f"# Friction-gear convergence as the step halves, {stamp} ({machine()})", "",
             "Produced by benchmarks/study_dt_convergence.py (see its docstring); forces in "
             "kN, differences in N, CPU time of this process (time.process_time); "
             "order a/b/c = log2(|q(a) - q(b)| / |q(b) - q(c)|), the observed order of the "
             "method over the steps a, b = a/2, c = a/4 (3 for ode3 on a smooth problem)."]

    # 1. the study train
    runs = {}
    for dt in STEPS:
        log(f"train, ode3 dt = {dt:g} s ...")
        runs[dt], cpu = train({"solver.method": "ode3", "solver.dt": dt})
        log(f"  done in {cpu:.1f} s CPU")
    log("train, bs23 at its default tolerance ...")
    bs23, cpu_bs = train({"solver.method": "bs23", "solver.dt": 1e-4})
    ref = runs[STEPS[-1]]
    nc = ref.sizes["coupler"]
    rows, res_train = [], []
    cols = (["quantity"] + [f"dt {dt:g} s" for dt in STEPS]
            + [f"diff {STEPS[k]:g}-{STEPS[k + 1]:g}" for k in range(len(STEPS) - 1)]
            + [f"order {STEPS[k]:g}/{STEPS[k + 1]:g}/{STEPS[k + 2]:g}"
               for k in range(len(STEPS) - 2)]
            + ["bs23 - finest [N]"])
    quantities = []
    for j in range(nc):
        quantities.append((f"coupler {j + 1} max tension",
                           lambda ds, j=j: float(ds.max_coupler_force.values[j])))
    for j in range(nc):
        quantities.append((f"coupler {j + 1} max compression",
                           lambda ds, j=j: 0.0 - float(ds.min_coupler_force.values[j])))
    quantities.append(("train's largest tension",
                       lambda ds: float(ds.max_coupler_force.values.max())))
    quantities.append(("train's largest compression",
                       lambda ds: 0.0 - float(ds.min_coupler_force.values.min())))
    for name, get in quantities:
        vals = [get(runs[dt]) for dt in STEPS]
        d, p = orders(vals)
        rows.append([name] + [f"{v / 1e3:.3f}" for v in vals] + [f"{x:.1f}" for x in d]
                    + [fmt_order(x) for x in p] + [f"{get(bs23) - vals[-1]:+.1f}"])
        res_train.append({"quantity": name, "values_N": vals, "diffs_N": d.tolist(),
                          "orders": [None if not np.isfinite(x) else float(x) for x in p],
                          "bs23_N": get(bs23)})
    result["train"] = {"steps_s": list(STEPS), "pid_ts_s": PID_TS, "t_end_s": T_END,
                       "bs23_steps": int(bs23.attrs.get("steps", -1)),
                       "bs23_cpu_s": cpu_bs, "rows": res_train}
    parts += ["", table(
        f"## 1. Study train (paper.toml base case, friction-wedge-high, first {T_END:g} s), "
        f"ode3; peaks over every step, kN; controller sampled every {PID_TS:g} s",
        cols, rows)]
    parts.append(f"\nbs23 at its default tolerance took {bs23.attrs.get('steps', '?')} steps "
                 f"({cpu_bs:.1f} s CPU).")
    # pointwise histories: how far apart the runs are over time
    f = {dt: runs[dt].coupler_force.values for dt in STEPS}
    t = ref.time.values
    hist_rows = []
    for a, b in zip(STEPS, STEPS[1:]):
        dd = np.abs(f[a] - f[b])
        first = t[np.argmax(dd.max(axis=1) > 1e3)] if (dd > 1e3).any() else math.nan
        hist_rows.append([f"{a:g} vs {b:g}", f"{dd.max() / 1e3:.1f}",
                          f"{np.sqrt((dd ** 2).mean()) / 1e3:.2f}", f"{first:.3f}"])
    parts += ["", table("Coupler force histories (1 ms samples) between successive steps",
                        ["steps [s]", "max |diff| [kN]", "RMS diff [kN]",
                         "first time a coupler differs by > 1 kN [s]"], hist_rows)]

    # 2. slack crossings
    windows = ((0.0, 5.0), (5.0, 25.0), (25.0, T_END))
    ent = slack_entries(runs[1e-4].coupler_force.values, t, windows)
    rows = [[f"{a:g}-{b:g}"] + [str(int(x)) for x in ent[w]]
            for w, (a, b) in enumerate(windows)]
    parts += ["", table("## 2. Entries into the slack per coupler (force falling to 0 on the "
                        "1 ms samples), ode3 dt = 1e-4 s",
                        ["window [s]"] + [f"c{j + 1}" for j in range(nc)], rows)]
    result["slack_entries"] = {"windows_s": windows, "counts": ent.tolist()}

    # 3. two-wagon impact
    cases = {"friction-wedge-high": CouplerParams(preset="friction-wedge-high"),
             "linear, undamped (control)": CouplerParams(model="linear", stiffness=4e7,
                                                         damping=0.0, slack=0.025)}
    rows, res_imp = [], []
    for label, c in cases.items():
        vals = {"peak force": [], "kinetic energy lost": [], "v(0.05 s) moving wagon": []}
        for dt in IMPACT_STEPS:
            log(f"impact {label}, ode3 dt = {dt:g} s ...")
            r = impact(c, 1.5, dt=dt, t_max=1.0)
            ds = r["dataset"]
            k = int(round(0.05 / dt))
            vals["peak force"].append(r["peak_force_N"])
            vals["kinetic energy lost"].append(r["kinetic_energy_lost_J"])
            vals["v(0.05 s) moving wagon"].append(float(ds.velocity.values[k, 1]))
        for q, v in vals.items():
            d, p = orders(v)
            unit = {"peak force": "N", "kinetic energy lost": "J"}.get(q, "m/s")
            rows.append([label, f"{q} [{unit}]", f"{v[-1]:.6g}"]
                        + [f"{x:.3g}" for x in d] + [fmt_order(x) for x in p])
            res_imp.append({"case": label, "quantity": q, "unit": unit, "values": v,
                            "diffs": d.tolist(),
                            "orders": [None if not np.isfinite(x) else float(x) for x in p]})
    result["impact"] = {"steps_s": list(IMPACT_STEPS), "speed_m_s": 1.5, "rows": res_imp}
    cols = (["coupling", "quantity", f"at {IMPACT_STEPS[-1]:g} s"]
            + [f"diff {IMPACT_STEPS[k]:g}-{IMPACT_STEPS[k + 1]:g}"
               for k in range(len(IMPACT_STEPS) - 1)]
            + [f"order {IMPACT_STEPS[k]:g}/{IMPACT_STEPS[k + 1]:g}/{IMPACT_STEPS[k + 2]:g}"
               for k in range(len(IMPACT_STEPS) - 2)])
    parts += ["", table("## 3. Two 90 t wagons meeting at 1.5 m/s (coupling bunched at the "
                        "start, so no slack crossing until they part), ode3", cols, rows)]

    # 4. the time constant
    rows, res_tau = [], []
    for tau in TAUS:
        log(f"tracking_time {tau:g} s ...")
        r = impact(CouplerParams(preset="friction-wedge-high", tracking_time=tau), 1.5,
                   dt=min(6.25e-6, tau / 8), t_max=1.0)
        ds, _ = train({"solver.method": "ode3", "solver.dt": min(2.5e-5, tau / 8),
                       "couplers.default": {"preset": "friction-wedge-high",
                                            "tracking_time": tau}})
        top = float(ds.max_coupler_force.values.max())
        rows.append([f"{tau:g}", f"{r['peak_force_N'] / 1e3:.3f}",
                     f"{r['kinetic_energy_lost_J']:.1f}", f"{top / 1e3:.3f}"])
        res_tau.append({"tracking_time_s": tau, "impact_peak_N": r["peak_force_N"],
                        "impact_energy_lost_J": r["kinetic_energy_lost_J"],
                        "train_largest_tension_N": top})
    result["tracking_time"] = res_tau
    parts += ["", table("## 4. The time constant: friction-wedge-high, impact at 1.5 m/s and "
                        "the study train's largest tension (first 30 s), each at a step at most "
                        "tracking_time / 8",
                        ["tracking_time [s]", "impact peak force [kN]",
                         "impact kinetic energy lost [J]", "train's largest tension [kN]"],
                        rows)]

    text = "\n".join(parts) + "\n"
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "study_dt_convergence.md") as tmp:
        tmp.write_text(text)
    import json
    with atomic_path(args.out / "study_dt_convergence.json") as tmp:
        tmp.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
