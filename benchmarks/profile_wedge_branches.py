"""Which of a friction-wedge gear's branches the processor guesses wrong (issue 18).

The wedge gear's CPU time over the simplified coupler's is above its instruction
ratio; mispredicted conditional branches (some 15-20 cycles each) are a suspect. This
machine's hardware counters cannot be read, so valgrind's callgrind simulates a
branch predictor (``--branch-sim=yes``, a table of two-bit counters: it compares
codes, it does not give the hardware's rate) over the replay of
``profile_wedge_gear.py``: the study case LHHL's coupler inputs (270 s, every 70th
evaluation at the 1e-4 s step, about 347,000), through

* the library's ``coupler_force``, per coupler model;
* for each wedge set, copies of the wedge gear's evaluation (scalar S) that differ
  from the library's in one place each, chosen by a flag fixed when the copy is made
  (each flag value is its own module, written to a temporary folder and compiled
  there, so that no form pays for a test of the flag):

  - ``plate jumps`` / ``carry jumps``: the plates' rate and their carry test with the
    jumps the library had before (``if v > 0 and ...: elif v < 0 and ...``,
    ``p > tol and u <= ...``);
  - ``band select``: the hysteresis band's force as ``min(max(F1, f_u), f_l)`` and its
    slope selected from values all computed;
  - ``mu4 always``: the plates' two friction laws computed whether the plates are
    engaged or not, the force ratios' plate terms selected;
  - ``spring max`` / ``solid max``: the release spring and the solid closure's
    additions by max/min and selects;
  - ``series to 1/8``: the friction laws by the whole series below 1/8 (one test for
    all five) instead of the series' head below 1/32.

Per evaluation it reports instructions (Ir), conditional branches (Bc) and their
mispredictions (Bcm). Compiled natively for haswell first, loaded from that cache by
the counted child (as ``profile_wedge_gear.py``). Takes about 10 minutes.

Writes benchmarks/results/profile_wedge_branches.md and .json.

Usage: python benchmarks/profile_wedge_branches.py
"""

from __future__ import annotations

import argparse
import importlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import profile_wedge_gear as pw  # (the recording and the library replay)

#: the copies' forms, by flag bit
PLATE_JUMPS, CARRY_JUMPS, BAND, MU4, SPRING, SOLID, SERIES8 = 1, 2, 4, 8, 16, 32, 64
FORMS = {"copy (as the library)": 0, "plate jumps": PLATE_JUMPS, "carry jumps": CARRY_JUMPS,
         "plate and carry jumps (the code before)": PLATE_JUMPS | CARRY_JUMPS,
         "band select": BAND, "mu4 always": MU4, "spring max": SPRING, "solid max": SOLID,
         "series to 1/8": SERIES8}

