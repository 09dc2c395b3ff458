"""Where a friction-wedge gear's evaluation spends its instructions (issue 18).

Runs the study case LHHL (270 s, ode3 at 1e-4 s) with the simplified coupler and with
each friction-wedge set, and replays its couplers' inputs through the coupler alone:
the deflections and rates of the 1 ms samples, interpolated to the 1e-4 s step, with
the gear's own states (internal force, plate displacement) integrated alongside by
explicit Euler; every 70th evaluation is kept (about 347,000 over the 9 couplers).
Then it counts with valgrind's callgrind the instructions of

* the library's ``coupler_force`` on those inputs, per coupler model;
* for each wedge set, a copy of the wedge gear's evaluation with a scalar S (``_wedge``
  below: the physics functions of ``ltdsim.physics.gears.draftgear`` in the order
  ``coupler_models._gear`` and ``wedge_curves`` call them, the parts to leave out
  chosen by a flag at run time) with one part at a time left out (replaced by a few
  operations): the
  friction laws' exponentials, the movable plates, the force ratios psi, the
  hysteresis band, the plate rate; and all of them.

The difference to the copy is what that part costs per evaluation. The copy's count
beside the library's tells whether the copy still matches it. Under valgrind numba
sees another CPU (no AVX-512) and would compile again; so everything is compiled first
natively for a fixed CPU (``NUMBA_CPU_NAME=haswell``) into a fresh cache, from which
the counted child loads it (the counts are of that code). Also reports, from the 1 ms
samples, how often a gear is out of its slack, has its plates engaged (deflection
beyond the plate gap) or is closed solid.

Writes benchmarks/results/profile_wedge_gear.md and .json. Takes about 10 minutes.

Usage: python benchmarks/profile_wedge_gear.py
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from numba import njit

from ltdsim.engine.couplers import (
    HYS_KLOCK, P_F0, P_KSOLID, P_RATE, P_SLACK, P_TRAVEL, P_ZOFF, W_BACK, W_C1, W_C2, W_C3,
    W_G, W_GAP, W_H1, W_H2, W_H3, W_KM, W_KR, W_S, W_TA, W_TB, W_TG, W_XM0, W_XR0,
    coupler_force,
)
from ltdsim.physics.gears.couplers import gear_deflection
from ltdsim.physics.decay import HEAD_LIMIT, exp_neg_small, series_head
from ltdsim.physics.gears.draftgear import (
    _psi_pair, gear_force, plate_rate, plates_carried, plates_out, relax, spring_forces,
)

HERE = Path(__file__).resolve().parent
PAPER = HERE.parent / "scenarios" / "paper.toml"
PRESETS = ("simplified", "friction-wedge-low", "friction-wedge-high")
#: parts left out of the copy, by flag bit
PARTS = {"exponentials": 1, "plates": 2, "psi": 4, "band": 8, "plate rate": 16}
ALL = sum(PARTS.values())


@njit(cache=True)
def record(model, cpl, ctab, ys0, d, dd, sub, every):
    """Replay the samples ``d``/``dd`` (m, m/s; 1 ms apart, one column per coupler) at
    ``sub`` steps per sample, integrating the gear states from ``ys0``; keep every
    ``every``-th evaluation as a row (coupler, d, dd, first state, second state)."""
    t_n, nc = d.shape
    ns = ys0.size
    y = ys0.copy()
    dy = np.zeros(max(ns, 1))
    rec = np.zeros((((t_n - 1) * sub * nc) // every + 1, 5))
    h = 1e-3 / sub
    k = 0
    r = 0
    for t in range(t_n - 1):
        for s in range(sub):
            w = s / sub
            for j in range(nc):
                dj = d[t, j] * (1 - w) + d[t + 1, j] * w
                ddj = dd[t, j] * (1 - w) + dd[t + 1, j] * w
                zo = int(cpl[j, P_ZOFF])
                if k % every == 0:
                    rec[r, 0] = j
                    rec[r, 1] = dj
                    rec[r, 2] = ddj
                    if zo >= 0:
                        rec[r, 3] = y[zo]
                        rec[r, 4] = y[zo + 1]
                    r += 1
                k += 1
                coupler_force(j, model[j], dj, ddj, y, 0, dy, 0, cpl, ctab)
            for i in range(ns):
                y[i] += h * dy[i]
    return rec[:r]


@njit(cache=True)
def replay_library(model, cpl, ctab, rec, ns):
    """The library's coupler force over the recorded rows (sum, to keep the work)."""
    y = np.zeros(max(ns, 2))
    dy = np.zeros(y.size)
    acc = 0.0
    for r in range(rec.shape[0]):
        j = int(rec[r, 0])
        zo = int(cpl[j, P_ZOFF])
        if zo >= 0:
            y[zo] = rec[r, 3]
            y[zo + 1] = rec[r, 4]
        acc += coupler_force(j, model[j], rec[r, 1], rec[r, 2], y, 0, dy, 0, cpl, ctab)
        acc += dy[0]
    return acc


