"""The compiled simulation loop: right-hand side, controller and Runge-Kutta stepping.

Everything here runs under numba with flat arrays only (see :mod:`ltdsim.lowering` for
the layout). The state vector is ``y = [x_0..x_(n-1), v_0..v_(n-1), z...]``: displacement of
each vehicle from its initial position (m), its speed (m/s), and the internal states of
the hysteretic draft gears (internal force N; wedge gears also the plate displacement m,
and with an S table the impact speed m/s; see
:mod:`ltdsim.physics.draftgear`). The discrete PID is
sampled between steps and its output held over the step (zero-order hold), as a
digital controller is; every continuous quantity is a pure function of ``(t, y)``, so
any Runge-Kutta method can evaluate it any number of times per step.

Compiling. The small helpers are inlined by numba into their callers
(``inline="always"``). The large ones (:func:`rhs`, :func:`_gear`, :func:`_record`,
:func:`_controller`, :func:`_brake_commands`) are compiled once each and inlined by
LLVM instead (``forceinline=True``): numba's own inlining copies and types a function's
whole body again at every call site, and with the right-hand side called from three
places in :func:`run` and four in :func:`run_adaptive` their first compile took about
140 s and 200 s of CPU (now about 17 s each, and the second shares most of the first).
The compiled kernels hold no calls to these functions: the machine code does the same
work as before. No argument of these functions may be a constant at a call site either:
numba compiles a function once per set of argument types, and a constant such as ``0``
or ``True`` is a type of its own (hence the stage slices ``K[s * ny:(s + 1) * ny]``
rather than an offset ``0``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.lowering import (
    C_LINEAR,
    C_SIMPLIFIED,
    C_WEDGE,
    D_BCTRL,
    D_BFULLSUM,
    D_BPLEN,
    D_BPOFF,
    D_BSHOEREF,
    D_BSLEN,
    D_BSOFF,
    D_BSTEP,
    D_BTAUA,
    D_BTAUR,
    D_AW,
    D_BVS,
    D_EVERY,
    D_FILT,
    D_INT,
    D_KD,
    D_KI,
    D_KP,
    D_MODE,
    D_N,
    D_TS,
    K_DBFADE,
    K_FMAX,
    K_MADH,
    K_NLEN,
    K_NOFF,
    K_PMAX,
    K_RATE,
    K_SHARE,
    K_TAU,
    K_VEH,
    K_Z,
    MODE_FORCE,
    MODE_NOTCH,
    MODE_SPEED,
    P_BACK,
    P_C1,
    P_C2,
    P_C3,
    P_D0,
    P_DAMP,
    P_F0,
    P_G,
    P_GAP,
    P_H1,
    P_H2,
    P_H3,
    P_K1,
    P_K2,
    P_K3,
    P_KLOCK,
    P_KM,
    P_KR,
    P_KSOLID,
    P_NLOAD,
    P_NUNL,
    P_PRELOAD,
    P_RATE,
    P_S,
    P_SLACK,
    P_SNV,
    P_SNX,
    P_STAB,
    P_STIFF,
    P_TA,
    P_TB,
    P_TG,
    P_TLOAD,
    P_TRAVEL,
    P_TUNL,
    P_IVC,
    P_XM0,
    P_XR0,
    P_ZOFF,
    T_AMAX,
    T_DMAX,
    T_FF,
    T_G,
    T_MTOT,
    T_REF,
    V_BDELAY,
    V_BFRIC,
    V_BFULL,
    V_BMU,
    V_BNTAB,
    V_BSHOE,
    V_BTAB,
    V_BZ,
    V_CONS,
    V_DA,
    V_DB,
    V_DC,
    V_DIV0,
    V_MASS,
    V_P0,
    V_SHARE,
    V_WMASS,
)
from ltdsim.physics.brakes import (
    FRICTION_CONSTANT,
    FRICTION_KARWATZKI,
    brake_retardation,
    karwatzki,
)
from ltdsim.physics.control import pid_step
from ltdsim.physics.couplers import coupler_linear, simplified_force, solid_closure
from ltdsim.physics.draftgear import (
    hysteresis,
    plate_rate,
    plates_carried,
    plates_out,
    s_table_lookup,
    table_curve,
    wedge_curves,
)
from ltdsim.physics.resistance import (
    curve_resistance,
    davis_force,
    grade_resistance,
)
from ltdsim.physics.traction import adhesion_limit, traction_limit

#: kernel return codes
OK, NONFINITE, EVENTS_FULL = 0, 1, 2
#: columns of the recorded scalar signals
S_TRACTION, S_VREF, S_ADHESION, S_ADEM, S_DEMAND, S_BRAKE = range(6)
N_SCALARS = 6
#: length of the right-hand side's signal vector (traction, reference speed, demand,
#: total resistance)
N_SIG = 4
#: controller state: PID integrator and filter (0, 1), held demand m/s^2, last reference
#: m/s, number of brake commands issued, last commanded level, next scheduled command,
#: next position trigger, next controller sample (bs23)
(C_PI, C_PF, C_ADEM, C_VREF, C_NEV, C_LEVEL, C_NEXT_SCHED, C_NEXT_POS,
 C_NEXT_SAMPLE) = range(9)
N_CTRL = 9


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


@njit(cache=True, _nrt=False, forceinline=True)
def _gear(j, model, d, dd, y, zo, dy, dzo, cpl, ctab):
    """Force (N, + tension) of hysteretic gear ``j``; writes its state rates to ``dy``.

    ``zo``/``dzo`` index the gear's states in ``y``/``dy``: internal force F1 (N); for a
    wedge gear also the plate displacement p (m); with an S table also the impact speed
    v0 (m/s).

    Compiled once for the train kernels and the gear rig (:mod:`ltdsim.gear`), inlined
    by LLVM (see the module's notes on compiling).
    """
    slack = cpl[j, P_SLACK]
    h = 0.5 * slack
    rate = cpl[j, P_RATE]
    wedge = model == C_WEDGE
    s_table = wedge and cpl[j, P_STAB] >= 0.0
    f1 = y[zo]
    p = y[zo + 1] if wedge else 0.0
    v0 = y[zo + 2] if s_table else 0.0
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
        if wedge:
            dy[dzo + 1] = plate_rate(-gap, p, 0.0, delta, rate) if p > 1e-12 else 0.0
        if s_table:
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
        engaged = plates_out(p, ramp)
        f_l, f_u, s_l, s_u = wedge_curves(
            x, v, cpl[j, P_TA], cpl[j, P_TB], cpl[j, P_TG], cpl[j, P_G], cpl[j, P_C1],
            cpl[j, P_C2], cpl[j, P_C3], cpl[j, P_H1], cpl[j, P_H2], cpl[j, P_H3], s_factor,
            cpl[j, P_KM], cpl[j, P_XM0], cpl[j, P_KR], cpl[j, P_XR0], engaged,
            engaged if plates_carried(u, p, delta) else 0.0)
    else:
        f_l, s_l = table_curve(ctab, int(cpl[j, P_TLOAD]), int(cpl[j, P_NLOAD]), x)
        f_u, s_u = table_curve(ctab, int(cpl[j, P_TUNL]), int(cpl[j, P_NUNL]), x)
    ks = cpl[j, P_KSOLID]
    solid = solid_closure(x, cpl[j, P_TRAVEL], ks)
    if solid > 0.0:  # closed solid
        f_l += solid
        f_u += solid
        s_l += ks
        s_u += ks
    if f_u > f_l:
        f_u = f_l
    f, df1 = hysteresis(f1, f_l, f_u, s_l, s_u, v, cpl[j, P_KLOCK], rate)
    if f < 0.0:
        f = 0.0
    dy[dzo] = df1
    if wedge:
        dy[dzo + 1] = plate_rate(x - gap, p, v, delta, rate)
    if s_table:
        dy[dzo + 2] = 0.0
    return sgn * f


@njit(cache=True, inline="always")
def coupler_force(j, model, d, dd, y, z0, dy, dz0, cpl, ctab):
    """Force of coupler ``j`` (N, + tension) at deflection ``d`` (m) and rate ``dd``
    (m/s). A hysteretic gear reads its states at ``y[z0 + offset]`` and writes their
    rates to ``dy[dz0 + offset]``."""
    if model == C_SIMPLIFIED:
        return simplified_force(d, dd, cpl[j, P_SLACK], cpl[j, P_PRELOAD], cpl[j, P_DAMP],
                                cpl[j, P_K1], cpl[j, P_K2], cpl[j, P_K3], cpl[j, P_IVC],
                                cpl[j, P_TRAVEL], cpl[j, P_KSOLID])
    if model == C_LINEAR:
        return coupler_linear(d, dd, cpl[j, P_SLACK], cpl[j, P_STIFF], cpl[j, P_DAMP],
                              cpl[j, P_TRAVEL], cpl[j, P_KSOLID])
    zo = int(cpl[j, P_ZOFF])
    return _gear(j, model, d, dd, y, z0 + zo, dy, dz0 + zo, cpl, ctab)


@njit(cache=True, inline="always")
def _held(xs, ys, x, hints, slot):
    """Value of the step function ``(xs, ys)`` at ``x``: ``ys[k]`` from ``xs[k]`` on."""
    k = _segment(xs, x, hints[slot])
    hints[slot] = k
    return ys[k]


@njit(cache=True, inline="always")
def _held_at(tab, off, m, x):
    """Step function stored as ``m`` abscissae then ``m`` values from ``tab[off]``."""
    k = 0
    while k + 1 < m and tab[off + k + 1] <= x:
        k += 1
    return tab[off + m + k]


@njit(cache=True, inline="always")
def _interp_at(tab, off, m, x):
    """Linear interpolation of ``m`` points stored as abscissae then values from
    ``tab[off]``, constant beyond the ends."""
    if x <= tab[off]:
        return tab[off + m]
    k = 0
    while k + 1 < m and tab[off + k + 1] <= x:
        k += 1
    if k + 1 >= m:
        return tab[off + m + k]
    x0 = tab[off + k]
    w = (x - x0) / (tab[off + k + 1] - x0)
    return tab[off + m + k] + w * (tab[off + m + k + 1] - tab[off + m + k])


@njit(cache=True, inline="always")
def shoe_friction(i, v, shoe_force, veh, ctab):
    """Shoe-wheel friction coefficient of vehicle ``i``'s brake at speed ``v`` (m/s)
    and force per shoe ``shoe_force`` (N)."""
    model = int(veh[i, V_BFRIC])
    if model == FRICTION_KARWATZKI:
        return karwatzki(v, shoe_force)
    if model == FRICTION_CONSTANT:
        return veh[i, V_BMU]
    return _interp_at(ctab, int(veh[i, V_BTAB]), int(veh[i, V_BNTAB]), abs(v))


@njit(cache=True, inline="always")
def brake_target(t, delay, events, n_events):
    """Brake level (0-1) that the latest command to have reached a vehicle with signal
    delay ``delay`` (s) asks for at time ``t`` (s); 0 before any command arrives."""
    e = n_events - 1
    while e >= 0:
        if events[e, 0] + delay <= t:
            return events[e, 1]
        e -= 1
    return 0.0


@njit(cache=True, _nrt=False, forceinline=True)
def rhs(t, y, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h,
        trac, drv, prof_t, prof_y, events, n_events, dy, force, defl, res, bforce, fcons,
        sig, hints):
    """Right-hand side ``dy/dt`` at ``(t, y)``, written to ``dy`` (``len(y)`` elements).

    Also fills ``force``/``defl`` (coupler force N, deflection m), ``res`` (resistance
    per vehicle, N), ``bforce`` (air-brake force per vehicle, N, + opposing forward
    motion), ``fcons`` (force of each locomotive consist, N) and ``sig[0:4]`` (total
    traction force N, speed of the reference vehicle m/s, traction demand before the
    traction-curve limits N, total resistance N). ``hints`` holds search cursors
    (``[0, n)`` track, ``n`` driver profile, ``n + 1`` speed profile, ``n + 2 + c`` the
    own notch profile of consist c); they change only how fast a lookup is, never its
    result.
    """
    n = veh.shape[0]
    g = trac[T_G]
    rtot = 0.0
    for i in range(n):
        v = y[n + i]
        p = veh[i, V_P0] + y[i]
        wm = veh[i, V_WMASS]
        r = davis_force(v, veh[i, V_DA], veh[i, V_DB], veh[i, V_DC], veh[i, V_DIV0])
        kt = _segment(tpos, p, hints[i])
        hints[i] = kt
        r += grade_resistance(wm, tgrade[kt], g)
        r += curve_resistance(v, wm, tcurv[kt], curve_h, g)
        rtot += r
        res[i] = r
    if drv[D_BFULLSUM] > 0.0:  # air brakes: each fill follows the command that has arrived
        vs = drv[D_BVS]
        for i in range(n):
            zb = int(veh[i, V_BZ])
            if zb < 0:
                continue
            v = y[n + i]
            target = brake_target(t, veh[i, V_BDELAY], events, n_events)
            fill = y[zb]
            tau = drv[D_BTAUA] if target > fill else drv[D_BTAUR]
            # (settled within 1e-12: an endless decay to 0 ends in slow subnormals)
            dy[zb] = (target - fill) / tau if abs(target - fill) > 1e-12 else 0.0
            fb = 0.0
            if fill > 0.0:
                shoe = fill * veh[i, V_BSHOE]
                fb = -brake_retardation(v, fill * veh[i, V_BFULL]
                                        * shoe_friction(i, v, shoe, veh, ctab), vs)
            bforce[i] = fb
            res[i] += fb
    mode = drv[D_MODE]
    fd = 0.0
    if mode == MODE_SPEED:
        fd = a_dem * trac[T_MTOT] + trac[T_FF] * rtot
    elif mode == MODE_FORCE:
        fd = _interp(prof_t, prof_y, t, hints, n)
    else:
        fd = _held(prof_t, prof_y, t, hints, n) / 8.0  # notch fraction
    ftot = 0.0
    fdem = 0.0
    for c in range(cons.shape[0]):
        vc = y[n + int(cons[c, K_VEH])]
        lim = traction_limit(vc, cons[c, K_FMAX], cons[c, K_PMAX], cons[c, K_MADH], g)
        m_own = int(cons[c, K_NLEN])
        if m_own > 0:
            dem = _held_at(ctab, int(cons[c, K_NOFF]), m_own, t) / 8.0 * lim
        elif mode == MODE_NOTCH:
            dem = fd * lim
        else:
            dem = fd * cons[c, K_SHARE]
        fdem += dem
        dl = min(max(dem, -lim), lim)
        z = int(cons[c, K_Z])
        if z >= 0:  # motor and inverter lag, with the jerk limit on its rate
            f = y[z]
            rate = (dl - f) / cons[c, K_TAU] if abs(dl - f) > 1e-6 else 0.0  # (as above)
            rmax = cons[c, K_RATE]
            if rmax > 0.0:
                rate = min(max(rate, -rmax), rmax)
            dy[z] = rate
            f = min(max(f, -lim), lim)
        else:
            f = dl
        fade = cons[c, K_DBFADE]
        if f < 0.0 and fade > 0.0:  # dynamic braking dies away as the motors slow
            f *= min(max(vc / fade, 0.0), 1.0)
        fcons[c] = f
        ftot += f
    sig[0] = ftot
    sig[1] = y[n + int(trac[T_REF])]
    sig[2] = fdem
    sig[3] = rtot
    for j in range(n - 1):
        d = y[j] - y[j + 1] + cpl[j, P_D0]
        dd = y[n + j] - y[n + j + 1]
        f = coupler_force(j, cpl_model[j], d, dd, y, 2 * n, dy, 2 * n, cpl, ctab)
        force[j] = f
        defl[j] = d
    for i in range(n):
        # (an unpowered vehicle has share 0 and reads consist 0: no branch in the loop)
        f = veh[i, V_SHARE] * fcons[int(veh[i, V_CONS])] - res[i]
        if i < n - 1:
            f -= force[i]
        if i > 0:
            f += force[i - 1]
        dy[i] = y[n + i]
        dy[n + i] = f * inv_m[i]


@njit(cache=True, inline="always")
def _push_event(events, ctrl, t, level):
    """Append brake command ``(t, level)``; False when the event store is full."""
    m = int(ctrl[C_NEV])
    if m >= events.shape[0]:
        return False
    events[m, 0] = t
    events[m, 1] = level
    ctrl[C_NEV] = m + 1
    ctrl[C_LEVEL] = level
    return True


@njit(cache=True, _nrt=False, forceinline=True)
def _brake_commands(t, horizon, y, ctrl, events, veh, cons, drv, trac, ctab, sig, sampled):
    """Issue the brake commands due at the start of a step at ``t`` (s).

    Scheduled applications with times before ``t + horizon`` are issued at their own
    times; a position trigger when the lead vehicle has passed it; a controller-made
    application (at controller samples, ``sampled``) when the demanded braking force
    exceeds the dynamic brake. Returns -1 if the event store overflowed, else the
    number of commands issued.
    """
    issued = 0
    m = int(drv[D_BSLEN])
    if m > 0:
        o = int(drv[D_BSOFF])
        k = int(ctrl[C_NEXT_SCHED])
        while k < m and ctab[o + k] < t + horizon:
            if not _push_event(events, ctrl, ctab[o + k], ctab[o + m + k]):
                return -1
            issued += 1
            k += 1
        ctrl[C_NEXT_SCHED] = k
    m = int(drv[D_BPLEN])
    if m > 0:
        o = int(drv[D_BPOFF])
        k = int(ctrl[C_NEXT_POS])
        lead = veh[0, V_P0] + y[0]
        while k < m and ctab[o + k] <= lead:
            if not _push_event(events, ctrl, t, ctab[o + m + k]):
                return -1
            issued += 1
            k += 1
        ctrl[C_NEXT_POS] = k
    if sampled and drv[D_BCTRL] > 0.0:
        n = veh.shape[0]
        g = trac[T_G]
        # braking force still wanted after the dynamic brake of every consist
        want = -(ctrl[C_ADEM] * trac[T_MTOT] + trac[T_FF] * sig[3])
        for c in range(cons.shape[0]):
            vc = y[n + int(cons[c, K_VEH])]
            lim = traction_limit(vc, cons[c, K_FMAX], cons[c, K_PMAX], cons[c, K_MADH], g)
            fade = cons[c, K_DBFADE]
            if fade > 0.0:
                lim *= min(max(vc / fade, 0.0), 1.0)
            want -= lim
        level = 0.0
        if want > 0.0:
            v = y[n + int(trac[T_REF])]
            cap = drv[D_BFULLSUM] * expected_shoe_friction(v, drv, veh, ctab)
            level = min(want / cap, 1.0) if cap > 0.0 else 1.0
        step = drv[D_BSTEP]
        q = min(round(level / step) * step, 1.0)
        if q != ctrl[C_LEVEL]:
            if not _push_event(events, ctrl, t, q):
                return -1
            issued += 1
    return issued


@njit(cache=True, inline="always")
def expected_shoe_friction(v, drv, veh, ctab):
    """Friction coefficient the controller expects at speed ``v`` (m/s): that of the
    first braked vehicle's shoes at the mean full shoe force."""
    for i in range(veh.shape[0]):
        if veh[i, V_BZ] >= 0:
            return shoe_friction(i, v, drv[D_BSHOEREF], veh, ctab)
    return 0.0


def work_size(n: int, ny: int, stages: int, n_consists: int = 1) -> int:
    """Length of the float work array :func:`run` and :func:`run_adaptive` need for
    ``n`` vehicles, a state of ``ny`` elements and ``stages`` stage derivatives."""
    return stages * ny + 2 * ny + 2 * max(n - 1, 1) + 3 * n + n_consists + N_SIG


@njit(cache=True, inline="always")
def _fold_peak(peaks, j, f, t):
    """Fold force ``f`` (N) of coupler ``j`` at time ``t`` (s) into ``peaks[j] =
    (largest N, smallest N, time of the largest s, time of the smallest s)``."""
    if f > peaks[j, 0]:
        peaks[j, 0] = f
        peaks[j, 2] = t
    if f < peaks[j, 1]:
        peaks[j, 1] = f
        peaks[j, 3] = t


@njit(cache=True, inline="always")
def _track_peaks(force, peaks, nc, t):
    """:func:`_fold_peak` for every coupler."""
    for j in range(nc):
        _fold_peak(peaks, j, force[j], t)


@njit(cache=True, inline="always")
def _work_views(work, ns, ny, n, nc, nk, veh):
    """Split the caller's ``work`` array (see :func:`work_size`) into the kernels' work
    arrays: ``ns`` stage derivatives (stage s at ``K[s * ny:(s + 1) * ny]``), two state
    buffers, coupler forces and deflections, resistances, inverse masses (filled here),
    brake forces, consist forces and the signal vector. The kernels are compiled without
    NRT, so views cost no reference counting in the loop."""
    K = work[0:ns * ny]
    o = ns * ny
    ytmp = work[o:o + ny]
    o += ny
    ynew = work[o:o + ny]
    o += ny
    force = work[o:o + nc]
    o += nc
    defl = work[o:o + nc]
    o += nc
    res = work[o:o + n]
    o += n
    inv_m = work[o:o + n]
    o += n
    bforce = work[o:o + n]
    o += n
    fcons = work[o:o + nk]
    o += nk
    sig = work[o:o + N_SIG]
    for i in range(n):
        inv_m[i] = 1.0 / veh[i, V_MASS]
    return K, ytmp, ynew, force, defl, res, inv_m, bforce, fcons, sig


@njit(cache=True, _nrt=False, forceinline=True)
def _controller(t, y, n, ctrl, prof_t, prof_y, hints, trac, drv, sig):
    """One controller sample at ``t`` for a train of ``n`` vehicles: the PID's demanded
    acceleration, clipped to the acceleration limits. With anti-windup the integrator
    holds (conditional integration) while the demand is clipped, or the traction drives
    are at their limits (``sig``: applied and demanded force of the last evaluation), in
    the direction the error pushes."""
    ts = drv[D_TS]
    vref = _interp(prof_t, prof_y, t, hints, n + 1)
    e = vref - y[n + int(trac[T_REF])]
    u = pid_step(e, ctrl, drv[D_KP], drv[D_KI], drv[D_KD], drv[D_N], ts, int(drv[D_INT]),
                 int(drv[D_FILT]))
    uc = min(max(u, -trac[T_DMAX]), trac[T_AMAX])
    if drv[D_AW] > 0.0:
        clipped = (u - uc) * e > 0.0
        saturated = abs(sig[2]) > abs(sig[0]) * (1.0 + 1e-9) and sig[2] * e > 0.0
        if clipped or saturated:
            ctrl[C_PI] -= ts * e
    ctrl[C_ADEM] = uc
    ctrl[C_VREF] = vref


@njit(cache=True, _nrt=False)
def run(y, ctrl, k_start, k_stop, n_steps, record_every, dt, A, B, C,
        veh, cons, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h, trac, drv, prof_t,
        prof_y, events, out_x, out_v, out_a, out_d, out_f, out_s, out_b, out_p, out_c, peaks,
        work, hints):
    """Advance ``y`` from step ``k_start`` to ``k_stop`` (time ``k dt``), recording.

    Records the state at every step that is a multiple of ``record_every`` (record
    ``k // record_every``) and, when ``k_stop == n_steps``, the final state.
    ``y``, ``ctrl`` (controller state, see ``C_*``) and ``events`` (brake commands,
    ``(time s, level)`` rows) are updated in place so a run can be split into chunks;
    ``peaks[j] = (largest N, smallest N, their times s)`` for coupler j over every step.

    ``work`` is a float array of :func:`work_size` elements and ``hints`` an int64 array
    of ``n + 2 + consists`` zeros (search cursors), both owned by the caller.

    Returns ``(status, k)``: ``OK`` and ``k_stop``; ``NONFINITE`` and the step whose
    result was not finite (``y`` then holds that state); ``EVENTS_FULL`` and the step.
    """
    n = veh.shape[0]
    ny = y.shape[0]
    ns = B.shape[0]
    nc = max(n - 1, 1)
    nk = cons.shape[0]
    K, ytmp, _, force, defl, res, inv_m, bforce, fcons, sig = _work_views(
        work, ns, ny, n, nc, nk, veh)
    speed_mode = drv[D_MODE] == MODE_SPEED
    every = int(drv[D_EVERY])
    braking = (drv[D_BSLEN] + drv[D_BPLEN] + drv[D_BCTRL]) > 0.0
    # counters instead of k % every: integer division is slow in the loop
    c_ctrl = k_start % every
    c_rec = k_start % record_every
    for k in range(k_start, k_stop):
        t = k * dt
        sampled = speed_mode and c_ctrl == 0
        if sampled:
            _controller(t, y, n, ctrl, prof_t, prof_y, hints, trac, drv, sig)
        if braking:
            if _brake_commands(t, dt, y, ctrl, events, veh, cons, drv, trac, ctab, sig,
                               sampled) < 0:
                return EVENTS_FULL, k
        a_dem = ctrl[C_ADEM]
        n_ev = int(ctrl[C_NEV])
        # stage 1 is the right-hand side at (t_k, y_k): record it when due
        rhs(t, y, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h,
            trac, drv, prof_t, prof_y, events, n_ev, K[0:ny], force, defl, res, bforce, fcons,
            sig, hints)
        _track_peaks(force, peaks, n - 1, t)
        if c_rec == 0:
            _record(k // record_every, t, y, K, force, defl, bforce, fcons, sig, a_dem,
                    ctrl[C_LEVEL], speed_mode, prof_t, prof_y, hints, trac, veh, cons, out_x,
                    out_v, out_a, out_d, out_f, out_s, out_b, out_p, out_c)
        for s in range(1, ns):
            for q in range(ny):
                ytmp[q] = y[q]
            for j in range(s):
                w = dt * A[s, j]
                if w != 0.0:
                    o = j * ny
                    for q in range(ny):
                        ytmp[q] += w * K[o + q]
            rhs(t + C[s] * dt, ytmp, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos,
                tgrade, tcurv, curve_h, trac, drv, prof_t, prof_y, events, n_ev,
                K[s * ny:(s + 1) * ny], force, defl, res, bforce, fcons, sig, hints)
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
        rhs(t, y, ctrl[C_ADEM], veh, cons, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv,
            curve_h, trac, drv, prof_t, prof_y, events, int(ctrl[C_NEV]), K[0:ny], force, defl,
            res, bforce, fcons, sig, hints)
        _track_peaks(force, peaks, n - 1, t)
        _record(k_stop // record_every, t, y, K, force, defl, bforce, fcons, sig, ctrl[C_ADEM],
                ctrl[C_LEVEL],
                speed_mode, prof_t, prof_y, hints, trac, veh, cons, out_x, out_v, out_a, out_d,
                out_f, out_s, out_b, out_p, out_c)
    return OK, k_stop


#: Bogacki-Shampine 3(2): third-order weights and the error weights (3rd - 2nd order)
_BS_B = (2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0)
_BS_E = (-5.0 / 72.0, 1.0 / 12.0, 1.0 / 9.0, -1.0 / 8.0)


@njit(cache=True, _nrt=False)
def run_adaptive(y, ctrl, astate, r_start, r_stop, n_rec, out_dt, h_max, atol, rtol,
                 veh, cons, cpl_model, cpl, ctab, tpos, tgrade, tcurv, curve_h, trac, drv,
                 prof_t, prof_y, events, out_x, out_v, out_a, out_d, out_f, out_s, out_b,
                 out_p, out_c, peaks, work, hints):
    """Advance ``y`` with the embedded Bogacki-Shampine 3(2) pair under error control,
    from record ``r_start`` (time ``r_start * out_dt``) to record ``r_stop``.

    Every step keeps the error estimate ``|y3 - y2|`` within ``atol + rtol |y|``
    element by element (max norm); steps end exactly on record times, controller
    samples and scheduled brake commands. ``astate = [step size s, accepted steps,
    rejected steps, time of the current state s, last accepted error, last step
    rejected (0/1)]`` carries over between calls. Records
    ``r_start`` (when it is 0) to ``r_stop - 1``, and ``n_rec - 1`` when ``r_stop``
    reaches ``n_rec``.

    Returns ``(status, t)``: ``OK``; ``NONFINITE`` when no step size down to 1e-12 s
    gives a finite state (``y`` holds the last good state at ``t``); ``EVENTS_FULL``.
    """
    n = veh.shape[0]
    ny = y.shape[0]
    nc = max(n - 1, 1)
    nk = cons.shape[0]
    K, ytmp, ynew, force, defl, res, inv_m, bforce, fcons, sig = _work_views(
        work, 4, ny, n, nc, nk, veh)
    speed_mode = drv[D_MODE] == MODE_SPEED
    ts = drv[D_TS]
    braking = (drv[D_BSLEN] + drv[D_BPLEN] + drv[D_BCTRL]) > 0.0
    m_sched = int(drv[D_BSLEN])
    o_sched = int(drv[D_BSOFF])
    h = astate[0]
    t = astate[3]
    r = r_start
    t_last = (n_rec - 1) * out_dt
    t_stop = min(r_stop, n_rec - 1) * out_dt
    eps = 1e-9 * out_dt
    fresh = True  # K[0:ny] must be (re)computed at (t, y)
    while True:
        # ---- driver: controller sample, brake commands (at the start of the step)
        sampled = False
        if speed_mode:
            m = ctrl[C_NEXT_SAMPLE]
            if t >= m * ts - eps:
                _controller(t, y, n, ctrl, prof_t, prof_y, hints, trac, drv, sig)
                ctrl[C_NEXT_SAMPLE] = m + 1.0
                sampled = True
                fresh = True
        if braking:
            issued = _brake_commands(t, eps, y, ctrl, events, veh, cons, drv, trac, ctab, sig,
                                     sampled)
            if issued < 0:
                astate[0], astate[3] = h, t
                return EVENTS_FULL, t
            if issued > 0:
                fresh = True
        a_dem = ctrl[C_ADEM]
        n_ev = int(ctrl[C_NEV])
        if fresh:
            rhs(t, y, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos, tgrade, tcurv,
                curve_h, trac, drv, prof_t, prof_y, events, n_ev, K[0:ny], force, defl, res,
                bforce, fcons, sig, hints)
            _track_peaks(force, peaks, n - 1, t)
            fresh = False
        # ---- record when on a record time
        if r < n_rec and abs(t - r * out_dt) <= eps:
            if r < r_stop or r == n_rec - 1:
                _record(r, t, y, K, force, defl, bforce, fcons, sig, a_dem, ctrl[C_LEVEL],
                        speed_mode, prof_t, prof_y, hints, trac, veh, cons, out_x, out_v,
                        out_a, out_d, out_f, out_s, out_b, out_p, out_c)
            r += 1
        if t >= t_stop - eps or t >= t_last - eps:
            break
        # ---- the next step ends no later than the next record, sample or command
        t_next = r * out_dt
        if speed_mode:
            t_next = min(t_next, ctrl[C_NEXT_SAMPLE] * ts)
        k = int(ctrl[C_NEXT_SCHED])
        if k < m_sched:
            t_next = min(t_next, ctab[o_sched + k])
        hit = False
        h_try = min(h, h_max)
        if t + h_try >= t_next - eps:
            h_try = t_next - t
            hit = True
        # ---- one Bogacki-Shampine step
        for q in range(ny):
            ytmp[q] = y[q] + 0.5 * h_try * K[q]
        rhs(t + 0.5 * h_try, ytmp, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos,
            tgrade, tcurv, curve_h, trac, drv, prof_t, prof_y, events, n_ev, K[ny:2 * ny],
            force, defl, res, bforce, fcons, sig, hints)
        for q in range(ny):
            ytmp[q] = y[q] + 0.75 * h_try * K[ny + q]
        rhs(t + 0.75 * h_try, ytmp, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos,
            tgrade, tcurv, curve_h, trac, drv, prof_t, prof_y, events, n_ev,
            K[2 * ny:3 * ny], force, defl, res, bforce, fcons, sig, hints)
        total = 0.0
        for q in range(ny):
            ynew[q] = y[q] + h_try * (_BS_B[0] * K[q] + _BS_B[1] * K[ny + q]
                                      + _BS_B[2] * K[2 * ny + q])
            total += ynew[q]
        t_new = t_next if hit else t + h_try
        err = np.inf
        if total - total == 0.0:
            rhs(t_new, ynew, a_dem, veh, cons, inv_m, cpl_model, cpl, ctab, tpos, tgrade,
                tcurv, curve_h, trac, drv, prof_t, prof_y, events, n_ev, K[3 * ny:4 * ny],
                force, defl, res, bforce, fcons, sig, hints)
            err = 0.0
            for q in range(ny):
                e = h_try * (_BS_E[0] * K[q] + _BS_E[1] * K[ny + q] + _BS_E[2] * K[2 * ny + q]
                             + _BS_E[3] * K[3 * ny + q])
                sc = atol[q] + rtol[q] * max(abs(y[q]), abs(ynew[q]))
                e = abs(e) / sc
                if e > err:
                    err = e
            if not (err - err == 0.0):
                err = np.inf
        if err <= 1.0:
            t = t_new
            for q in range(ny):
                y[q] = ynew[q]
                K[q] = K[3 * ny + q]  # first same as last
            _track_peaks(force, peaks, n - 1, t)
            astate[1] += 1.0
            # PI step-size control (Gustafsson): smoother step sequences, fewer rejections
            if err == 0.0:
                fac = 5.0
            else:
                fac = 0.9 * err ** (-0.7 / 3.0) * max(astate[4], 1e-4) ** (0.4 / 3.0)
                fac = min(5.0, max(0.2, fac))
            if astate[5] > 0.0:  # no growth right after a rejection
                fac = min(fac, 1.0)
            astate[4] = err
            astate[5] = 0.0
            if not hit or fac < 1.0:
                h = h_try * fac
            else:  # a step shortened to land on a target says little about the next one
                h = max(h, h_try * fac)
        else:
            astate[2] += 1.0
            astate[5] = 1.0
            fac = 0.2 if err == np.inf else max(0.2, 0.9 * err ** (-1.0 / 3.0))
            h = h_try * fac
            if h < 1e-12:
                astate[0], astate[3] = h, t
                return NONFINITE, t
    astate[0], astate[3] = h, t
    return OK, t


@njit(cache=True, _nrt=False, forceinline=True)
def _record(r, t, y, dy, force, defl, bforce, fcons, sig, a_dem, level, speed_mode, prof_t,
            prof_y, hints, trac, veh, cons, out_x, out_v, out_a, out_d, out_f, out_s, out_b, out_p,
            out_c):
    n = out_x.shape[1]
    for i in range(n):
        out_x[r, i] = y[i] + veh[i, V_P0]  # track position
        out_v[r, i] = y[n + i]
        out_a[r, i] = dy[n + i]  # stage-1 derivatives sit at offset 0
    for j in range(n - 1):
        out_d[r, j] = defl[j]
        out_f[r, j] = force[j]
    if out_b.shape[1] > 0:
        for i in range(n):
            zb = int(veh[i, V_BZ])
            out_b[r, i] = bforce[i] if zb >= 0 else 0.0
            out_p[r, i] = y[zb] if zb >= 0 else 0.0
    if out_c.shape[1] > 0:
        for c in range(cons.shape[0]):
            out_c[r, c] = fcons[c]
    out_s[r, S_TRACTION] = sig[0]
    adh = 0.0
    for c in range(cons.shape[0]):
        adh += adhesion_limit(y[n + int(cons[c, K_VEH])], cons[c, K_MADH], trac[T_G])
    out_s[r, S_ADHESION] = adh
    out_s[r, S_DEMAND] = sig[2]
    out_s[r, S_BRAKE] = level
    if speed_mode:
        out_s[r, S_VREF] = _interp(prof_t, prof_y, t, hints, n + 1)
        out_s[r, S_ADEM] = a_dem
    else:
        out_s[r, S_VREF] = np.nan
        out_s[r, S_ADEM] = np.nan