_COPY = r'''
import numpy as np
from numba import njit
from ltdsim.engine.couplers import (
    HYS_KLOCK, P_F0, P_KSOLID, P_RATE, P_SLACK, P_TRAVEL, P_ZOFF, W_BACK, W_C1, W_C2, W_C3,
    W_G, W_GAP, W_H1, W_H2, W_H3, W_KM, W_KR, W_S, W_TA, W_TB, W_TG, W_XM0, W_XR0)
from ltdsim.physics.gears.couplers import gear_deflection, solid_closure
from ltdsim.physics.decay import HEAD_LIMIT, SERIES_LIMIT, exp_neg_small, series_head, _series
from ltdsim.physics.gears.draftgear import (
    _psi_pair, hysteresis, plate_rate, plates_carried, plates_out, relax, spring_forces,
    PLATE_TOL)

FL = __FLAGS__


@njit(cache=True, inline="always")
def carried(u, p, delta):
    if FL & 2:
        return p > PLATE_TOL and u <= p - delta + PLATE_TOL
    return plates_carried(u, p, delta)


@njit(cache=True, inline="always")
def prate(u, p, v, delta, rate):
    if FL & 1:
        lo = u if u > 0.0 else 0.0
        up = u + delta
        hi = up if up > 0.0 else 0.0
        dp = 0.0
        if v > 0.0 and u >= p - PLATE_TOL:
            dp = v
        elif v < 0.0 and carried(u, p, delta):
            dp = v
        gap = min(max(p, lo), hi) - p
        return dp + rate * gap if abs(gap) > 1e-12 else dp
    return plate_rate(u, p, v, delta, rate)


@njit(cache=True, inline="always")
def psi_pair(ta, tb, tg, mu1, mu2, mu3, plates, mu4, loading):
    if FL & 8:
        n0, d0 = _psi_pair(ta, tb, tg, mu1, mu2, mu3, 0.0, mu4, loading)
        n1, d1 = _psi_pair(ta, tb, tg, mu1, mu2, mu3, 1.0, plates * mu4, loading)
        on = plates > 0.0
        return (n1 if on else n0), (d1 if on else d0)
    return _psi_pair(ta, tb, tg, mu1, mu2, mu3, plates, mu4, loading)


@njit(cache=True, inline="always")
def mus(z1, z2, z3, z4, z5, h1, h2, s_factor, pl_l, pl_u):
    zmax = max(max(max(z1, z2), max(z3, z4)), z5)
    if FL & 64 and 0.0 <= zmax < SERIES_LIMIT:
        return ((h1 + h2 * _series(z1)) * s_factor, h1 + h2 * _series(z2),
                h1 + h2 * _series(z3),
                h1 + h2 * _series(z4) if pl_l > 0.0 else 0.0,
                h1 + h2 * _series(z5) if pl_u > 0.0 else 0.0)
    if not FL & 64 and 0.0 <= zmax < HEAD_LIMIT:
        e4 = series_head(z4)
        e5 = series_head(z5)
        if FL & 8:
            return ((h1 + h2 * series_head(z1)) * s_factor, h1 + h2 * series_head(z2),
                    h1 + h2 * series_head(z3), h1 + h2 * e4, h1 + h2 * e5)
        return ((h1 + h2 * series_head(z1)) * s_factor, h1 + h2 * series_head(z2),
                h1 + h2 * series_head(z3), h1 + h2 * e4 if pl_l > 0.0 else 0.0,
                h1 + h2 * e5 if pl_u > 0.0 else 0.0)
    return ((h1 + h2 * exp_neg_small(z1)) * s_factor, h1 + h2 * exp_neg_small(z2),
            h1 + h2 * exp_neg_small(z3),
            h1 + h2 * exp_neg_small(z4) if (pl_l > 0.0 or FL & 8) else 0.0,
            h1 + h2 * exp_neg_small(z5) if (pl_u > 0.0 or FL & 8) else 0.0)


@njit(cache=True, inline="always")
def curves(x, v, ta, tb, tg, big_g, c1, c2, c3, h1, h2, h3, s_factor, k_m, x_m0, k_r, x_r0,
           pl_l, pl_u):
    s = abs(v)
    mu1, mu2, mu3, mu4l, mu4u = mus(h3 * abs(c1 * s), h3 * abs(c2 * s), h3 * abs(c3 * s),
                                    h3 * abs(s), h3 * abs(big_g * s), h1, h2, s_factor,
                                    pl_l, pl_u)
    nl, dl = psi_pair(ta, tb, tg, mu1, mu2, mu3, pl_l, mu4l, True)
    nu, du = psi_pair(ta, tb, tg, mu1, mu2, mu3, pl_u, mu4u, False)
    r = 1.0 / (dl * du)
    pl = nl * du * r
    pu = nu * dl * r
    if FL & 16:
        fsm = k_m * (x_m0 + big_g * x)
        fsr0 = k_r * (x_r0 - (big_g - 1.0) * x)
        fsr = max(fsr0, 0.0)
        dsr = -k_r * (big_g - 1.0) if fsr0 > 0.0 else 0.0
    else:
        fsm, fsr = spring_forces(x, big_g, k_m, x_m0, k_r, x_r0)
        dsr = -k_r * (big_g - 1.0) if fsr > 0.0 else 0.0
    dsm = k_m * big_g
    return (pl * fsm - (pl - 1.0) * fsr, pu * fsm - (pu - 1.0) * fsr,
            pl * dsm - (pl - 1.0) * dsr, pu * dsm - (pu - 1.0) * dsr)


@njit(cache=True, inline="always")
def gforce(f1, f_l, f_u, s_l, s_u, v, x, travel, ks, k_locked, rate):
    solid = solid_closure(x, travel, ks)
    if FL & 32:
        f_l = f_l + solid
        f_u = min(f_u + solid, f_l)
        add = ks if solid > 0.0 else 0.0
        s_l = s_l + add
        s_u = s_u + add
    else:
        if solid > 0.0:
            f_l += solid
            f_u += solid
            s_l += ks
            s_u += ks
        if f_u > f_l:
            f_u = f_l
    if FL & 4:
        f = min(max(f1, f_u), f_l)
        s_mid = s_u + (f1 - f_u) / (f_l - f_u) * (s_l - s_u)
        s_band = s_l if f1 >= f_l else (s_u if f1 <= f_u else s_mid)
        df1 = (k_locked + s_band) * v + rate * (f - f1)
    else:
        f, df1 = hysteresis(f1, f_l, f_u, s_l, s_u, v, k_locked, rate)
    return max(f, 0.0) if FL & 32 else (0.0 if f < 0.0 else f), df1


@njit(cache=True, inline="always")
def gear(j, d, dd, y, zo, dy, cpl):
    x, sgn, in_slack = gear_deflection(d, dd, cpl[j, P_SLACK])
    rate = cpl[j, P_RATE]
    f1 = y[zo]
    if in_slack:
        dy[zo] = relax(f1, cpl[j, P_F0], rate)
        p = y[zo + 1]
        dy[zo + 1] = prate(-cpl[j, W_GAP], p, 0.0, cpl[j, W_BACK], rate) if p > 1e-12 else 0.0
        return 0.0
    v = sgn * dd
    p = y[zo + 1]
    delta = cpl[j, W_BACK]
    u = x - cpl[j, W_GAP]
    engaged = plates_out(p, max(delta, 1e-3))
    f_l, f_u, s_l, s_u = curves(
        x, v, cpl[j, W_TA], cpl[j, W_TB], cpl[j, W_TG], cpl[j, W_G], cpl[j, W_C1],
        cpl[j, W_C2], cpl[j, W_C3], cpl[j, W_H1], cpl[j, W_H2], cpl[j, W_H3], cpl[j, W_S],
        cpl[j, W_KM], cpl[j, W_XM0], cpl[j, W_KR], cpl[j, W_XR0], engaged,
        engaged if carried(u, p, delta) else 0.0)
    f, df1 = gforce(f1, f_l, f_u, s_l, s_u, v, x, cpl[j, P_TRAVEL], cpl[j, P_KSOLID],
                    cpl[j, HYS_KLOCK], rate)
    dy[zo] = df1
    dy[zo + 1] = prate(u, p, v, delta, rate)
    return sgn * f


@njit(cache=True)
def replay(model, cpl, ctab, rec, ns):
    y = np.zeros(max(ns, 2))
    dy = np.zeros(y.size)
    acc = 0.0
    for r in range(rec.shape[0]):
        j = int(rec[r, 0])
        zo = int(cpl[j, P_ZOFF])
        y[zo] = rec[r, 3]
        y[zo + 1] = rec[r, 4]
        acc += gear(j, rec[r, 1], rec[r, 2], y, zo, dy, cpl)
        acc += dy[zo] + dy[zo + 1]
    return acc
'''


