"""The compiled simulation loop: right-hand side, controller and Runge-Kutta stepping.

Everything here runs under numba with flat arrays only (see :mod:`ltdsim.lowering` for
the layout). The state vector is ``y = [x_0..x_(n-1), v_0..v_(n-1), z...]``: displacement of
each vehicle from its initial position (m), its speed (m/s), and three internal states
per hysteretic draft gear (internal force N, plate displacement m, impact speed m/s; see
:mod:`ltdsim.physics.draftgear`). The discrete PID is
sampled between steps and its output held over the step (zero-order hold), as a
digital controller is; every continuous quantity is a pure function of ``(t, y)``, so
any Runge-Kutta method can evaluate it any number of times per step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.lowering import (
    C_LINEAR, C_SIMPLIFIED, C_WEDGE, D_EVERY, D_FILT, D_INT, D_KD, D_KI, D_KP, D_MODE, D_N,
    D_TS, MODE_SPEED,
    P_BACK, P_C1, P_C2, P_C3, P_D0, P_DAMP, P_F0, P_G, P_GAP, P_H1, P_H2, P_H3, P_K1, P_K2, P_K3,
    P_KLOCK, P_KM, P_KR, P_KSOLID, P_NLOAD, P_NUNL, P_PRELOAD, P_RATE, P_S, P_SLACK, P_SNV,
    P_SNX, P_STAB, P_STIFF, P_TA, P_TB, P_TG, P_TLOAD, P_TRAVEL, P_TUNL, P_VC, P_XM0, P_XR0,
    P_ZOFF,
    T_DMAX, T_AMAX, T_FF, T_FMAX, T_G, T_MADH, T_MTOT, T_PMAX, T_REF,
    V_DA, V_DB, V_DC, V_DV0, V_MASS, V_P0, V_SHARE, V_WMASS,
)
from ltdsim.physics.control import pid_step
from ltdsim.physics.couplers import coupler_linear, coupler_simplified
from ltdsim.physics.draftgear import (
    hysteresis, plate_rate, plates_carried, plates_out, s_table_lookup, table_curve,
    wedge_curves,
)
from ltdsim.physics.resistance import curve_resistance, davis_resistance, grade_resistance
from ltdsim.physics.traction import adhesion_limit, traction_limit

#: kernel return codes
OK, NONFINITE = 0, 1
#: columns of the recorded scalar signals
S_TRACTION, S_VREF, S_ADHESION, S_ADEM, S_DEMAND = range(5)
N_SCALARS = 5
#: controller state: [PID integrator, PID filter, held demand m/s^2, last reference m/s]
N_CTRL = 4


@njit(cache=True, inline="always")
def _segment(xs, x, hint):
    """Index k of the segment ``xs[k] <= x < xs[k+1]`` (0 before the first point).

    Starts from the previous answer ``hint``, so a slowly moving argument costs O(1).
    The answer does not depend on the hint: it only speeds up the search.
    """
    k = hint
    m = xs.shape[0]
    while k + 1 < m and xs[k + 1] <= x:
        k += 1
    while k > 0 and xs[k] > x:
        k -= 1
    return k


@njit(cache=True, inline="always")
def _interp(xs, ys, x, hints, slot):
    """Linear interpolation of ``(xs, ys)`` at ``x``, constant beyond the ends."""
    k = _segment(xs, x, hints[slot])
    hints[slot] = k
    if x <= xs[0]:
        return ys[0]
    if k + 1 >= xs.shape[0]:
        return ys[k]
    w = (x - xs[k]) / (xs[k + 1] - xs[k])
    return ys[k] + w * (ys[k + 1] - ys[k])


@njit(cache=True, inline="always")
def _gear(j, model, d, dd, y, zo, dy, dzo, cpl, ctab):
    """Force (N, + tension) of hysteretic gear ``j``; writes its state rates to ``dy``.

    ``zo``/``dzo`` index the gear's three states in ``y``/``dy``: internal force F1 (N),
    plate displacement p (m), impact speed v0 (m/s).
    """
    slack = cpl[j, P_SLACK]
    h = 0.5 * slack
    rate = cpl[j, P_RATE]
    f1 = y[zo]
    p = y[zo + 1]
    v0 = y[zo + 2]
    wedge = model == C_WEDGE
    gap = cpl[j, P_GAP]
    delta = cpl[j, P_BACK]
    in_slack = False
    if d > h:
        x = d - h
        sgn = 1.0
    elif d < -h:
        x = -(d + h)
        sgn = -1.0
    elif slack > 0.0:
        in_slack = True
        x = 0.0
        sgn = 1.0
    else:
        x = 0.0
        sgn = 1.0 if dd >= 0.0 else -1.0
    if in_slack:
        # no force. The gear extends fully and its wedges come free, so it meets the next
        # load on its loading curve (F1 relaxes to the released force f_l(0)); the plates
        # go home; the impact speed follows the closing speed so that it holds its value
        # at contact. (States within 1e-12 of rest stop there: an endless exponential
        # decay ends in subnormal numbers, which are slow on every CPU.)
        dy[dzo] = rate * (cpl[j, P_F0] - f1)
        dy[dzo + 1] = plate_rate(-gap, p, 0.0, delta, rate) if p > 1e-12 else 0.0
        dy[dzo + 2] = rate * (abs(dd) - v0)
        return 0.0
    v = sgn * dd  # > 0 while the gear closes
    if wedge:
        off = int(cpl[j, P_STAB])
        if off >= 0:
            s_factor = s_table_lookup(ctab, off, int(cpl[j, P_SNV]), int(cpl[j, P_SNX]), v0, x)
        else:
            s_factor = cpl[j, P_S]
        u = x - gap
        ramp = max(delta, 1e-3)  # plate friction fades in and out over this travel, m
        f_l, f_u, s_l, s_u = wedge_curves(
            x, v, cpl[j, P_TA], cpl[j, P_TB], cpl[j, P_TG], cpl[j, P_G], cpl[j, P_C1],
            cpl[j, P_C2], cpl[j, P_C3], cpl[j, P_H1], cpl[j, P_H2], cpl[j, P_H3], s_factor,
            cpl[j, P_KM], cpl[j, P_XM0], cpl[j, P_KR], cpl[j, P_XR0], plates_out(p, ramp),
            plates_out(p, ramp) if plates_carried(u, p, delta) else 0.0)
    else:
        f_l, s_l = table_curve(ctab, int(cpl[j, P_TLOAD]), int(cpl[j, P_NLOAD]), x)
        f_u, s_u = table_curve(ctab, int(cpl[j, P_TUNL]), int(cpl[j, P_NUNL]), x)
    over = x - cpl[j, P_TRAVEL]
    if over > 0.0:  # closed solid
        ks = cpl[j, P_KSOLID]
        f_l += ks * over
        f_u += ks * over
        s_l += ks
        s_u += ks
    if f_u > f_l:
        f_u = f_l
    f, df1 = hysteresis(f1, f_l, f_u, s_l, s_u, v, cpl[j, P_KLOCK], rate)
    if f < 0.0:
        f = 0.0
    dy[dzo] = df1
    dy[dzo + 1] = plate_rate(x - gap, p, v, delta, rate) if wedge else 0.0
    dy[dzo + 2] = 0.0
    return sgn * f


@njit(cache=True, inline="always")
def coupler_force(j, model, d, dd, y, z0, dy, dz0, cpl, ctab):
    """Force of coupler ``j`` (N, + tension) at deflection ``d`` (m) and rate ``dd``
    (m/s). A hysteretic gear reads its states at ``y[z0 + offset]`` and writes their
    rates to ``dy[dz0 + offset]``."""
    if model == C_SIMPLIFIED:
        return coupler_simplified(d, dd, cpl[j, P_SLACK], cpl[j, P_PRELOAD], cpl[j, P_DAMP],
                                  cpl[j, P_K1], cpl[j, P_K2], cpl[j, P_K3], cpl[j, P_VC])
    if model == C_LINEAR:
        return coupler_linear(d, dd, cpl[j, P_SLACK], cpl[j, P_STIFF], cpl[j, P_DAMP])
    zo = int(cpl[j, P_ZOFF])
    return _gear(j, model, d, dd, y, z0 + zo, dy, dz0 + zo, cpl, ctab)


@njit(cache=True, inline="always")
def rhs(t, y, a_dem, veh, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h, trac,
        drv, prof_t, prof_y, dy, off, force, defl, res, sig, hints):
    """Right-hand side ``dy/dt`` at ``(t, y)``, written to ``dy[off:off + len(y)]``.

    Also fills ``force``/``defl`` (coupler force N, deflection m), ``res`` (resistance
    per vehicle, N) and ``sig[0:3]`` (traction force N, speed of the reference vehicle
    m/s, traction demand before the traction-curve limit N). ``hints``
    holds search cursors (``[0, n)`` track, ``n`` force and ``n + 1`` speed profile); they change
    only how fast a lookup is, never its result.
    """
    n = veh.shape[0]
    g = trac[T_G]
    rtot = 0.0
    for i in range(n):
        v = y[n + i]
        p = veh[i, V_P0] + y[i]
        wm = veh[i, V_WMASS]
        r = davis_resistance(v, veh[i, V_DA], veh[i, V_DB], veh[i, V_DC], veh[i, V_DV0])
        kt = _segment(tpos, p, hints[i])
        hints[i] = kt
        r += grade_resistance(wm, tgrade[kt], g)
        r += curve_resistance(v, wm, tcurv[kt], curve_h, g)
        res[i] = r
        rtot += r
    vl = y[n + int(trac[T_REF])]
    if drv[D_MODE] == MODE_SPEED:
        fd = a_dem * trac[T_MTOT] + trac[T_FF] * rtot
    else:
        fd = _interp(prof_t, prof_y, t, hints, n)
    lim = traction_limit(vl, trac[T_FMAX], trac[T_PMAX], trac[T_MADH], g)
    ftr = min(max(fd, -lim), lim)
    sig[0] = ftr
    sig[1] = vl
    sig[2] = fd
    for j in range(n - 1):
        d = y[j] - y[j + 1] + cpl[j, P_D0]
        dd = y[n + j] - y[n + j + 1]
        f = coupler_force(j, cpl_model[j], d, dd, y, 2 * n, dy, off + 2 * n, cpl, ctab)
        force[j] = f
        defl[j] = d
    for i in range(n):
        f = veh[i, V_SHARE] * ftr - res[i]
        if i < n - 1:
            f -= force[i]
        if i > 0:
            f += force[i - 1]
        dy[off + i] = y[n + i]
        dy[off + n + i] = f * inv_m[i]


def work_size(n: int, ny: int, stages: int) -> int:
    """Length of the float work array :func:`run` needs for ``n`` vehicles and a state
    of ``ny`` elements."""
    return stages * ny + ny + 2 * max(n - 1, 1) + 2 * n + 3


@njit(cache=True, _nrt=False)
def run(y, ctrl, k_start, k_stop, n_steps, record_every, dt, A, B, C,
        veh, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h, trac, drv, prof_t, prof_y,
        out_x, out_v, out_a, out_d, out_f, out_s, work, hints):
    """Advance ``y`` from step ``k_start`` to ``k_stop`` (time ``k dt``), recording.

    Records the state at every step that is a multiple of ``record_every`` (record
    ``k // record_every``) and, when ``k_stop == n_steps``, the final state.
    ``y`` and ``ctrl`` are updated in place so a run can be split into chunks.

    ``work`` is a float array of :func:`work_size` elements and ``hints`` an int64 array
    of ``n + 2`` zeros (search cursors), both owned by the caller.

    Returns ``(status, k)``: ``OK`` and ``k_stop``, or ``NONFINITE`` and the step whose
    result was not finite (``y`` then holds that state).
    """
    n = veh.shape[0]
    ny = y.shape[0]
    ns = B.shape[0]
    nc = max(n - 1, 1)
    # Work arrays are views into ``work`` (see work_size). The kernel is compiled
    # without NRT, so views and array arguments cost no reference counting in the loop.
    K = work[0:ns * ny]  # stage s occupies K[s * ny:(s + 1) * ny]
    o = ns * ny
    ytmp = work[o:o + ny]
    o += ny
    force = work[o:o + nc]
    o += nc
    defl = work[o:o + nc]
    o += nc
    res = work[o:o + n]
    o += n
    inv_m = work[o:o + n]
    o += n
    sig = work[o:o + 3]
    for i in range(n):
        inv_m[i] = 1.0 / veh[i, V_MASS]
    speed_mode = drv[D_MODE] == MODE_SPEED
    every = int(drv[D_EVERY])
    ref = int(trac[T_REF])
    kp, ki, kd, nf, ts = drv[D_KP], drv[D_KI], drv[D_KD], drv[D_N], drv[D_TS]
    imeth, fmeth = int(drv[D_INT]), int(drv[D_FILT])
    amax, dmax = trac[T_AMAX], trac[T_DMAX]
    # counters instead of k % every: integer division is slow in the loop
    c_ctrl = k_start % every
    c_rec = k_start % record_every
    for k in range(k_start, k_stop):
        t = k * dt
        if speed_mode and c_ctrl == 0:
            vref = _interp(prof_t, prof_y, t, hints, n + 1)
            u = pid_step(vref - y[n + ref], ctrl, kp, ki, kd, nf, ts, imeth, fmeth)
            ctrl[2] = min(max(u, -dmax), amax)
            ctrl[3] = vref
        a_dem = ctrl[2]
        # stage 1 is the right-hand side at (t_k, y_k): record it when due
        rhs(t, y, a_dem, veh, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h, trac,
            drv, prof_t, prof_y, K, 0, force, defl, res, sig, hints)
        if c_rec == 0:
            _record(k // record_every, t, y, K, force, defl, sig, a_dem, speed_mode,
                    prof_t, prof_y, hints, trac, veh, out_x, out_v, out_a, out_d, out_f, out_s)
        for s in range(1, ns):
            for q in range(ny):
                ytmp[q] = y[q]
            for j in range(s):
                w = dt * A[s, j]
                if w != 0.0:
                    o = j * ny
                    for q in range(ny):
                        ytmp[q] += w * K[o + q]
            rhs(t + C[s] * dt, ytmp, a_dem, veh, inv_m, cpl_model, cpl, ctab, tpos, tgrade,
                tcurv, curve_h, trac, drv, prof_t, prof_y, K, s * ny, force, defl, res, sig,
                hints)
        # y += dt * sum_s b_s K_s, increment summed first for accuracy
        for q in range(ny):
            ytmp[q] = 0.0
        for s in range(ns):
            w = dt * B[s]
            o = s * ny
            for q in range(ny):
                ytmp[q] += w * K[o + q]
        total = 0.0
        for q in range(ny):
            y[q] += ytmp[q]
            total += y[q]
        if not (total - total == 0.0):
            return NONFINITE, k + 1
        c_ctrl += 1
        if c_ctrl == every:
            c_ctrl = 0
        c_rec += 1
        if c_rec == record_every:
            c_rec = 0
    if k_stop == n_steps:
        t = k_stop * dt
        rhs(t, y, ctrl[2], veh, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h, trac,
            drv, prof_t, prof_y, K, 0, force, defl, res, sig, hints)
        _record(k_stop // record_every, t, y, K, force, defl, sig, ctrl[2], speed_mode,
                prof_t, prof_y, hints, trac, veh, out_x, out_v, out_a, out_d, out_f, out_s)
    return OK, k_stop


@njit(cache=True, inline="always")
def _record(r, t, y, dy, force, defl, sig, a_dem, speed_mode, prof_t, prof_y, hints, trac, veh,
            out_x, out_v, out_a, out_d, out_f, out_s):
    n = out_x.shape[1]
    for i in range(n):
        out_x[r, i] = y[i] + veh[i, V_P0]  # track position
        out_v[r, i] = y[n + i]
        out_a[r, i] = dy[n + i]  # stage-1 derivatives sit at offset 0
    for j in range(n - 1):
        out_d[r, j] = defl[j]
        out_f[r, j] = force[j]
    out_s[r, S_TRACTION] = sig[0]
    out_s[r, S_ADHESION] = adhesion_limit(sig[1], trac[T_MADH], trac[T_G])
    out_s[r, S_DEMAND] = sig[2]
    if speed_mode:
        out_s[r, S_VREF] = _interp(prof_t, prof_y, t, hints, n + 1)
        out_s[r, S_ADEM] = a_dem
    else:
        out_s[r, S_VREF] = np.nan
        out_s[r, S_ADEM] = np.nan
