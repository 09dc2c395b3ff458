"""Figure and numbers of docs/creep.md, "Against a measured case: the Eurosprinter".

Run: ``python docs/scripts/creep_measured_figures.py`` (writes
docs/figures/creep_eurosprinter.png and prints the numbers the text quotes). The case, the
measured points and CONTACT's curves are read from tests/physics/data/eurosprinter_creep.toml
(which names their sources); ltdsim's curve is its Polach law with the ``eurosprinter``
preset on the Hertz ellipse of the case, evaluated as tests/physics/test_creep_measured.py
evaluates it.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from ltdsim.data import load_preset
from ltdsim.physics.drive import creep as cr

ROOT = Path(__file__).resolve().parents[2]   # the repository
FIGURES = ROOT / "docs" / "figures"
DATA = tomllib.loads((ROOT / "tests" / "physics" / "data" / "eurosprinter_creep.toml")
                     .read_text(encoding="utf-8"))
CASE = DATA["case"]
Q, V = CASE["wheel_load"], CASE["speed"]                 # N, m/s
G, NU = CASE["shear_modulus"], CASE["poisson"]           # Pa, -
A_SEMI, B_SEMI = cr.hertz_contact(Q, CASE["wheel_radius"], 1.0 / (2.0 * CASE["curvature_across"]),
                                  2.0 * G * (1.0 + NU), NU)
C11 = cr.kalker_c11(A_SEMI / B_SEMI)
F11 = G * A_SEMI * B_SEMI * C11                          # N
X = np.array(DATA["measured"]["creepage_percent"])        # %
Y = np.array(DATA["measured"]["traction_coefficient"])    # -
EDGES = (0.38, 0.6, 1.0, 1.5, 3.0, 5.0, 10.0, 15.0, 22.0)  # %, as the test
PRESET = load_preset("creep", "eurosprinter")
ROW = cr.creep_row(PRESET)


def law(row, f11=F11):
    def f(xi):
        s = np.asarray(xi, dtype=float) / 100.0
        return np.array([cr.polach_force(x, x * V, Q, f11, *row) for x in s]) / Q
    return f


def contact(name):
    c = DATA["contact"][name]
    xs, ys = np.array(c["creepage_percent"]), np.array(c["minus_fx_N"]) / Q
    return (lambda xi: np.interp(xi, xs, ys)), xs, ys


LTD = law(ROW)
EXT, EXT_X, EXT_Y = contact("extended")
MFS, MFS_X, MFS_Y = contact("modified_fastsim")
KAL, KAL_X, KAL_Y = contact("kalker")
DRY = law(cr.creep_row(load_preset("creep", "dry")))


def bands(f):
    rows = []
    for lo, hi in zip(EDGES[:-1], EDGES[1:]):
        m = (X >= lo) & (X < hi)
        rows.append((lo, hi, int(m.sum()), float(np.median(X[m])), Y[m].mean(),
                     Y[m].std(ddof=1), f(X[m]).mean()))
    return rows


def numbers():
    print(f"contact ellipse a = {A_SEMI * 1e3:.3f} mm, b = {B_SEMI * 1e3:.3f} mm "
          f"(CONTACT {CASE['semi_axis_a'] * 1e3:.3f}, {CASE['semi_axis_b'] * 1e3:.2f}), "
          f"c11 = {C11:.3f}, f11 = {F11 / 1e6:.2f} MN, f11/Q = {F11 / Q:.1f}")
    ss = dof = 0.0
    print("band %, points, measured mean +- std, ltdsim / extended / mod. Fastsim "
          "(deviation in measured std)")
    rows = {n: bands(f) for n, f in (("ltdsim", LTD), ("ext", EXT), ("mfs", MFS))}
    for i, (lo, hi, n, _, mean, std, mod) in enumerate(rows["ltdsim"]):
        y = Y[(X >= lo) & (X < hi)]
        ss += float(((y - y.mean()) ** 2).sum())
        dof += y.size - 1
        dev = [(rows[k][i][6] - mean) / std for k in ("ltdsim", "ext", "mfs")]
        print(f"  {lo:5.2f}-{hi:5.2f} {n:3d}  {mean:.4f} +- {std:.4f}  {mod:.4f} "
              f"{rows['ext'][i][6]:.4f} {rows['mfs'][i][6]:.4f}   "
              + " ".join(f"{d:+.2f}" for d in dev))
    pooled = math.sqrt(ss / dof)
    print(f"pooled scatter about the band means {pooled:.4f}")
    for name, f in (("ltdsim", LTD), ("extended CONTACT", EXT), ("modified Fastsim", MFS),
                    ("Kalker + Coulomb 0.33", KAL), ("dry preset", DRY)):
        r = f(X) - Y
        i = int(np.argmax(abs(r)))
        print(f"  {name:22s} bias {r.mean():+.4f}, rms {math.sqrt((r ** 2).mean()):.4f} "
              f"({math.sqrt((r ** 2).mean()) / pooled:.2f} x scatter), largest point "
              f"residual {r[i]:+.4f} at {X[i]:.2f} %")
    xi = np.geomspace(0.05, 25.0, 4000)
    for name, f in (("ltdsim", LTD), ("extended CONTACT", EXT), ("modified Fastsim", MFS)):
        v = f(xi)
        i = int(np.argmax(v))
        print(f"  peak {name:18s} {v[i]:.4f} at {xi[i]:.2f} %")
    xs = np.union1d(EXT_X, MFS_X)
    for label, sel in (("measured range 0.38-22 %", (xs >= X.min()) & (xs <= X.max())),
                       ("0.6-22 %", (xs >= 0.6) & (xs <= X.max())),
                       ("below 0.38 %", (xs > 0.01) & (xs < X.min()))):
        x = xs[sel]
        lt, e, m = LTD(x), EXT(x), MFS(x)
        de, dm = lt - e, lt - m
        band = np.maximum(np.minimum(e, m) - lt, lt - np.maximum(e, m))
        ie, im, ib, ic = (int(np.argmax(abs(de))), int(np.argmax(abs(dm))),
                          int(np.argmax(band)), int(np.argmax(abs(e - m))))
        print(f"  {label}: ltdsim - extended up to {de[ie]:+.4f} at {x[ie]} %, "
              f"- mod. Fastsim up to {dm[im]:+.4f} at {x[im]} %, outside their band by "
              f"{max(band[ib], 0):.4f} at {x[ib]} %; extended - mod. Fastsim up to "
              f"{(e - m)[ic]:+.4f} at {x[ic]} %")
    c11_28 = law(ROW, F11 * 3.733 / C11)
    d = c11_28(xs) - LTD(xs)
    print(f"  c11 3.733 (CONTACT's, nu 0.28) instead of {C11:.3f}: curve moves by at most "
          f"{abs(d).max():.4f}")


def figure():
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8),
                             gridspec_kw={"width_ratios": [1.0, 1.0, 0.9]})
    fine = np.concatenate([np.linspace(0.0, 1.0, 200)[1:], np.linspace(1.0, 25.0, 600)])
    for ax, xmax, ymax in ((axes[0], 5.0, 0.45), (axes[1], 25.0, 0.40)):
        ax.plot(X, Y, "*", color="0.45", ms=5, label=f"measured, Engel et al. ({X.size} points)")
        ax.plot(KAL_X, KAL_Y, ":", color="tab:blue", lw=1.2,
                label="CONTACT: Kalker, Coulomb 0.33 (rejected)")
        ax.plot(fine, DRY(fine), ":", color="tab:red", lw=1.2,
                label="ltdsim, dry preset (rejected)")
        ax.plot(EXT_X, EXT_Y, "-", color="tab:orange", lw=1.8, label="CONTACT: extended model")
        ax.plot(MFS_X, MFS_Y, "-", color="tab:olive", lw=3.2, alpha=0.8,
                label="CONTACT: modified Fastsim")
        ax.plot(fine, LTD(fine), "-", color="k", lw=1.5,
                label="ltdsim: Polach, eurosprinter preset")
        ax.set_xlim(0.0, xmax)
        ax.set_ylim(0.0, ymax)
        ax.set_xlabel("longitudinal creepage (omega r - v) / v, %")
        ax.set_ylabel("traction coefficient F / Q, -")
        ax.grid(True, alpha=0.3)
    axes[0].set_title("creepage 0-5 %", fontsize=10)
    axes[1].set_title("creepage 0-25 %", fontsize=10)
    axes[1].legend(fontsize=7.5, loc="lower right")
    ax = axes[2]
    rows = bands(LTD)
    mid = np.array([r[3] for r in rows])
    ax.errorbar(mid, [r[4] for r in rows], yerr=[r[5] for r in rows], fmt="s", color="0.45",
                capsize=3, label="measured band mean +- 1 std (test bound)")
    for f, st, col, lab in ((EXT, "^", "tab:orange", "CONTACT: extended"),
                            (MFS, "v", "tab:olive", "CONTACT: modified Fastsim"),
                            (LTD, "o", "k", "ltdsim")):
        ax.plot(mid, [r[6] for r in bands(f)], st, color=col, ms=6, label=lab)
    for lo in EDGES:
        ax.axvline(lo, color="0.85", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlim(0.3, 25.0)
    ax.set_xticks(EDGES)
    ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_ylim(0.15, 0.36)
    ax.set_xlabel("creepage, % (ticks: band edges; marks at band medians)")
    ax.set_ylabel("mean traction coefficient over the band's points, -")
    ax.set_title("per creepage band", fontsize=10)
    ax.legend(fontsize=7.5, loc="lower left")
    ax.grid(True, which="major", alpha=0.3)
    fig.suptitle("Eurosprinter 127 001 at 10 m/s: wheel load 106.7 kN, wheel radius 625 mm, "
                 f"a/b 0.5 (a {A_SEMI * 1e3:.2f} mm, b {B_SEMI * 1e3:.2f} mm), f11 "
                 f"{F11 / 1e6:.1f} MN; ltdsim mu0 {ROW[0]:.2f}, A {ROW[1]:.2f}, B {ROW[2]:.2f} "
                 f"s/m, kA {ROW[3]:.2f}, kS {ROW[4]:.2f}", fontsize=10)
    fig.tight_layout()
    fig.savefig(FIGURES / "creep_eurosprinter.png", dpi=100)


if __name__ == "__main__":
    numbers()
    figure()