def _write_copies(work: Path) -> None:
    """One module per form, ``copy_<flags>.py`` in ``work``."""
    for flags in FORMS.values():
        (work / f"copy_{flags}.py").write_text(_COPY.replace("__FLAGS__", str(flags)))


def _runs(cases, work: Path):
    """``(preset, label, call)`` for every counted replay."""
    sys.path.insert(0, str(work))
    for preset, (low, ys0, rec, _) in cases.items():
        yield preset, "library", lambda r, low=low, ys0=ys0: pw.replay_library(
            low.cpl_model, low.cpl, low.ctab, r, ys0.size)
        if preset == "simplified":
            continue
        for label, flags in FORMS.items():
            fn = importlib.import_module(f"copy_{flags}").replay if low is not None else None
            yield preset, label, lambda r, low=low, ys0=ys0, fn=fn: fn(
                low.cpl_model, low.cpl, low.ctab, r, ys0.size)


def _child(work: Path, counted: bool) -> None:
    cases = pw._cases(work, native=not counted)
    pw.run_replays(_runs(cases, work), cases, counted)


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

    work = Path(tempfile.mkdtemp(prefix="ltdsim-wedge-branches-"))
    _write_copies(work)
    env = dict(os.environ, NUMBA_CPU_NAME="haswell", NUMBA_CPU_FEATURES="",
               NUMBA_CACHE_DIR=str(work / "cache"))
    me = [sys.executable, str(Path(__file__).resolve()), "--work", str(work), "--child"]
    done = False
    try:
        print("recording the inputs and compiling (natively, for haswell)", flush=True)
        subprocess.run([*me, "native"], env=env, check=True)
        print("counting (callgrind, branch simulation)", flush=True)
        out = work / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", "--branch-sim=yes",
                        "--instr-atstart=no", f"--callgrind-out-file={out}", *me, "counted"],
                       env=env, check=True, capture_output=True)
        n_rec = int(np.load(work / "rec-simplified.npy").shape[0])
        labels = [f"{p}|{l}" for p, l, _ in _runs(
            {p: (None, None, None, None) for p in pw.PRESETS}, work)]
        counts = pw.read_dumps(work, labels)
        done = True
    finally:
        if done:  # (kept for a look when something failed)
            shutil.rmtree(work, ignore_errors=True)
    rows = []
    for label in labels:
        preset, form = label.split("|")
        c = counts[label]
        rows.append((f"{preset}: {form}", f"{c['Ir'] / n_rec:.0f}", f"{c['Bc'] / n_rec:.1f}",
                     f"{c['Bcm'] / n_rec:.3f}"))
    publish(args.out, "profile_wedge_branches",
            "Wedge-gear branch profile, {stamp}; per coupler evaluation, callgrind with its "
            f"branch simulation (kernels compiled for haswell), {n_rec:,} evaluations "
            "replayed from the study case LHHL's 270 s (every 70th at the 1e-4 s step)",
            rows, columns=("replay", "instructions", "conditional branches",
                           "mispredicted"),
            result={"evaluations": n_rec, "counts": counts})
    return counts


if __name__ == "__main__":
    main()
