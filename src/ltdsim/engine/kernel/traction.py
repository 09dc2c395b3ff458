"""Traction in the right-hand side: the driver's demand by mode (speed controller, force
profile, notch), shared among the locomotive consists and clipped to each one's
traction curve with its motor lag and dynamic-brake fade; the consists on the induction
drive turn their demand into force through the drive, the slip controller and the
wheelset's creep (:mod:`ltdsim.physics.drive`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.engine.kernel.tables import _held, _held_at, _interp
from ltdsim.engine.layout import (
    DM_FADE, DM_GEAR_EFF, DM_MOTORS, DM_PER_LOCO, DM_SLIP_ON, DM_TO_RMS, DM_VDC, DS_CREEP,
    DS_CURRENT, DS_FORCE, DS_PDC, DS_PRD, DS_PRQ, DS_PSD, DS_PSQ, DS_SPEED, DS_TORQUE,
    D_MODE, K_DBFADE, K_FMAX, K_MADH, K_NLEN, K_NOFF, K_PMAX, K_RATE, K_SHARE, K_TAU, K_VEH,
    K_Z, MODE_FORCE, MODE_NOTCH, MODE_SPEED, T_FF, T_G, T_MTOT,
)
from ltdsim.physics.drive.creep import WS_I, WS_R, WS_VREG, slip_control, wheelset_rate
from ltdsim.physics.drive.foc import N_DRIVE, O_ID, O_IQ, O_PDC, drive_rates
from ltdsim.physics.drive.induction import IM_PRD, IM_PRQ, IM_PSD, IM_PSQ
from ltdsim.physics.drive.traction import braking_share, traction_max


@njit(cache=True, _nrt=False, forceinline=True)
def _traction(t, y, a_dem, rtot, tr, dr, w, dy):
    """Traction and dynamic-brake force of each locomotive consist (N, + forward) at
    time ``t`` (s), written to ``w.fcons``; the motor lags' rates (N/s) go to ``dy``.

    The driver's demand by mode: speed, the held demanded acceleration ``a_dem``
    (m/s^2) times the train's mass plus the feed-forward share of the total resistance
    ``rtot`` (N); force, the force profile (N); notch, the held notch (0-8) as a share
    of each consist's limit. A consist with its own notch schedule follows that. The
    demand is shared among the consists and clipped to each one's traction curve
    (force, power and adhesion limits, N). Writes the total applied force and the total
    demand before the limits (N) to ``w.sig``."""
    veh = tr.veh
    cons = tr.cons
    trac = tr.trac
    ctab = tr.tables
    drv = dr.par
    hints = w.hints
    n = veh.shape[0]
    g = trac[T_G]
    mode = drv[D_MODE]
    fd = 0.0
    if mode == MODE_SPEED:
        fd = a_dem * trac[T_MTOT] + trac[T_FF] * rtot
    elif mode == MODE_FORCE:
        fd = _interp(dr.prof_t, dr.prof_y, t, hints, n)
    else:
        fd = _held(dr.prof_t, dr.prof_y, t, hints, n) / 8.0  # notch fraction
    ftot = 0.0
    fdem = 0.0
    for c in range(cons.shape[0]):
        vc = y[n + int(cons[c, K_VEH])]
        lim = traction_max(vc, cons[c, K_FMAX], cons[c, K_PMAX], cons[c, K_MADH], g)
        m_own = int(cons[c, K_NLEN])
        if m_own > 0:
            dem = _held_at(ctab, int(cons[c, K_NOFF]), m_own, t) / 8.0 * lim
        elif mode == MODE_NOTCH:
            dem = fd * lim
        else:
            dem = fd * cons[c, K_SHARE]
        fdem += dem
        kd = tr.drive.of[c]
        if kd >= 0:  # an induction drive: _induction turns the demand into force
            w.ddem[kd] = dem
            continue
        dl = min(max(dem, -lim), lim)
        z = int(cons[c, K_Z])
        if z >= 0:  # motor and inverter lag, with the jerk limit on its rate
            f = y[z]
            # (settled within 1e-6 N: an endless decay ends in slow subnormals)
            rate = (dl - f) / cons[c, K_TAU] if abs(dl - f) > 1e-6 else 0.0
            rmax = cons[c, K_RATE]
            if rmax > 0.0:
                rate = min(max(rate, -rmax), rmax)
            dy[z] = rate
            f = min(max(f, -lim), lim)
        else:
            f = dl
        if f < 0.0:  # dynamic braking dies away as the motors slow, and opposes the motion
            f *= braking_share(vc, cons[c, K_DBFADE])
        w.fcons[c] = f
        ftot += f
    sig = w.sig[0]
    sig["traction"] = ftot
    sig["demand"] = fdem


@njit(cache=True, _nrt=False)
def _drive_axle(y, dy, d, kd, vc, dem, out, sg):
    """Induction drive ``kd`` of the :class:`Drive` ``d`` (a consist's motors, alike) at
    vehicle speed ``vc`` (m/s) under the consist's demand ``dem`` (N): the rates of its
    states at ``y[d.z[kd]:]`` into ``dy``, its drive outputs into ``out`` and its signals
    into ``sg``; returns the consist's creep force, N (law in :func:`_induction`). A
    compiled function of its own, called, not inlined: inlined into every copy of the
    right-hand side it made the kernels' first compile slower
    (docs/induction-drive-train.md)."""
    z = d.z[kd]
    motor = d.motor[kd]
    ctrl = d.ctrl[kd]
    ws = d.ws[kd]
    rail = d.rail[kd]
    slip = d.slip[kd]
    misc = d.misc[kd]
    zw = z + N_DRIVE
    r = ws[WS_R]
    gr = ws[WS_I]
    eta = misc[DM_GEAR_EFF]
    nm = misc[DM_MOTORS]
    if dem < 0.0:
        dem *= braking_share(vc, misc[DM_FADE])
    tw = dem * r / nm
    om = y[zw]
    if misc[DM_SLIP_ON] > 0.0:
        if tw >= 0.0:
            tw, rate = slip_control(y[zw + 1], tw, om, vc, r, slip)
        else:  # braking: the same law on the mirrored slip (wheel-slide protection)
            tw, rate = slip_control(y[zw + 1], -tw, -om, -vc, r, slip)
            tw = -tw
        dy[zw + 1] = rate
    else:
        dy[zw + 1] = 0.0
    t_ref = tw / (gr * eta) if tw >= 0.0 else tw * eta / gr
    wm = gr * om
    te = drive_rates(y[z:zw], wm, t_ref, misc[DM_VDC], motor, ctrl, dy[z:zw], out)
    tw_m = gr * eta * te if te * wm >= 0.0 else gr * te / eta
    dom, f = wheelset_rate(om, vc, tw_m, ws, rail)
    dy[zw] = dom
    sg[DS_TORQUE] = te
    sg[DS_SPEED] = wm
    sg[DS_CURRENT] = misc[DM_TO_RMS] * np.sqrt(out[O_ID] * out[O_ID] + out[O_IQ] * out[O_IQ])
    sg[DS_CREEP] = (om * r - vc) / max(abs(vc), ws[WS_VREG])
    sg[DS_FORCE] = misc[DM_PER_LOCO] * f
    sg[DS_PDC] = misc[DM_PER_LOCO] * out[O_PDC]
    sg[DS_PSD] = y[z + IM_PSD]
    sg[DS_PSQ] = y[z + IM_PSQ]
    sg[DS_PRD] = y[z + IM_PRD]
    sg[DS_PRQ] = y[z + IM_PRQ]
    return nm * f


@njit(cache=True, _nrt=False, forceinline=True)
def _induction(y, tr, w, dy):
    """Force of each locomotive consist with the induction drive (N, + forward), written
    to ``w.fcons`` and added to the signals' total traction; the rates of its states to
    ``dy``; its signals to ``w.dsig`` (:data:`ltdsim.engine.layout.DRIVE_SIGNALS`).

    One motor, its controller, one wheelset and one slip controller stand for each of
    the consist's motors (they share its speed and demand). The consist's demand
    ``w.ddem`` (N, from :func:`_traction`; a braking demand faded below the fade speed as
    on the curve) becomes a wheel-torque demand ``dem r / motors`` (N m); the slip
    controller (:func:`ltdsim.physics.drive.creep.slip_control`; in braking the same law on
    the mirrored slip) may lower its magnitude; the motor's torque demand is it over
    ``G eta`` (motoring) or times ``eta / G`` (braking). The drive
    (:func:`ltdsim.physics.drive.foc.drive_rates`) gives the motor torque ``T_m`` at the shaft
    speed ``G omega``; the gear gives the wheelset ``G eta T_m`` (motoring) or ``G T_m /
    eta`` (braking: the gear's loss is then on the wheel's side); the wheelset
    (:func:`ltdsim.physics.drive.creep.wheelset_rate`) turns under it against the creep force,
    which pushes the consist ``motors`` times."""
    d = tr.drive
    if d.z.shape[0] == 0:
        return
    cons = tr.cons
    n = tr.veh.shape[0]
    ftot = 0.0
    for c in range(cons.shape[0]):
        kd = d.of[c]
        if kd < 0:
            continue
        vc = y[n + int(cons[c, K_VEH])]
        fc = _drive_axle(y, dy, d, kd, vc, w.ddem[kd], w.dout[kd], w.dsig[kd])
        w.fcons[c] = fc
        ftot += fc
    w.sig[0]["traction"] += ftot