@njit(cache=True)
def _wedge(j, d, dd, y, zo, dy, cpl, off):
    """A copy of the wedge gear's evaluation (scalar S), with the parts whose bits are
    set in ``off`` replaced by a few operations; force N, rates to ``dy``."""
    x, sgn, in_slack = gear_deflection(d, dd, cpl[j, P_SLACK])
    rate = cpl[j, P_RATE]
    f1 = y[zo]
    if in_slack:
        dy[zo] = relax(f1, cpl[j, P_F0], rate)
        p = y[zo + 1]
        dy[zo + 1] = plate_rate(-cpl[j, W_GAP], p, 0.0, cpl[j, W_BACK], rate) \
            if p > 1e-12 else 0.0
        return 0.0
    v = sgn * dd
    p = y[zo + 1]
    gap = cpl[j, W_GAP]
    delta = cpl[j, W_BACK]
    s_factor = cpl[j, W_S]
    u = x - gap
    if off & 2:
        engaged = 0.0
        eu = 0.0
    else:
        engaged = plates_out(p, max(delta, 1e-3))
        eu = engaged if plates_carried(u, p, delta) else 0.0
    ta, tb, tg, big_g = cpl[j, W_TA], cpl[j, W_TB], cpl[j, W_TG], cpl[j, W_G]
    h1, h2, h3 = cpl[j, W_H1], cpl[j, W_H2], cpl[j, W_H3]
    s = abs(v)
    if off & 1:
        mu1 = (h1 + h2 * s) * s_factor
        mu2 = h1 + h2 * s * 0.5
        mu3 = h1 + h2 * s * 0.25
        mu4l = h1 + h2 * s * 0.125 if engaged > 0.0 else 0.0
        mu4u = h1 + h2 * s * 0.3 if eu > 0.0 else 0.0
    else:  # (as wedge_curves: the series' head for all laws when all are small)
        z1 = h3 * abs(cpl[j, W_C1] * s)
        z2 = h3 * abs(cpl[j, W_C2] * s)
        z3 = h3 * abs(cpl[j, W_C3] * s)
        z4 = h3 * abs(s)
        z5 = h3 * abs(big_g * s)
        if 0.0 <= max(max(max(z1, z2), max(z3, z4)), z5) < HEAD_LIMIT:
            mu1 = (h1 + h2 * series_head(z1)) * s_factor
            mu2 = h1 + h2 * series_head(z2)
            mu3 = h1 + h2 * series_head(z3)
            mu4l = h1 + h2 * series_head(z4) if engaged > 0.0 else 0.0
            mu4u = h1 + h2 * series_head(z5) if eu > 0.0 else 0.0
        else:
            mu1 = (h1 + h2 * exp_neg_small(z1)) * s_factor
            mu2 = h1 + h2 * exp_neg_small(z2)
            mu3 = h1 + h2 * exp_neg_small(z3)
            mu4l = h1 + h2 * exp_neg_small(z4) if engaged > 0.0 else 0.0
            mu4u = h1 + h2 * exp_neg_small(z5) if eu > 0.0 else 0.0
    if off & 4:
        pl = 1.3 + mu1 + mu2 + mu3 + mu4l
        pu = 0.7 - mu1 - mu2 - mu3 - mu4u
    else:
        nl, dl = _psi_pair(ta, tb, tg, mu1, mu2, mu3, engaged, mu4l, True)
        nu, du = _psi_pair(ta, tb, tg, mu1, mu2, mu3, eu, mu4u, False)
        rr = 1.0 / (dl * du)
        pl = nl * du * rr
        pu = nu * dl * rr
    k_m, k_r = cpl[j, W_KM], cpl[j, W_KR]
    fsm, fsr = spring_forces(x, big_g, k_m, cpl[j, W_XM0], k_r, cpl[j, W_XR0])
    dsm = k_m * big_g
    dsr = -k_r * (big_g - 1.0) if fsr > 0.0 else 0.0
    f_l = pl * fsm - (pl - 1.0) * fsr
    f_u = pu * fsm - (pu - 1.0) * fsr
    s_l = pl * dsm - (pl - 1.0) * dsr
    s_u = pu * dsm - (pu - 1.0) * dsr
    if off & 8:
        f = min(max(f1, f_u), f_l)
        df1 = s_l * v
    else:
        f, df1 = gear_force(f1, f_l, f_u, s_l, s_u, v, x, cpl[j, P_TRAVEL],
                            cpl[j, P_KSOLID], cpl[j, HYS_KLOCK], rate)
    dy[zo] = df1
    dy[zo + 1] = v if off & 16 else plate_rate(u, p, v, delta, rate)
    return sgn * f


