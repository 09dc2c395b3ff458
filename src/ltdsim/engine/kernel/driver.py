"""The driver between steps: the speed controller's samples (the discrete PID, its output
held over the step) on one clock shared by both kernels, and the brake commands
(scheduled, at track positions, and the controller's own applications when the
dynamic brake is not enough).
"""

from __future__ import annotations

from numba import njit

from ltdsim.engine.kernel.brakes import expected_shoe_friction
from ltdsim.engine.kernel.tables import _interp
from ltdsim.engine.layout import (
    D_AW, D_BCTRL, D_BFULLSUM, D_BPLEN, D_BPOFF, D_BSLEN, D_BSOFF, D_BSTEP, D_FILT, D_INT,
    D_KD, D_KI, D_KP, D_N, D_TS, EV_KIND, EV_LEVEL, EV_TIME, EV_VALUE, K_DBFADE, K_FMAX,
    K_MADH, K_PMAX, K_VEH, T_AMAX, T_DMAX, T_FF, T_G, T_MTOT, T_REF, V_P0,
)
from ltdsim.physics.control import pid_step
from ltdsim.physics.drive.traction import traction_max


@njit(cache=True, inline="always")
def _push_event(ctl, t, level):
    """Append brake command ``(t, level)`` to the :class:`Controller` ``ctl``; False
    when its event store is full."""
    st = ctl.state[0]
    events = ctl.events
    m = st["n_events"]
    if m >= events.shape[0]:
        return False
    events[m, EV_TIME] = t
    events[m, EV_LEVEL] = level
    st["n_events"] = m + 1
    st["level"] = level
    return True


@njit(cache=True, inline="always")
def _push_command(ctl, t, tab, o, m, k):
    """Append scheduled brake command ``k`` of the ``m`` stored from ``tab[o]`` (one
    column after the other, :data:`ltdsim.engine.layout.EVENT_COLUMNS`) at time ``t`` (s);
    False when the event store is full."""
    if not _push_event(ctl, t, tab[o + m + k]):
        return False
    e = ctl.state[0]["n_events"] - 1
    ctl.events[e, EV_KIND] = tab[o + 2 * m + k]
    ctl.events[e, EV_VALUE] = tab[o + 3 * m + k]
    return True


@njit(cache=True, _nrt=False, forceinline=True)
def _brake_commands(t, horizon, y, ctl, tr, dr, w, sampled):
    """Issue the brake commands due at the start of a step at ``t`` (s).

    Scheduled applications with times before ``t + horizon`` are issued at their own
    times; a position trigger when the lead vehicle has passed it; a controller-made
    application (at controller samples, ``sampled``) when the demanded braking force
    exceeds the dynamic brake. Returns -1 if the event store overflowed, else the
    number of commands issued.
    """
    st = ctl.state[0]
    drv = dr.par
    ctab = tr.tables
    veh = tr.veh
    issued = 0
    m = int(drv[D_BSLEN])
    if m > 0:
        o = int(drv[D_BSOFF])
        k = st["next_scheduled"]
        while k < m and ctab[o + k] < t + horizon:
            if not _push_command(ctl, ctab[o + k], ctab, o, m, k):
                return -1
            issued += 1
            k += 1
        st["next_scheduled"] = k
    m = int(drv[D_BPLEN])
    if m > 0:
        o = int(drv[D_BPOFF])
        k = st["next_position"]
        lead = veh[0, V_P0] + y[0]
        while k < m and ctab[o + k] <= lead:
            if not _push_command(ctl, t, ctab, o, m, k):
                return -1
            issued += 1
            k += 1
        st["next_position"] = k
    if sampled and drv[D_BCTRL] > 0.0:
        cons = tr.cons
        trac = tr.trac
        n = veh.shape[0]
        g = trac[T_G]
        # braking force still wanted after the dynamic brake of every consist
        want = -(st["a_dem"] * trac[T_MTOT] + trac[T_FF] * w.sig[0]["resistance"])
        for c in range(cons.shape[0]):
            vc = y[n + int(cons[c, K_VEH])]
            lim = traction_max(vc, cons[c, K_FMAX], cons[c, K_PMAX], cons[c, K_MADH], g)
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
        if q != st["level"]:
            if not _push_event(ctl, t, q):
                return -1
            issued += 1
    return issued


@njit(cache=True, inline="always")
def _sample_due(t, st, ts, tol):
    """The controller's clock, the same for both kernels: True when its next sample,
    at ``st["next_sample"] * ts`` (s), is due at ``t`` (s) within ``tol`` (s), and the
    clock then moves on to the sample after it."""
    m = st["next_sample"]
    if t >= m * ts - tol:
        st["next_sample"] = m + 1
        return True
    return False


@njit(cache=True, _nrt=False, forceinline=True)
def _controller(t, y, ctl, tr, dr, w):
    """One controller sample at ``t``: the PID's demanded acceleration, clipped to the
    acceleration limits. With anti-windup the integrator holds (conditional
    integration) while the demand is clipped, or the traction drives are at their
    limits (``w.sig``: applied and demanded force of the last evaluation), in the
    direction the error pushes."""
    drv = dr.par
    trac = tr.trac
    n = tr.veh.shape[0]
    st = ctl.state[0]
    pid = ctl.pid[0]
    ts = drv[D_TS]
    vref = _interp(dr.prof_t, dr.prof_y, t, w.hints, n + 1)
    e = vref - y[n + int(trac[T_REF])]
    u = pid_step(e, pid, drv[D_KP], drv[D_KI], drv[D_KD], drv[D_N], ts, int(drv[D_INT]),
                 int(drv[D_FILT]))
    uc = min(max(u, -trac[T_DMAX]), trac[T_AMAX])
    if drv[D_AW] > 0.0:
        sig = w.sig[0]
        clipped = (u - uc) * e > 0.0
        saturated = (abs(sig["demand"]) > abs(sig["traction"]) * (1.0 + 1e-9)
                     and sig["demand"] * e > 0.0)
        if clipped or saturated:
            pid["integrator"] -= ts * e
    st["a_dem"] = uc
    st["v_ref"] = vref
