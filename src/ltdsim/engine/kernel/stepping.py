"""The two kernels: :func:`run`, a fixed-step explicit Runge-Kutta method on the run's
grid, and :func:`run_adaptive`, the bs23 pair under error control with steps that end
on record times, controller samples and scheduled brake commands.

The fixed-step kernel checks the state for non-finite values at record steps and at
the end of each call, not after every step: such values persist (every later step adds
to them), so the next check finds them, and the error names the interval between the
last good check and the failing one.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.engine.couplers import P_F0, P_RATE
from ltdsim.engine.kernel.brakes import _air_cut, _air_interpolate, _air_start, _air_step
from ltdsim.engine.kernel.driver import _brake_commands, _controller, _sample_due
from ltdsim.engine.kernel.energy import (
    _account_first, _account_traction, _energy_totals, _powers,
)
from ltdsim.engine.features import when
from ltdsim.engine.kernel.recording import _implausible, _record, _track_peaks
from ltdsim.engine.kernel.rhs import _train_rhs, _train_rhs_split, rhs, rhs_split
from ltdsim.engine.kernel.rk import (
    EDGE_LOCATION, EDGE_MIN_STEP, EDGE_SPEED, EDGE_TAIL, MIN_STEP, _advance, _finite,
    _stages, max_scaled_error, pair_error, pair_solution, scaled_error, step_accepted,
    step_rejected,
)
from ltdsim.engine.kernel.slack import (
    _edge_crossing, _exerted_error, _hold_crossing, _hold_enter, _hold_exit, _hold_keep,
    _relax_in_slack, _slack_throughout,
)
from ltdsim.engine.kernel.structs import ABSURD, EVENTS_FULL, NONFINITE, OK, PW_END
from ltdsim.engine.layout import (
    D_BCTRL, D_BPLEN, D_BSLEN, D_BSOFF, D_MODE, D_TS, I_PIPE, MODE_SPEED, T_EZ,
)


@njit(cache=True, _nrt=False)
def run(y, ctl, k_start, k_stop, fs, tr, cp, dr, w, out):
    """Advance ``y`` from step ``k_start`` to ``k_stop`` (time ``k dt``), recording.

    ``ctl`` :class:`Controller`, ``fs`` :class:`FixedStep`, ``tr`` :class:`Train`,
    ``cp`` :class:`CouplerArrays`, ``dr`` :class:`DriverArrays`, ``w`` :class:`Work` (its arrays
    sized by :func:`make_work` with ``fs``'s stages), ``out`` :class:`Outputs`.
    Records the state at every step that is a multiple of ``fs.record_every`` (record
    ``k // record_every``) and, when ``k_stop == fs.n_steps``, the final state. ``y``
    and ``ctl`` are updated in place so a run can be split into chunks; ``out.peaks``
    holds the peak coupler forces over every step.

    Returns ``(status, k)``: ``OK`` and ``k_stop``; ``NONFINITE`` and the first
    checked step whose state is not finite (``y`` then holds that state; the state is
    checked at every record step and at ``k_stop``, so it became non-finite after the
    last record step before ``k``); ``ABSURD`` and the first such step whose state is
    finite but beyond any physical bound (:func:`_implausible`; ``y`` holds it);
    ``EVENTS_FULL`` and the step.
    """
    A = fs.A
    B = fs.b
    C = fs.c
    dt = fs.dt
    record_every = fs.record_every
    drv = dr.par
    st = ctl.state[0]
    K = w.K
    ytmp = w.ytmp
    force = w.force
    peaks = out.peaks
    n = tr.veh.shape[0]
    ny = y.shape[0]
    ns = B.shape[0]
    speed_mode = drv[D_MODE] == MODE_SPEED
    ts = drv[D_TS]
    half = 0.5 * dt  # (sample times fall on steps: ts is a whole number of steps)
    braking = (drv[D_BSLEN] + drv[D_BPLEN] + drv[D_BCTRL]) > 0.0
    energy = w.energy.shape[0] > 0
    # a counter instead of k % record_every: integer division is slow in the loop
    c_rec = k_start % record_every
    energy_every = fs.energy_every
    c_sam = k_start % energy_every
    h_sam = dt * energy_every  # (the sampling interval of the powers but traction's, s)
    for k in range(k_start, k_stop):
        t = k * dt
        # non-finite values persist, so the state is checked only where it is recorded
        # (and at the chunk's end), not after every step
        if c_rec == 0:
            if not _finite(y):
                return NONFINITE, k
            if _implausible(y, tr, cp.par) >= 0:
                return ABSURD, k
        sampled = speed_mode and _sample_due(t, st, ts, half)
        if sampled:
            _controller(t, y, ctl, tr, dr, w)
        if braking:
            if _brake_commands(t, dt, y, ctl, tr, dr, w, sampled) < 0:
                return EVENTS_FULL, k
        a_dem = st["a_dem"]
        n_ev = st["n_events"]
        # stage 1 is the right-hand side at (t_k, y_k): record it when due
        rhs(t, y, a_dem, n_ev, tr, cp, dr, ctl.events, w, K[0:ny])
        _track_peaks(force, peaks, n - 1, t)
        if energy:  # the work of the step that ended here, from the powers at its ends
            # (traction every step; the other powers every energy_every steps, which
            # divides record_every, so that each record is a sample)
            if k == 0:
                when(tr.features.energy, _account_first, None, y, tr, w)
            else:
                when(tr.features.energy, _account_traction, None, dt, y, tr, w)
                if c_rec == 0:
                    when(tr.features.energy, _powers, None, y, tr, w, PW_END, True)
                elif c_sam == 0:
                    when(tr.features.energy, _powers, None, y, tr, w, -1, True)
        if c_rec == 0:
            if energy:
                when(tr.features.energy, _energy_totals, None, h_sam, w)
            _record(k // record_every, t, y, K, a_dem, st["level"], speed_mode, tr, dr, w,
                    out)
        _stages(_train_rhs, (a_dem, n_ev, tr, cp, dr, ctl.events, w), t, y, dt, A, C, ns, K,
                ytmp)
        _advance(y, dt, B, ns, K, ytmp)
        c_rec += 1
        if c_rec == record_every:
            c_rec = 0
        c_sam += 1
        if c_sam == energy_every:
            c_sam = 0
    if not _finite(y):
        return NONFINITE, k_stop
    if _implausible(y, tr, cp.par) >= 0:
        return ABSURD, k_stop
    if k_stop == fs.n_steps:
        t = k_stop * dt
        rhs(t, y, st["a_dem"], st["n_events"], tr, cp, dr, ctl.events, w, K[0:ny])
        _track_peaks(force, peaks, n - 1, t)
        if energy:
            if k_stop == 0:
                when(tr.features.energy, _account_first, None, y, tr, w)
            else:
                when(tr.features.energy, _account_traction, None, dt, y, tr, w)
                when(tr.features.energy, _powers, None, y, tr, w, PW_END, True)
            when(tr.features.energy, _energy_totals, None, h_sam, w)
        _record(k_stop // record_every, t, y, K, st["a_dem"], st["level"], speed_mode, tr,
                dr, w, out)
    return OK, k_stop


@njit(cache=True, _nrt=False)
def run_adaptive(y, ctl, stepper, r_start, r_stop, ad, tr, cp, dr, w, out):
    """Advance ``y`` with an embedded Runge-Kutta pair (the Bogacki-Shampine 3(2) of
    ``ad``) under error control, from record ``r_start`` (time ``r_start * ad.out_dt``)
    to record ``r_stop``.

    ``ctl`` :class:`Controller`, ``stepper`` one ``STEPPER`` record (array of one)
    carried over between calls, ``ad`` :class:`Adaptive`; the others as in :func:`run`
    (``w`` sized for the pair's stages plus one). Every step keeps the error estimate
    ``|y3 - y2|`` within ``atol + rtol |y|`` element by element (max norm), a
    hysteretic gear's internal force by the error of the force it exerts
    (:func:`_exerted_error`); a gear that spends the whole step in its slack has its
    states relaxed exactly (:func:`_relax_in_slack`). Steps end
    exactly on record times, controller samples and scheduled brake commands, and with
    ``rk.EDGE_LOCATION`` just past the first point where a coupling meets or leaves its
    slack edge at more than ``rk.EDGE_SPEED`` times the speeds' tolerance
    (:func:`_edge_crossing`; a step that would run on past it by more than
    ``rk.EDGE_TAIL`` of its length is taken again, cut, and counted as rejected). Records
    ``r_start`` (when it is 0) to ``r_stop - 1``, and ``n_rec - 1`` when ``r_stop``
    reaches ``n_rec``.

    With ``ad.hold_speed`` > 0 (``solver.hold_speed``) a coupling that may be held
    (``w.hold_f``) and meets or leaves its slack edge slower than that is held there
    after the step (:func:`_hold_enter`), and let go after the step at whose end its
    force has left its range (:func:`_hold_exit`; a step in which it leaves the range
    early is taken again once, to end just past that point, :func:`_hold_crossing`).
    While held, its two sides move as one body (:func:`ltdsim.engine.kernel.rhs._held_blocks`).

    With the fluid brake (``w.air`` sized, see :func:`make_work`) the pneumatic states
    take their own steps under the same error control (:func:`_air_step`), as long as
    their dynamics allow, one step ahead when a mechanical step would pass the end of
    the current one: a mechanical step may span two pneumatic steps (it ends no later
    than the second), reads the cylinder pressures from the interpolant of the one that
    holds each stage's time (:func:`rhs_split`), and steps and controls the error of the
    mechanical states only. The pneumatic states in
    ``y`` are brought up to date at every record.

    Returns ``(status, t)``: ``OK``; ``NONFINITE`` when no step size down to 1e-12 s
    gives a finite state (``y`` holds the last good state at ``t``); ``ABSURD`` at the
    first record time whose state is beyond any physical bound (:func:`_implausible`;
    ``y`` holds it); ``EVENTS_FULL``.
    """
    drv = dr.par
    st = ctl.state[0]
    sp = stepper[0]
    A = ad.A
    B = ad.b
    C = ad.c
    E = ad.e
    ns = B.shape[0]
    atol = ad.atol
    err_atol = ad.err_atol
    gear_f1 = ad.gear_f1
    gear_of = ad.gear_of
    gear_plate = ad.gear_plate
    gear_exact = ad.gear_exact
    cpl = cp.par
    rtol = ad.rtol
    out_dt = ad.out_dt
    n_rec = ad.n_rec
    K = w.K
    ynew = w.ynew
    force = w.force
    peaks = out.peaks
    ctab = tr.tables
    n = tr.veh.shape[0]
    split = w.air.shape[1] > 0  # the fluid brake's pneumatics on their own steps
    air_st = w.air_step[0]
    # the mechanical states (all of them without the fluid brake), stepped here
    ny = tr.air.index[I_PIPE] if split else y.shape[0]
    ym = y[:ny]
    # the pair's stages in K, by their offsets (rk.pair_solution)
    stage_at = (0, ny, 2 * ny)
    error_at = (0, ny, 2 * ny, 3 * ny)
    speed_mode = drv[D_MODE] == MODE_SPEED
    ts = drv[D_TS]
    braking = (drv[D_BSLEN] + drv[D_BPLEN] + drv[D_BCTRL]) > 0.0
    m_sched = int(drv[D_BSLEN])
    o_sched = int(drv[D_BSOFF])
    h = sp["h"]
    t = sp["t"]
    r = r_start
    t_last = (n_rec - 1) * out_dt
    t_stop = min(r_stop, n_rec - 1) * out_dt
    eps = 1e-9 * out_dt
    fresh = True  # K[0:ny] must be (re)computed at (t, y)
    cut = False  # the pneumatic step must end at t (a command, or the start)
    h_edge = np.inf  # the step cut to end just past a slack edge, s (inf: none)
    hold_speed = ad.hold_speed
    hold = hold_speed > 0.0  # couplings may be held at their slack edges
    ez = int(tr.trac[T_EZ])  # (their touches' energy goes to the couplings' work)
    if split and not air_st["started"]:
        when(tr.features.fluid, _air_start, None, t, y, tr, w)
        cut = True
    while True:
        # ---- driver: controller sample, brake commands (at the start of the step)
        sampled = speed_mode and _sample_due(t, st, ts, eps)
        if sampled:
            _controller(t, y, ctl, tr, dr, w)
            fresh = True
        if braking:
            issued = _brake_commands(t, eps, y, ctl, tr, dr, w, sampled)
            if issued < 0:
                sp["h"] = h
                sp["t"] = t
                return EVENTS_FULL, t
            if issued > 0:
                fresh = True
                cut = split  # the pneumatic step ends here, with the new command's rates
        a_dem = st["a_dem"]
        n_ev = st["n_events"]
        if cut:
            when(tr.features.fluid, _air_cut, None, t, ctl.events, n_ev, tr, w)
            cut = False
        if fresh:
            rhs_split(t, ym, a_dem, n_ev, tr, cp, dr, ctl.events, w, K[0:ny])
            if hold:
                # a coupling just held whose force is out of its range is let go at once
                let_go = _hold_exit(ym, n, ad.hold_ftol, w)
                if let_go > 0:
                    sp["holds"] += let_go
                    rhs_split(t, ym, a_dem, n_ev, tr, cp, dr, ctl.events, w, K[0:ny])
                _hold_keep(n, w)
            _track_peaks(force, peaks, n - 1, t)
            fresh = False
        # ---- record when on a record time
        if r < n_rec and abs(t - r * out_dt) <= eps:
            if r < r_stop or r == n_rec - 1:
                if split:
                    when(tr.features.fluid, _air_interpolate, None, t, tr, w, y)
                if _implausible(y, tr, cp.par) >= 0:
                    return ABSURD, t
                _record(r, t, y, K, a_dem, st["level"], speed_mode, tr, dr, w, out)
            r += 1
        if t >= t_stop - eps or t >= t_last - eps:
            break
        # ---- the next step ends no later than the next record, sample or command
        t_next = r * out_dt
        if speed_mode:
            t_next = min(t_next, st["next_sample"] * ts)
        k = st["next_scheduled"]
        if k < m_sched:
            t_next = min(t_next, ctab[o_sched + k])
        h_try = min(h, ad.h_max)
        at_edge = h_edge < h_try
        if at_edge:
            h_try = h_edge
        if split:
            if (min(t + h_try, t_next) > air_st["t1"] and t >= air_st["t0"]
                    and t < t_last - eps):
                # the step would pass the pneumatic step's end: take the next pneumatic
                # step (to the next scheduled command at most), keeping the one the
                # mechanical step starts in, so that the step need not end there
                t_cap = t_last
                k = st["next_scheduled"]
                if k < m_sched and ctab[o_sched + k] > t + eps:
                    t_cap = min(t_cap, ctab[o_sched + k])
                if not when(tr.features.fluid, _air_step, True, t_cap, ctl.events, n_ev, tr,
                            w, ad):
                    sp["h"] = h
                    sp["t"] = t
                    return NONFINITE, t
            t_next = min(t_next, air_st["t1"])
        hit = False
        if t + h_try >= t_next - eps:
            h_try = t_next - t
            hit = True
            at_edge = False
        # ---- one step of the embedded pair: its stages, the solution kept, the error
        _stages(_train_rhs_split, (a_dem, n_ev, tr, cp, dr, ctl.events, w), t, ym, h_try, A,
                C, ns, K, w.ytmp)
        # (the pair's three stages written out: one pass over the state for the solution
        # and one for the error, the same sums in the same order. The heavy-haul train
        # over 20 s runs 6 % fewer instructions in all than with a pass per stage, and
        # a loop over the stages inside the loop over the state runs 35 % more)
        finite = pair_solution(y, K, stage_at, h_try, B, 0, ny, ynew)
        t_new = t_next if hit else t + h_try
        err = np.inf
        if EDGE_LOCATION and finite and h_try > EDGE_MIN_STEP:
            # ---- slack edges: the first point where a coupling meets or leaves one
            # (compiled in with rk.EDGE_LOCATION)
            theta = 2.0
            for j in range(n - 1):
                th = _edge_crossing(j, y, ynew, n, h_try, EDGE_SPEED * atol[n + j], cpl)
                if th < theta:
                    theta = th
            if theta < 1.0 - EDGE_TAIL:
                # the step runs on past it in the old regime: take it again, ending just
                # past the edge (the controller's step h is kept for the step after)
                h_edge = max(theta * h_try / (1.0 - 0.5 * EDGE_TAIL), EDGE_MIN_STEP)
                sp["rejected"] += 1
                continue
        if finite:
            # the right-hand side at the step's end: the error's last stage, and the next
            # step's first if the step is accepted (first same as last)
            rhs_split(t_new, ynew[:ny], a_dem, n_ev, tr, cp, dr, ctl.events, w,
                      K[ns * ny:(ns + 1) * ny])
            err = max_scaled_error(K, error_at, h_try, E, 0, ny, y, ynew, err_atol, rtol)
            e_w = (E[0], E[1], E[2], E[3])  # (read here, as rk.pair_solution says)
            # the stage weights of the slack test, and the slack's decay for one rate at
            # a time (the gears mostly share one: one exponential per step)
            w10 = h_try * A[1, 0]
            w20 = h_try * A[2, 0]
            w21 = h_try * A[2, 1]
            rate_last = -1.0
            decay = 1.0
            for g in range(gear_f1.shape[0]):
                q = gear_f1[g]
                j = gear_of[g]
                qp = gear_plate[g]
                if gear_exact[g] and _slack_throughout(j, y, ynew, K, ny, w10, w20, w21,
                                                       cpl):
                    # the gear spent the step in its slack, where its states relax to
                    # constants and act on nothing: relax them exactly (no error)
                    rate = cpl[j, P_RATE]
                    if rate != rate_last:
                        decay = np.exp(-rate * h_try)
                        rate_last = rate
                    _relax_in_slack(j, q, qp, y, ynew, K[ns * ny:], decay, cpl)
                    continue
                e = _exerted_error(ynew[q], pair_error(q, K, error_at, h_try, e_w),
                                   abs(force[j]), cpl[j, P_F0])
                e = scaled_error(e, q, y, ynew, atol, rtol)
                if e > err:
                    err = e
                if qp >= 0:
                    e = scaled_error(pair_error(qp, K, error_at, h_try, e_w), qp, y, ynew,
                                     atol, rtol)
                    if e > err:
                        err = e
            if not (err - err == 0.0):
                err = np.inf
            if hold and err <= 1.0 and not at_edge and h_try > EDGE_MIN_STEP:
                # a held coupling's force left its range inside the step: take it again,
                # ending just past that point, once (a force that jumps there, with a
                # neighbour's touch, is not found by interpolation: the step is cut by
                # half at most, and the coupling let go at the end of the step taken)
                theta = _hold_crossing(n, ad.hold_ftol, w)
                if theta < 1.0 - EDGE_TAIL:
                    h_edge = max(max(theta, 0.5) * h_try / (1.0 - 0.5 * EDGE_TAIL),
                                 EDGE_MIN_STEP)
                    sp["rejected"] += 1
                    continue
        if err <= 1.0:
            t = t_new
            changed = 0
            if hold:
                # couplings let go of their edge, and couplings that met one slowly held
                changed = _hold_exit(ynew, n, ad.hold_ftol, w) \
                    + _hold_enter(y, ynew, n, hold_speed, cpl, tr.inv_m, ez, w)
                if changed > 0:
                    sp["holds"] += changed
                    fresh = True  # (the state changed: the next step starts afresh)
                else:
                    _hold_keep(n, w)
            for q in range(ny):
                y[q] = ynew[q]
                K[q] = K[ns * ny + q]  # first same as last
            if changed == 0:  # (else the fresh evaluation at the next start tracks them)
                _track_peaks(force, peaks, n - 1, t)
            h = step_accepted(sp, err, h, h_try, hit or at_edge)
            h_edge = np.inf
        else:
            h = step_rejected(sp, err, h_try)
            if h < MIN_STEP:
                sp["h"] = h
                sp["t"] = t
                return NONFINITE, t
    sp["h"] = h
    sp["t"] = t
    return OK, t
