"""The records (one row per record time, of the arrays the run keeps: ``solver.record``)
and the peak coupler forces over every step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.engine.features import when
from ltdsim.engine.kernel.structs import (
    PK_MAX, PK_MIN, PK_TMAX, PK_TMIN, SG_ADEM, SG_ADHESION, SG_BRAKE, SG_DEMAND,
    SG_TRACTION, SG_VREF,
)
from ltdsim.engine.kernel.tables import _interp
from ltdsim.engine.couplers import P_D0
from ltdsim.engine.layout import (
    A_ATM, ABSURD_DEFLECTION, ABSURD_PRESSURE, ABSURD_SPEED, I_CELLS, I_EXH, I_PIPE, K_MADH,
    K_VEH, N_DRIVE_SIGNALS, T_EZ, T_G, V_BCELL, V_BPFS, V_BZ, V_MASS, V_P0,
)
from ltdsim.physics.air.brakevalves import CV_AUX, CV_CYL
from ltdsim.physics.drive.traction import adhesion_max


@njit(cache=True, inline="always")
def _fold_peak(peaks, j, f, t):
    """Fold force ``f`` (N) of coupler ``j`` at time ``t`` (s) into row j of the peak
    table (``PK_*`` columns)."""
    if f > peaks[j, PK_MAX]:
        peaks[j, PK_MAX] = f
        peaks[j, PK_TMAX] = t
    if f < peaks[j, PK_MIN]:
        peaks[j, PK_MIN] = f
        peaks[j, PK_TMIN] = t


@njit(cache=True, inline="always")
def _track_peaks(force, peaks, nc, t):
    """:func:`_fold_peak` for every coupler."""
    for j in range(nc):
        _fold_peak(peaks, j, force[j], t)


@njit(cache=True, _nrt=False, forceinline=True)
def _record_air(r, y, tr, out):
    """The fluid brake's part of record ``r`` (:func:`_record`): the pipe pressure at
    each vehicle, its auxiliary reservoir and brake cylinder (Pa gauge), the cylinder's
    fill (its pressure over the full-service pressure) and the air exhausted (kg)."""
    veh = tr.veh
    n = veh.shape[0]
    atm = tr.air.gas[A_ATM]
    zp = tr.air.index[I_PIPE]
    for i in range(out.bp.shape[1]):
        out.bp[r, i] = y[zp + int(veh[i, V_BCELL])] - atm
    for i in range(n):
        zb = int(veh[i, V_BZ])
        aux = y[zb + CV_AUX] - atm if zb >= 0 else np.nan
        cyl = y[zb + CV_CYL] - atm if zb >= 0 else np.nan
        if out.ar.shape[1] > 0:
            out.ar[r, i] = aux
        if out.bc.shape[1] > 0:
            out.bc[r, i] = cyl
        if out.p.shape[1] > 0:
            out.p[r, i] = cyl / veh[i, V_BPFS] if zb >= 0 else 0.0
    if out.ax.shape[1] > 0:
        out.ax[r, 0] = y[tr.air.index[I_EXH]]


@njit(cache=True, _nrt=False, forceinline=True)
def _record(r, t, y, dy, a_dem, level, speed_mode, tr, dr, w, out):
    """Write record ``r`` at time ``t`` (s) of state ``y`` to ``out``: positions,
    speeds, the accelerations ``dy[n:2n]`` (stage 1 at ``(t, y)``), coupler
    deflections and forces, brakes and consist forces from ``w``, the scalar signals
    with the held demand ``a_dem`` (m/s^2) and the last brake level (0-1). A record
    array of width 0 is one the run does not record (``solver.record``)."""
    veh = tr.veh
    cons = tr.cons
    trac = tr.trac
    out_s = out.s
    n = veh.shape[0]
    for i in range(out.x.shape[1]):
        out.x[r, i] = y[i] + veh[i, V_P0]  # track position
    for i in range(out.v.shape[1]):
        out.v[r, i] = y[n + i]
    for i in range(out.a.shape[1]):
        out.a[r, i] = dy[n + i]  # stage-1 derivatives sit at offset 0
    for j in range(out.d.shape[1]):
        out.d[r, j] = w.defl[j]
    for j in range(out.f.shape[1]):
        out.f[r, j] = w.force[j]
    fluid = w.inflow.shape[0] > 0  # the fluid brake's pipe cells
    for i in range(out.b.shape[1]):
        out.b[r, i] = w.bforce[i] if veh[i, V_BZ] >= 0 else 0.0
    if not fluid:
        for i in range(out.p.shape[1]):
            zb = int(veh[i, V_BZ])
            out.p[r, i] = y[zb] if zb >= 0 else 0.0
    else:
        when(tr.features.fluid, _record_air, None, r, y, tr, out)
    if out.c.shape[1] > 0:
        for c in range(cons.shape[0]):
            out.c[r, c] = w.fcons[c]
    for kd in range(out.m.shape[1]):
        for q in range(N_DRIVE_SIGNALS):
            out.m[r, kd, q] = w.dsig[kd, q]
    ne = out.e.shape[1]
    if ne > 0:
        ez = int(trac[T_EZ])  # (run_adaptive integrates them as states, run sums them)
        for q in range(ne - 1):
            out.e[r, q] = y[ez + q] if ez >= 0 else w.energy[q]
        kin = 0.0
        for i in range(n):
            kin += 0.5 * veh[i, V_MASS] * y[n + i] * y[n + i]
        out.e[r, ne - 1] = kin
    sig = w.sig[0]
    out_s[r, SG_TRACTION] = sig["traction"]
    adh = 0.0
    for c in range(cons.shape[0]):
        adh += adhesion_max(y[n + int(cons[c, K_VEH])], cons[c, K_MADH], trac[T_G])
    out_s[r, SG_ADHESION] = adh
    out_s[r, SG_DEMAND] = sig["demand"]
    out_s[r, SG_BRAKE] = level
    if speed_mode:
        out_s[r, SG_VREF] = _interp(dr.prof_t, dr.prof_y, t, w.hints, n + 1)
        out_s[r, SG_ADEM] = a_dem
    else:
        out_s[r, SG_VREF] = np.nan
        out_s[r, SG_ADEM] = np.nan


@njit(cache=True, _nrt=False, forceinline=True)
def _implausible(y, tr, cpl):
    """The first part of the finite state ``y`` beyond any physical bound
    (:data:`ltdsim.engine.layout.ABSURD_SPEED`, ``ABSURD_DEFLECTION``,
    ``ABSURD_PRESSURE``), or -1: vehicle ``i``'s speed as ``i``, coupler ``j``'s
    deflection (``cpl`` the couplers' rows) as ``n + j``, the brake pipe's cell ``c``
    as ``2 n - 1 + c``. Checked where the state is recorded: a run that blows up while
    staying finite stops there (:data:`~ltdsim.engine.kernel.structs.ABSURD`)."""
    n = tr.veh.shape[0]
    for i in range(n):
        if abs(y[n + i]) > ABSURD_SPEED:
            return i
    for j in range(n - 1):
        if abs(y[j] - y[j + 1] + cpl[j, P_D0]) > ABSURD_DEFLECTION:
            return n + j
    zp = tr.air.index[I_PIPE]
    if zp >= 0:
        for c in range(tr.air.index[I_CELLS]):
            p = y[zp + c]
            if p < 0.0 or p > ABSURD_PRESSURE:
                return 2 * n - 1 + c
    return -1
