"""Kernels of the named-structures prototype (benchmarks/bench_named_structs.py).

Two versions of one small train kernel with the same arithmetic in the same order; see
the benchmark's docstring. They live in a module of their own: numba finds a kernel
whose arguments are namedtuples in its on-disk cache only when the namedtuple classes
can be imported by name, which classes defined in a script run as ``__main__`` cannot.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ltdsim.engine.kernel import _interp, _segment  # the engine's own look-ups

# ----------------------------------------------------------------- shared pieces
D0, SLACK, K1, K3, DAMP = range(5)  # coupler columns
MASS, DA, DB, DC, P0 = range(5)  # vehicle columns
T_MTOT, T_FMAX, T_REF, T_G = range(4)  # train scalars
C_PI, C_ADEM, C_VREF = range(3)  # controller slots (positional version)
N_SIG = 3


@njit(cache=True, inline="always")
def _coupler(d, dd, slack, k1, k3, damp):
    h = 0.5 * slack
    if d > h:
        e = d - h
    elif d < -h:
        e = d + h
    else:
        return 0.0
    f = k1 * e + k3 * e * e * e + damp * dd
    if slack > 0.0 and f * e < 0.0:
        return 0.0
    return f


# ----------------------------------------------------------------- positional version
@njit(cache=True, _nrt=False, forceinline=True)
def rhs_pos(t, y, a_dem, veh, cpl, tpos, tgrade, trac, inv_m, dy, force, res, sig, hints):
    n = veh.shape[0]
    rtot = 0.0
    for i in range(n):
        v = y[n + i]
        r = veh[i, DA] + veh[i, DB] * v + veh[i, DC] * v * v
        kt = _segment(tpos, veh[i, P0] + y[i], hints[i])
        hints[i] = kt
        r += veh[i, MASS] * trac[T_G] * tgrade[kt]
        res[i] = r
        rtot += r
    ft = min(max(a_dem * trac[T_MTOT] + rtot, -trac[T_FMAX]), trac[T_FMAX])
    sig[0] = ft
    sig[1] = rtot
    sig[2] = y[n + int(trac[T_REF])]
    for j in range(n - 1):
        d = y[j] - y[j + 1] + cpl[j, D0]
        dd = y[n + j] - y[n + j + 1]
        force[j] = _coupler(d, dd, cpl[j, SLACK], cpl[j, K1], cpl[j, K3], cpl[j, DAMP])
    for i in range(n):
        f = -res[i]
        if i == 0:
            f += ft
        if i < n - 1:
            f -= force[i]
        if i > 0:
            f += force[i - 1]
        dy[i] = y[n + i]
        dy[n + i] = f * inv_m[i]


@njit(cache=True, _nrt=False, forceinline=True)
def record_pos(r, y, dy, force, sig, veh, out_x, out_v, out_a, out_f, out_s):
    n = veh.shape[0]
    for i in range(n):
        out_x[r, i] = y[i] + veh[i, P0]
        out_v[r, i] = y[n + i]
        out_a[r, i] = dy[n + i]
    for j in range(n - 1):
        out_f[r, j] = force[j]
    out_s[r, 0] = sig[0]
    out_s[r, 1] = sig[1]
    out_s[r, 2] = sig[2]


@njit(cache=True, _nrt=False, forceinline=True)
def controller_pos(t, ctrl, prof_t, prof_y, hints, n, kp, ki, ts, sig, trac):
    vref = _interp(prof_t, prof_y, t, hints, n)
    e = vref - sig[2]
    ctrl[C_PI] += ts * e
    u = kp * e + ki * ctrl[C_PI]
    ctrl[C_ADEM] = min(max(u, -1.0), 1.0)
    ctrl[C_VREF] = vref


@njit(cache=True, _nrt=False)
def run_pos(y, ctrl, k_start, k_stop, dt, every, record_every, kp, ki, A, B, C, veh, cpl,
            tpos, tgrade, trac, prof_t, prof_y, out_x, out_v, out_a, out_f, out_s, peaks,
            work, hints):
    n = veh.shape[0]
    ny = y.shape[0]
    ns = B.shape[0]
    nc = n - 1
    K = work[0:ns * ny]
    ytmp = work[ns * ny:(ns + 1) * ny]
    o = (ns + 1) * ny
    force = work[o:o + nc]
    res = work[o + nc:o + nc + n]
    inv_m = work[o + nc + n:o + nc + 2 * n]
    sig = work[o + nc + 2 * n:o + nc + 2 * n + N_SIG]
    for i in range(n):
        inv_m[i] = 1.0 / veh[i, MASS]
    c_ctrl = k_start % every
    c_rec = k_start % record_every
    for k in range(k_start, k_stop):
        t = k * dt
        if c_ctrl == 0:
            controller_pos(t, ctrl, prof_t, prof_y, hints, n, kp, ki, every * dt, sig, trac)
        a_dem = ctrl[C_ADEM]
        rhs_pos(t, y, a_dem, veh, cpl, tpos, tgrade, trac, inv_m, K[0:ny], force, res, sig,
                hints)
        for j in range(nc):
            f = force[j]
            if f > peaks[j, 0]:
                peaks[j, 0] = f
            if f < peaks[j, 1]:
                peaks[j, 1] = f
        if c_rec == 0:
            record_pos(k // record_every, y, K, force, sig, veh, out_x, out_v, out_a, out_f,
                       out_s)
        for s in range(1, ns):
            for q in range(ny):
                ytmp[q] = y[q]
            for j in range(s):
                w = dt * A[s, j]
                if w != 0.0:
                    for q in range(ny):
                        ytmp[q] += w * K[j * ny + q]
            rhs_pos(t + C[s] * dt, ytmp, a_dem, veh, cpl, tpos, tgrade, trac, inv_m,
                    K[s * ny:(s + 1) * ny], force, res, sig, hints)
        for q in range(ny):
            ytmp[q] = 0.0
        for s in range(ns):
            w = dt * B[s]
            for q in range(ny):
                ytmp[q] += w * K[s * ny + q]
        for q in range(ny):
            y[q] += ytmp[q]
        c_ctrl += 1
        if c_ctrl == every:
            c_ctrl = 0
        c_rec += 1
        if c_rec == record_every:
            c_rec = 0
    t = k_stop * dt
    rhs_pos(t, y, ctrl[C_ADEM], veh, cpl, tpos, tgrade, trac, inv_m, K[0:ny], force, res,
            sig, hints)
    record_pos(k_stop // record_every, y, K, force, sig, veh, out_x, out_v, out_a, out_f,
               out_s)
    return 0


# ----------------------------------------------------------------- named version
Tableau = namedtuple("Tableau", "A b c")
Train = namedtuple("Train", "veh cpl tpos tgrade mtot fmax ref g")
Driver = namedtuple("Driver", "prof_t prof_y kp ki every")
Work = namedtuple("Work", "K ytmp force res inv_m sig hints")
Outputs = namedtuple("Outputs", "x v a f s peaks")
CTRL = np.dtype([("pi", np.float64), ("adem", np.float64), ("vref", np.float64)])
SIG = np.dtype([("traction", np.float64), ("resistance", np.float64),
                ("vref_vehicle", np.float64)])


@njit(cache=True, _nrt=False, forceinline=True)
def rhs_named(t, y, a_dem, tr, w, dy):
    veh = tr.veh
    n = veh.shape[0]
    res = w.res
    hints = w.hints
    rtot = 0.0
    for i in range(n):
        v = y[n + i]
        r = veh[i, DA] + veh[i, DB] * v + veh[i, DC] * v * v
        kt = _segment(tr.tpos, veh[i, P0] + y[i], hints[i])
        hints[i] = kt
        r += veh[i, MASS] * tr.g * tr.tgrade[kt]
        res[i] = r
        rtot += r
    ft = min(max(a_dem * tr.mtot + rtot, -tr.fmax), tr.fmax)
    sig = w.sig[0]
    sig.traction = ft
    sig.resistance = rtot
    sig.vref_vehicle = y[n + tr.ref]
    cpl = tr.cpl
    force = w.force
    for j in range(n - 1):
        d = y[j] - y[j + 1] + cpl[j, D0]
        dd = y[n + j] - y[n + j + 1]
        force[j] = _coupler(d, dd, cpl[j, SLACK], cpl[j, K1], cpl[j, K3], cpl[j, DAMP])
    inv_m = w.inv_m
    for i in range(n):
        f = -res[i]
        if i == 0:
            f += ft
        if i < n - 1:
            f -= force[i]
        if i > 0:
            f += force[i - 1]
        dy[i] = y[n + i]
        dy[n + i] = f * inv_m[i]


@njit(cache=True, _nrt=False, forceinline=True)
def record_named(r, y, dy, tr, w, out):
    veh = tr.veh
    n = veh.shape[0]
    for i in range(n):
        out.x[r, i] = y[i] + veh[i, P0]
        out.v[r, i] = y[n + i]
        out.a[r, i] = dy[n + i]
    for j in range(n - 1):
        out.f[r, j] = w.force[j]
    sig = w.sig[0]
    out.s[r, 0] = sig.traction
    out.s[r, 1] = sig.resistance
    out.s[r, 2] = sig.vref_vehicle


@njit(cache=True, _nrt=False, forceinline=True)
def controller_named(t, st, drv, w, n, ts):
    vref = _interp(drv.prof_t, drv.prof_y, t, w.hints, n)
    e = vref - w.sig[0].vref_vehicle
    st.pi += ts * e
    u = drv.kp * e + drv.ki * st.pi
    st.adem = min(max(u, -1.0), 1.0)
    st.vref = vref


@njit(cache=True, _nrt=False)
def run_named(y, ctrl, k_start, k_stop, dt, record_every, tab, tr, drv, w, out):
    st = ctrl[0]
    n = tr.veh.shape[0]
    ny = y.shape[0]
    ns = tab.b.shape[0]
    nc = n - 1
    K = w.K
    ytmp = w.ytmp
    peaks = out.peaks
    every = drv.every
    for i in range(n):
        w.inv_m[i] = 1.0 / tr.veh[i, MASS]
    c_ctrl = k_start % every
    c_rec = k_start % record_every
    for k in range(k_start, k_stop):
        t = k * dt
        if c_ctrl == 0:
            controller_named(t, st, drv, w, n, every * dt)
        a_dem = st.adem
        rhs_named(t, y, a_dem, tr, w, K[0:ny])
        for j in range(nc):
            f = w.force[j]
            if f > peaks[j, 0]:
                peaks[j, 0] = f
            if f < peaks[j, 1]:
                peaks[j, 1] = f
        if c_rec == 0:
            record_named(k // record_every, y, K, tr, w, out)
        for s in range(1, ns):
            for q in range(ny):
                ytmp[q] = y[q]
            for j in range(s):
                wt = dt * tab.A[s, j]
                if wt != 0.0:
                    for q in range(ny):
                        ytmp[q] += wt * K[j * ny + q]
            rhs_named(t + tab.c[s] * dt, ytmp, a_dem, tr, w, K[s * ny:(s + 1) * ny])
        for q in range(ny):
            ytmp[q] = 0.0
        for s in range(ns):
            wt = dt * tab.b[s]
            for q in range(ny):
                ytmp[q] += wt * K[s * ny + q]
        for q in range(ny):
            y[q] += ytmp[q]
        c_ctrl += 1
        if c_ctrl == every:
            c_ctrl = 0
        c_rec += 1
        if c_rec == record_every:
            c_rec = 0
    t = k_stop * dt
    rhs_named(t, y, st.adem, tr, w, K[0:ny])
    record_named(k_stop // record_every, y, K, tr, w, out)
    return 0


# ----------------------------------------------------------------- a case for both
def case(steps: int, n: int = 10, dt: float = 1e-4, record_every: int = 10):
    """Arrays of one run of ``steps`` steps of an ``n``-vehicle train, ode3."""
    rng = np.random.default_rng(1)
    veh = np.zeros((n, 5))
    veh[:, MASS] = 8e4 + 1e4 * rng.random(n)
    veh[:, DA], veh[:, DB], veh[:, DC] = 1e3, 20.0, 3.0
    veh[:, P0] = -np.arange(n) * 15.0
    cpl = np.zeros((n - 1, 5))
    cpl[:, SLACK], cpl[:, K1], cpl[:, K3], cpl[:, DAMP] = 0.02, 2e7, 5e11, 5e4
    tpos = np.linspace(-500.0, 5000.0, 40)
    tgrade = 0.005 * np.sin(np.arange(40.0))
    prof_t = np.array([0.0, 20.0, 40.0, 1e4])
    prof_y = np.array([0.0, 10.0, 10.0, 10.0])
    A = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.75, 0.0]])
    B = np.array([2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0])
    C = np.array([0.0, 0.5, 0.75])
    n_rec = steps // record_every + 1
    return dict(n=n, dt=dt, steps=steps, record_every=record_every, veh=veh, cpl=cpl,
                tpos=tpos, tgrade=tgrade, prof_t=prof_t, prof_y=prof_y, A=A, B=B, C=C,
                n_rec=n_rec, every=10, kp=0.5, ki=0.05,
                trac=np.array([veh[:, MASS].sum(), 4e5, 0.0, 9.81]))


def _outputs(c):
    n, r = c["n"], c["n_rec"]
    return (np.zeros((r, n)), np.zeros((r, n)), np.zeros((r, n)), np.zeros((r, n - 1)),
            np.zeros((r, 3)), np.tile([-np.inf, np.inf], (n - 1, 1)))


def call_pos(c, steps=None):
    n = c["n"]
    y = np.zeros(2 * n)
    ctrl = np.zeros(3)
    outs = _outputs(c)
    work = np.zeros(3 * 2 * n + 2 * n + (n - 1) + 2 * n + N_SIG)
    hints = np.zeros(n + 1, dtype=np.int64)
    run_pos(y, ctrl, 0, c["steps"] if steps is None else steps, c["dt"], c["every"],
            c["record_every"], c["kp"], c["ki"], c["A"], c["B"], c["C"], c["veh"], c["cpl"],
            c["tpos"], c["tgrade"], c["trac"], c["prof_t"], c["prof_y"], *outs, work, hints)
    return y, outs


def call_named(c, steps=None):
    n = c["n"]
    y = np.zeros(2 * n)
    ctrl = np.zeros(1, dtype=CTRL)
    x, v, a, f, s, peaks = _outputs(c)
    out = Outputs(x, v, a, f, s, peaks)
    w = Work(np.zeros(3 * 2 * n), np.zeros(2 * n), np.zeros(n - 1), np.zeros(n), np.zeros(n),
             np.zeros(1, dtype=SIG), np.zeros(n + 1, dtype=np.int64))
    tr = Train(c["veh"], c["cpl"], c["tpos"], c["tgrade"], c["trac"][0], c["trac"][1],
               int(c["trac"][2]), c["trac"][3])
    drv = Driver(c["prof_t"], c["prof_y"], c["kp"], c["ki"], c["every"])
    run_named(y, ctrl, 0, c["steps"] if steps is None else steps, c["dt"], c["record_every"],
              Tableau(c["A"], c["B"], c["C"]), tr, drv, w, out)
    return y, tuple(out)


CALLS = {"positional": call_pos, "named": call_named}
KERNELS = {"positional": run_pos, "named": run_named}