@njit(cache=True)
def replay_copy(cpl, rec, ns, off):
    """The copy :func:`_wedge` over the recorded rows (sum, to keep the work)."""
    y = np.zeros(max(ns, 2))
    dy = np.zeros(y.size)
    acc = 0.0
    for r in range(rec.shape[0]):
        j = int(rec[r, 0])
        zo = int(cpl[j, P_ZOFF])
        y[zo] = rec[r, 3]
        y[zo + 1] = rec[r, 4]
        acc += _wedge(j, rec[r, 1], rec[r, 2], y, zo, dy, cpl, off)
        acc += dy[0]
    return acc


def _cases(work: Path, native: bool) -> dict:
    """Per preset: the lowered couplers and the recorded rows (recorded and saved
    natively, loaded under valgrind); with ``native`` also the 1 ms sample shares."""
    import ltdsim
    from ltdsim.engine.lowering import lower

    base = ltdsim.load_scenario(PAPER, case="LHHL")
    out = {}
    for preset in PRESETS:
        sc = base if preset == "simplified" else base.with_overrides(
            {"couplers.default": {"preset": preset}})
        low = lower(sc)
        n = low.cpl.shape[0] + 1
        ys0 = np.array(low.y0[2 * n:2 * n + 2 * (n - 1)]) if preset != "simplified" \
            else np.zeros(2)
        f = work / f"rec-{preset}.npy"
        shares = {}
        if native:
            ds = ltdsim.simulate(sc)
            d = np.ascontiguousarray(ds.coupler_deflection.values)
            vel = ds.velocity.values
            dd = np.ascontiguousarray(vel[:, :-1] - vel[:, 1:])
            np.save(f, record(low.cpl_model, low.cpl, low.ctab, ys0, d, dd, 10, 70))
            c = sc.coupler(0)
            x = np.abs(d) - 0.5 * c.slack
            shares = {"out of slack": float((x > 0).mean())}
            if preset != "simplified":
                shares["plates engaged"] = float((x > c.plate_gap).mean())
                shares["solid"] = float((x > c.travel).mean())
        out[preset] = (low, ys0, np.load(f), shares)
    return out


def _runs(cases):
    """``(preset, label, call)`` for every counted replay."""
    for preset, (low, ys0, rec, _) in cases.items():
        yield preset, "library", lambda r, low=low, ys0=ys0: replay_library(
            low.cpl_model, low.cpl, low.ctab, r, ys0.size)
        if preset == "simplified":
            continue
        yield preset, "copy", lambda r, low=low, ys0=ys0: replay_copy(low.cpl, r, ys0.size, 0)
        for part, bit in [*PARTS.items(), ("all of them", ALL)]:
            yield preset, f"without {part}", lambda r, low=low, ys0=ys0, bit=bit: replay_copy(
                low.cpl, r, ys0.size, bit)


def run_replays(runs, cases, counted: bool) -> None:
    """Call every replay of ``runs`` (``(preset, label, call)``, ``call`` taking the
    preset's record from ``cases``) once on a short piece to compile or load it; with
    ``counted`` (this process under callgrind) call it again on the whole record with
    the instrumentation on, and dump its counts as ``run<i>`` (``i`` its place in
    ``runs``)."""
    pid = str(os.getpid())
    for i, (preset, label, call) in enumerate(runs):
        rec = cases[preset][2]
        call(rec[:1000].copy())  # compile or load
        if counted:
            for cmd in (["-i", "on"], None, ["-i", "off"], [f"--dump=run{i}"]):
                if cmd is None:
                    call(rec)
                else:
                    subprocess.run(["callgrind_control", *cmd, pid], check=True,
                                   capture_output=True)


def read_dumps(work: Path, labels: list[str]) -> dict:
    """The counts of each replay from the callgrind dumps in ``work``: ``labels[i]`` (the
    label of dump ``run<i>``) -> event name (``Ir``, ...) -> count."""
    counts = {}
    for dump in work.glob("callgrind.out.*"):
        text = dump.read_text()
        m = re.search(r"^desc: Trigger:.*\brun(\d+)", text, re.M)
        if m:
            events = re.search(r"^events: (.*)$", text, re.M).group(1).split()
            totals = re.search(r"^totals: (.*)$", text, re.M).group(1).split()
            counts[labels[int(m.group(1))]] = dict(zip(events, map(int, totals)))
    if len(counts) != len(labels):
        raise SystemExit(f"found {len(counts)} of {len(labels)} callgrind dumps in {work}")
    return counts


def _child(work: Path, counted: bool) -> None:
    cases = _cases(work, native=not counted)
    if not counted:
        (work / "shares.json").write_text(json.dumps({p: c[3] for p, c in cases.items()}))
    run_replays(_runs(cases), cases, counted)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--child", choices=("native", "counted"), help=argparse.SUPPRESS)
    ap.add_argument("--work", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        _child(args.work, args.child == "counted")
        return {}
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind is not installed")
    from _results import publish

    work = Path(tempfile.mkdtemp(prefix="ltdsim-wedge-profile-"))
    env = dict(os.environ, NUMBA_CPU_NAME="haswell", NUMBA_CPU_FEATURES="",
               NUMBA_CACHE_DIR=str(work / "cache"))
    me = [sys.executable, str(Path(__file__).resolve()), "--work", str(work), "--child"]
    done = False
    try:
        print("recording the inputs and compiling (natively, for haswell)", flush=True)
        subprocess.run([*me, "native"], env=env, check=True)
        print("counting (callgrind)", flush=True)
        out = work / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no",
                        f"--callgrind-out-file={out}", *me, "counted"], env=env, check=True,
                       capture_output=True)
        shares = json.loads((work / "shares.json").read_text())
        n_rec = int(np.load(work / "rec-simplified.npy").shape[0])
        labels = [f"{preset}|{label}" for preset, label, _ in _runs(
            {p: (None, None, None, None) for p in PRESETS})]
        counts = {k: c["Ir"] for k, c in read_dumps(work, labels).items()}
        done = True
    finally:
        if done:  # (kept for a look when something failed)
            shutil.rmtree(work, ignore_errors=True)
    rows = []
    for preset in PRESETS:
        sh = ", ".join(f"{k} {100 * v:.1f} %" for k, v in shares[preset].items())
        lib = counts[f"{preset}|library"] / n_rec
        rows.append((f"{preset}: library coupler_force", f"{lib:.0f}", f"1 ms samples: {sh}"))
        if preset == "simplified":
            continue
        copy = counts[f"{preset}|copy"] / n_rec
        rows.append((f"{preset}: copy of the wedge gear", f"{copy:.0f}", ""))
        for part in [*PARTS, "all of them"]:
            c = counts[f"{preset}|without {part}"] / n_rec
            rows.append((f"{preset}: copy without {part}", f"{c:.0f}",
                         f"{part}: {copy - c:.0f} per evaluation"))
    publish(args.out, "profile_wedge_gear",
            "Wedge-gear profile, {stamp}; instructions per coupler evaluation (callgrind, "
            f"kernels compiled for haswell), {n_rec:,} evaluations replayed from the study "
            "case LHHL's 270 s (every 70th at the 1e-4 s step)", rows,
            columns=("replay", "instructions per evaluation", "note"),
            result={"evaluations": n_rec, "instructions": counts, "shares": shares})
    return counts


if __name__ == "__main__":
    main()
