"""The valves of the fluid-dynamic air brake: the driver's brake valve and the control
valve (distributor) of every braked vehicle.

Both are written as right-hand sides of ordinary differential equations: the valve's
volumes (reservoirs, cylinder, chambers) hold air whose pressure is a state, and every
flow between two volumes, or from a volume to the atmosphere, passes an orifice and
follows :func:`ltdsim.physics.air.pneumatics.orifice_flow` (compressible, choked and
unchoked, linear very near equal pressures). The valves' air is isothermal at the
ambient temperature ``T`` (K), the brake pipe wall's (``brake.air.temperature``), so a
volume ``V`` (m^3) at pressure ``p`` (Pa, absolute) holds the mass ``p V / (R T)`` (kg)
and its pressure changes at ``dp/dt = R T / V x (mass flow in)``: reservoirs, chambers
and cylinders are small and thick-walled, and the air that enters one from the pipe
takes its wall's temperature (their fast adiabatic transients are left out, see
docs/brake-valves.md). The brake pipe's air has a temperature of its own
(:mod:`ltdsim.physics.air.brakepipe`, ``t_bp``): an orifice that the pipe's air passes
through takes the pipe's temperature on its upstream side
(:func:`ltdsim.physics.air.pneumatics.orifice_flow_between`), and the valves report the
air they feed into the pipe (at ``T``) apart from what they draw, so that the pipe's
energy balance takes each at its own temperature.

Valve positions are continuous states, never flags switched inside the right-hand side,
so that every Runge-Kutta stage sees a right-hand side fixed by the states alone:

* a **piston** position ``x`` in [-1, 1] (-1 release, 0 lap, +1 application) relaxes
  with the time constant ``piston_time`` (s) towards the position its pressures ask for;
  the openings of the valve seats are ``max(x, 0)`` (application) and ``max(-x, 0)``
  (release, exhaust, charging). Openings are ramps of the pressure difference over a
  band (Pa), so the right-hand side is continuous in the states.
* the **emergency piston** position ``e`` in [0, 1] relaxes (``emergency_time``, s)
  towards 1 when the quick-action chamber is more than ``trip`` (Pa) above the pipe,
  towards 0 otherwise. The chamber is charged from the pipe through a choke: a slow
  (service) reduction lets it follow; a fast (emergency) one does not, and the pressure
  difference trips the piston. The difference is a measure of the pipe's rate of fall
  (the sensing of the ABD/ABDX-class emergency portion, whose quick-action chamber is
  charged and discharged through a choke): for a steady fall at ``r`` Pa/s it settles
  where the choke passes the chamber's share, ``orifice_flow(p + lag, p) = V_qa r /
  (R T)`` (:func:`quick_action_lag`), rising about as ``r^2``; a drop shorter than the
  chamber's time constant leaves a lag near its own depth. So the piston trips on a
  fall that is both fast and deep: an emergency (tens of bar/s behind the vents) within
  some 0.05 s, while a service front, steep at the closed rear of a long train but
  only a few tenths of a bar deep, does not. Once open, the vent holds the pipe at the atmosphere, so
  the difference stays and the valve stays tripped (the latch) until the chamber has
  blown down through its vent choke; then the piston closes and the pipe can be
  recharged. The latch is the chamber's pressure, not a flag.
* the **governor** of the main reservoir's compressor (``g`` in [0, 1]) has the same
  hysteresis: on below the cut-in pressure, off above the cut-out, held in between.

Two control-valve families share one state layout (:data:`CV_STATES`) and one parameter
row (:data:`CV_PARAMS`); the row's ``family`` picks the law:

* **UIC** (graduated application and release; three-pressure distributor): a control
  reservoir charged from the pipe holds the reference pressure while the valve is
  released; the cylinder pressure asked for is ``max_cylinder (drop - threshold) /
  (full_drop - threshold)``, capped at ``max_cylinder`` (Pa, gauge), where ``drop`` is
  the pipe's pressure below the control reservoir. The piston compares that with the
  cylinder: it admits auxiliary-reservoir air when the cylinder is low, exhausts the
  cylinder when it is high, laps when equal, so every pipe increase steps the cylinder
  down (graduated release). The control reservoir is connected to the pipe through its
  choke only while the cylinder is below ``control_cutoff`` (released valve); a slow
  pipe leak then bleeds it along (the UIC insensitivity), a driver's reduction outruns
  the choke and applies the brake. The auxiliary reservoir is charged from the pipe
  through a check valve and a choke.
* **AAR** (direct release; triple-valve behaviour): the piston compares the auxiliary
  reservoir with the pipe: application when the reservoir is ``threshold`` above the
  pipe (the threshold shrinks to 0 as the piston travels to application: the slide
  valve's friction, then the lighter graduating valve), lap when they are equal again,
  release when the pipe is ``release_threshold`` above the reservoir. In between the
  piston stays where it is (its friction): a released valve stays released, an applying
  one laps. In release the cylinder exhausts fully and the auxiliary and emergency
  reservoirs recharge. In emergency the emergency reservoir joins the auxiliary one in
  the cylinder; with ``emergency_build_cda`` > 0 the build-up is staged, as the AB-family
  valves build emergency pressure in stages at a controlled rate to spare the train
  slack shocks (US Army TM 55-203, AB and AB-1-B brake system components): up to
  ``emergency_inshot`` (Pa gauge) the cylinder fills through its usual passages, beyond
  it each reservoir feeds it through the build-up choke only.

Both families have quick service (while the piston applies and the cylinder is below
``quick_service_limit``, pipe air flows into a quick-service bulb that bleeds to the
atmosphere: a local draw that speeds the service wave) and a first stage that fills the
cylinder fast up to that limit: from the pipe in AAR valves (secondary quick service,
another local draw), from the auxiliary reservoir in UIC distributors (the minimum-
pressure stage of the Knorr KE, fed from the auxiliary reservoir, and the C3W's inshot
valve, closing at 0.5 bar, as their technical descriptions give them), so that an
emergency, whose vented pipe has no air to give, has its first stage too. Both have the
emergency vent described above (a local vent of the pipe to the atmosphere).

The driver's brake valve has a main reservoir (optionally fed by a compressor), an
equalising reservoir whose pressure the handle sets through a regulating valve
(release: charge to the regulated pressure; service: reduce by ``reduction`` Pa through
the service choke; lap: hold; emergency: exhaust) and a relay valve that makes the pipe
follow the equalising reservoir (feed from the main reservoir when the pipe is below,
exhaust when above). Both are proportional valves: their openings are ramps of their
pressure differences over their bands, fast compared to the reservoirs they serve, so
they are algebraic (no state). The emergency position also opens a large vent whose
position is a state.

Pressures inside are absolute, Pa; parameter rows hold gauge pressures (Pa, gauge)
where the docs say so, and orifices as discharge coefficient times area (m^2).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ltdsim.physics.air.pneumatics import (
    orifice_conductance, orifice_flow, orifice_flow_between,
)

# --- handle codes of the driver's valve -------------------------------------------------
H_RELEASE = 0
H_SERVICE = 1
H_EMERGENCY = 2
H_LAP = 3
H_FAST_FILL = 4

# --- control valve ----------------------------------------------------------------------
FAMILY_UIC = 0
FAMILY_AAR = 1

CV_STATES = (
    "auxiliary",            # auxiliary reservoir, Pa abs
    "cylinder",             # brake cylinder, Pa abs
    "control",              # control reservoir (UIC; AAR: unused, constant), Pa abs
    "emergency_reservoir",  # emergency reservoir (AAR; UIC: unused, constant), Pa abs
    "quick_service",        # quick-service bulb, Pa abs
    "quick_action",         # quick-action chamber of the emergency portion, Pa abs
    "piston",               # service piston position, -1 release .. 0 lap .. +1 apply, -
    "emergency_piston",     # emergency piston position, 0 closed .. 1 tripped, -
)
N_CV = len(CV_STATES)
(CV_AUX, CV_CYL, CV_CTRL, CV_ER, CV_QS, CV_QA, CV_PISTON, CV_EM) = range(N_CV)

CV_PARAMS = (
    "family",                  # 0 UIC (graduated release), 1 AAR (direct release), -
    "auxiliary_volume",        # m^3
    "cylinder_volume",         # m^3 (cylinder at working stroke with its piping)
    "control_volume",          # m^3 (UIC control reservoir; 0 for AAR)
    "emergency_volume",        # m^3 (AAR emergency reservoir; 0 for UIC)
    "quick_service_volume",    # m^3 (0: no bulb)
    "quick_action_volume",     # m^3 (0: no emergency portion)
    "charge_cda",              # pipe -> auxiliary, m^2
    "control_cda",             # pipe <-> control reservoir (UIC), m^2
    "emergency_charge_cda",    # pipe -> emergency reservoir (AAR), m^2
    "apply_cda",               # auxiliary -> cylinder, m^2
    "release_cda",             # cylinder -> atmosphere, m^2
    "quick_service_cda",       # pipe -> quick-service bulb, m^2
    "quick_service_vent_cda",  # bulb -> atmosphere, m^2
    "quick_service_cylinder_cda",  # first stage into the cylinder (UIC: from the auxiliary
                                   # reservoir; AAR: from the pipe), m^2
    "quick_action_cda",        # pipe <-> quick-action chamber (the choke), m^2
    "quick_action_vent_cda",   # quick-action chamber -> atmosphere when tripped, m^2
    "vent_cda",                # pipe -> atmosphere when tripped (emergency vent), m^2
    "emergency_apply_cda",     # emergency reservoir -> cylinder when tripped, m^2
    "max_cylinder",            # UIC: cylinder pressure at full service and above, Pa gauge
    "full_drop",               # UIC: pipe drop below the control reservoir giving it, Pa
    "threshold",               # UIC: drop where application begins; AAR: aux above pipe, Pa
    "release_threshold",       # AAR: pipe above aux that releases, Pa
    "band",                    # proportional band of the piston, Pa
    "piston_time",             # s
    "quick_service_limit",     # cylinder pressure ending quick service, Pa gauge
    "trip",                    # quick-action chamber above pipe that trips emergency, Pa
    "trip_band",               # Pa
    "emergency_time",          # s
    "control_cutoff",          # UIC: cylinder pressure closing the control-reservoir choke, Pa gauge
    "emergency_inshot",        # cylinder pressure up to which an emergency fills freely, Pa gauge
    "emergency_build_cda",     # beyond it each reservoir feeds the cylinder through this, m^2
    "accelerated_release_cda",  # AAR: emergency reservoir -> pipe at the start of a release, m^2
    "branch_volume",           # volume on the pipe's side of the valve (branch pipe, dirt collector,
                               # pipe bracket), m^3: the brake pipe's capacitance, not the valve's
)
N_CV_PARAMS = len(CV_PARAMS)
_CV = {name: i for i, name in enumerate(CV_PARAMS)}
(CVP_FAMILY, CVP_VAUX, CVP_VCYL, CVP_VCTRL, CVP_VER, CVP_VQS, CVP_VQA, CVP_CHARGE, CVP_CTRL, CVP_ERCHARGE,
 CVP_APPLY, CVP_RELEASE, CVP_QS, CVP_QSVENT, CVP_QSCYL, CVP_QA, CVP_QAVENT, CVP_VENT, CVP_EMAPPLY,
 CVP_MAXCYL, CVP_FULLDROP, CVP_THRESH, CVP_RELTHRESH, CVP_BAND, CVP_TPISTON, CVP_QSLIMIT, CVP_TRIP,
 CVP_TRIPBAND, CVP_TEM, CVP_CUTOFF, CVP_INSHOT, CVP_EMBUILD, CVP_ACCREL,
 CVP_VBRANCH) = range(N_CV_PARAMS)

# --- driver's brake valve ---------------------------------------------------------------
DV_STATES = (
    "main_reservoir",   # Pa abs
    "equalising",       # equalising reservoir, Pa abs
    "vent",             # emergency vent position, 0 closed .. 1 open, -
    "governor",         # compressor governor, 0 off .. 1 on, -
    "overcharge",       # overcharge the regulating valve adds to the regulated pressure, Pa
)
N_DV = len(DV_STATES)
(DV_MR, DV_ER, DV_VENT, DV_GOV, DV_OC) = range(N_DV)

DV_PARAMS = (
    "main_volume",            # m^3
    "equalising_volume",      # m^3
    "regulated",              # pipe pressure in release, Pa gauge
    "full_reduction",         # full-service reduction, Pa
    "minimum_reduction",      # minimum (first) service reduction, Pa
    "charge_cda",             # main -> equalising reservoir (regulating valve), m^2
    "service_cda",            # equalising reservoir -> atmosphere in service, m^2
    "emergency_cda",          # equalising reservoir -> atmosphere in emergency, m^2
    "feed_cda",               # main reservoir -> pipe (relay supply), m^2
    "exhaust_cda",            # pipe -> atmosphere (relay exhaust), m^2
    "vent_cda",               # pipe -> atmosphere in emergency, m^2
    "regulating_band",        # Pa
    "relay_band",             # Pa
    "vent_time",              # s
    "compressor_flow",        # kg/s when running (0: none)
    "cut_in",                 # governor starts the compressor below, Pa gauge
    "cut_out",                # and stops it above, Pa gauge
    "governor_band",          # Pa
    "governor_time",          # s
    "main_initial",           # main reservoir pressure at the start, Pa gauge
    "fast_fill_cda",          # main reservoir -> pipe in fast fill (0: no such position), m^2
    "overcharge",             # overcharge a fast fill leaves, Pa above the regulated pressure
    "overcharge_charge_time",  # s: the overcharge builds with this time constant in fast fill
    "overcharge_time",        # s: and decays with this one afterwards
)
N_DV_PARAMS = len(DV_PARAMS)
_DV = {name: i for i, name in enumerate(DV_PARAMS)}
(DVP_VMR, DVP_VER, DVP_REG, DVP_FULL, DVP_MIN, DVP_CHARGE, DVP_SERVICE, DVP_EMERG, DVP_FEED, DVP_EXH,
 DVP_VENT, DVP_REGBAND, DVP_RELBAND, DVP_TVENT, DVP_COMP, DVP_CUTIN, DVP_CUTOUT, DVP_GOVBAND,
 DVP_TGOV, DVP_MRINIT, DVP_FASTFILL, DVP_OC, DVP_TOCCHARGE, DVP_TOC) = range(N_DV_PARAMS)


@njit(cache=True, forceinline=True)
def _ramp(u):
    """0 below 0, 1 above 1, linear in between, -."""
    return min(max(u, 0.0), 1.0)


@njit(cache=True, forceinline=True)
def _through(opening, p1, p2, cda, gamma, r_gas, temperature, r_lin):
    """``opening`` (0-1) times the orifice flow from ``p1`` to ``p2``, kg/s; the orifice
    law is not evaluated at all while the seat is shut (most seats, most of the time)."""
    if opening <= 0.0:
        return 0.0
    return opening * orifice_flow(p1, p2, cda, gamma, r_gas, temperature, r_lin)


@njit(cache=True, forceinline=True)
def _through_between(opening, p1, p2, cda, gamma, r_gas, t1, t2, r_lin):
    """As :func:`_through` between air at ``t1`` (side 1) and ``t2`` (side 2), K: the
    upstream side's temperature (:func:`~ltdsim.physics.air.pneumatics.orifice_flow_between`),
    kg/s."""
    if opening <= 0.0:
        return 0.0
    return opening * orifice_flow_between(p1, p2, cda, gamma, r_gas, t1, t2, r_lin)


@njit(cache=True, forceinline=True)
def _checked(opening, p1, p2, cda, gamma, r_gas, temperature, r_lin):
    """As :func:`_through` behind a check valve: flow from ``p1`` to ``p2`` only, kg/s."""
    if opening <= 0.0 or p1 <= p2:
        return 0.0
    return opening * orifice_flow(p1, p2, cda, gamma, r_gas, temperature, r_lin)


@njit(cache=True, forceinline=True)
def control_valve(p_bp, t_bp, s, par, gamma, r_gas, temperature, atmosphere, r_lin, ds):
    """Rates of one control valve's states and its exchange with the pipe.

    Parameters
    ----------
    p_bp : float
        Brake-pipe pressure at the valve, Pa abs.
    t_bp : float
        Temperature of the brake pipe's air at the valve, K (``temperature`` where the
        pipe is isothermal): the upstream temperature of every flow out of the pipe.
    s : float64 array (N_CV)
        The valve's states, :data:`CV_STATES` (pressures Pa abs, positions -).
    par : float64 array (N_CV_PARAMS)
        Its parameter row, :data:`CV_PARAMS` (see :func:`control_valve_row`).
    gamma, r_gas, temperature, atmosphere, r_lin : float
        Ratio of specific heats (-), gas constant J/(kg K), the valve's (the ambient)
        temperature K, atmosphere Pa abs, the orifice law's linear-region ratio (-).
    ds : float64 array (N_CV)
        Written: the states' rates (Pa/s, 1/s).

    Returns
    -------
    (draw, exhaust, feed) : (float, float, float)
        Net mass flow drawn from the pipe (kg/s; includes the emergency vent), mass
        flow to the atmosphere (kg/s) and the part of the exchange that flows from the
        valve into the pipe (kg/s, >= 0: a control or quick-action chamber, or an AAR
        auxiliary reservoir, above a falling pipe; an AAR valve's accelerated release),
        at ``temperature``; the pipe gives
        ``draw + feed`` at ``t_bp``. The valve's air mass changes at ``draw - exhaust``.
    """
    rt = r_gas * temperature
    pa = s[CV_AUX]
    pc = s[CV_CYL]
    pr = s[CV_CTRL]
    pe = s[CV_ER]
    pq = s[CV_QS]
    pk = s[CV_QA]
    x = min(max(s[CV_PISTON], -1.0), 1.0)
    e = min(max(s[CV_EM], 0.0), 1.0)
    pcg = pc - atmosphere
    band = par[CVP_BAND]

    # emergency portion: quick-action chamber against the pipe
    f_qa = 0.0
    f_qa_vent = 0.0
    f_vent = 0.0
    if par[CVP_VQA] > 0.0:
        f_qa = orifice_flow_between(p_bp, pk, par[CVP_QA], gamma, r_gas, t_bp, temperature,
                                    r_lin)
        f_qa_vent = _through(e, pk, atmosphere, par[CVP_QAVENT], gamma, r_gas,
                             temperature, r_lin)
        f_vent = _through(e, p_bp, atmosphere, par[CVP_VENT], gamma, r_gas, t_bp, r_lin)
        e_target = _ramp((pk - p_bp - par[CVP_TRIP]) / par[CVP_TRIPBAND])
        ds[CV_EM] = (e_target - s[CV_EM]) / par[CVP_TEM]
        ds[CV_QA] = rt / par[CVP_VQA] * (f_qa - f_qa_vent)
    else:
        ds[CV_EM] = -s[CV_EM] / par[CVP_TEM]
        ds[CV_QA] = 0.0

    f_ctrl = 0.0
    f_er = 0.0
    f_em = 0.0
    if par[CVP_FAMILY] == FAMILY_UIC:
        # three-pressure law: the cylinder pressure the control reservoir asks for
        span = par[CVP_FULLDROP] - par[CVP_THRESH]
        target = par[CVP_MAXCYL] * min(max((pr - p_bp - par[CVP_THRESH]) / span, 0.0), 1.0)
        x_target = min(max((target - pcg) / band, -1.0), 1.0)
        # the auxiliary reservoir charges through a check valve, always
        f_charge = _checked(1.0, p_bp, pa, par[CVP_CHARGE], gamma, r_gas, t_bp, r_lin)
        if par[CVP_VCTRL] > 0.0:
            f_ctrl = _through_between(_ramp(1.0 - pcg / par[CVP_CUTOFF]), p_bp, pr,
                                      par[CVP_CTRL], gamma, r_gas, t_bp, temperature, r_lin)
            ds[CV_CTRL] = rt / par[CVP_VCTRL] * f_ctrl
        else:
            ds[CV_CTRL] = 0.0
    else:
        # triple valve: auxiliary reservoir against the pipe, with piston friction
        d = pa - p_bp
        # the slide valve needs `threshold` to leave release or lap; once applying, the
        # lighter graduating valve laps as the reservoir falls to the pipe (with `band`
        # under `threshold` the piston snaps both ways: a physical hysteresis)
        pull_apply = _ramp((d - par[CVP_THRESH] * (1.0 - max(x, 0.0))) / band)
        pull_release = _ramp((-d - par[CVP_RELTHRESH]) / band)
        x_target = pull_apply - pull_release + (1.0 - pull_apply - pull_release) * min(x, 0.0)
        f_charge = _through_between(-x, p_bp, pa, par[CVP_CHARGE], gamma, r_gas, t_bp,
                                    temperature, r_lin)
        ds[CV_CTRL] = 0.0
    # staged emergency build-up: past the inshot pressure, an emergency fills the cylinder
    # from each reservoir through the build-up choke only (0: not staged)
    staged = 0.0
    if par[CVP_EMBUILD] > 0.0:
        staged = e * (1.0 - _ramp((par[CVP_INSHOT] - pcg) / band))
    f_acc = 0.0
    if par[CVP_VER] > 0.0:
        f_er = _checked(-x, p_bp, pe, par[CVP_ERCHARGE], gamma, r_gas, t_bp, r_lin)
        f_em = _checked(e, pe, pc, (1.0 - staged) * par[CVP_EMAPPLY]
                        + staged * par[CVP_EMBUILD], gamma, r_gas, temperature, r_lin)
        if par[CVP_ACCREL] > 0.0:
            # accelerated release: while a release has just begun (the piston in release,
            # the cylinder still above the quick-service limit) emergency-reservoir air
            # goes into the pipe, a local rise that carries the release down the train
            acc = max(-x, 0.0) * _ramp(pcg / par[CVP_QSLIMIT] - 1.0)
            f_acc = _checked(acc, pe, p_bp, par[CVP_ACCREL], gamma, r_gas, temperature, r_lin)
        ds[CV_ER] = rt / par[CVP_VER] * (f_er - f_em - f_acc)
    else:
        ds[CV_ER] = 0.0
    ds[CV_PISTON] = (x_target - s[CV_PISTON]) / par[CVP_TPISTON]

    opening = max(x, 0.0)
    f_apply = _checked(opening, pa, pc, (1.0 - staged) * par[CVP_APPLY]
                       + staged * min(par[CVP_EMBUILD], par[CVP_APPLY]), gamma, r_gas,
                       temperature, r_lin)
    f_release = _through(-x, pc, atmosphere, par[CVP_RELEASE], gamma, r_gas, temperature,
                         r_lin)
    # quick service: while applying and the cylinder is still low
    qs = opening * _ramp(1.0 - pcg / par[CVP_QSLIMIT])
    # the cylinder's first stage: UIC distributors fill it from the auxiliary reservoir
    # (so it comes in an emergency too, with the pipe vented); AAR valves' secondary
    # quick service takes pipe air into the cylinder
    uic = par[CVP_FAMILY] == FAMILY_UIC
    f_qs_cyl = _checked(qs, pa if uic else p_bp, pc, par[CVP_QSCYL], gamma, r_gas,
                        temperature if uic else t_bp, r_lin)
    f_qs_aux = f_qs_cyl if uic else 0.0
    f_qs_pipe = 0.0 if uic else f_qs_cyl
    f_qs = 0.0
    f_qs_vent = 0.0
    if par[CVP_VQS] > 0.0:
        f_qs = _checked(qs, p_bp, pq, par[CVP_QS], gamma, r_gas, t_bp, r_lin)
        f_qs_vent = orifice_flow(pq, atmosphere, par[CVP_QSVENT], gamma, r_gas, temperature,
                                 r_lin)
        ds[CV_QS] = rt / par[CVP_VQS] * (f_qs - f_qs_vent)
    else:
        ds[CV_QS] = 0.0

    ds[CV_AUX] = rt / par[CVP_VAUX] * (f_charge - f_apply - f_qs_aux)
    ds[CV_CYL] = rt / par[CVP_VCYL] * (f_apply + f_em + f_qs_cyl - f_release)
    draw = f_charge + f_ctrl + f_er + f_qs + f_qs_pipe + f_qa + f_vent - f_acc
    exhaust = f_release + f_qs_vent + f_qa_vent + f_vent
    feed = max(-f_charge, 0.0) + max(-f_ctrl, 0.0) + max(-f_qa, 0.0) + f_acc
    return draw, exhaust, feed


@njit(cache=True, forceinline=True)
def driver_valve(p_bp, t_bp, s, par, handle, reduction, gamma, r_gas, temperature,
                 atmosphere, r_lin, ds):
    """Rates of one driver's brake valve's states and its exchange with the pipe.

    Parameters
    ----------
    p_bp : float
        Brake-pipe pressure where the valve feeds it, Pa abs.
    t_bp : float
        Temperature of the brake pipe's air there, K (the relay exhaust's and the
        vent's upstream temperature).
    s : float64 array (N_DV)
        The valve's states, :data:`DV_STATES`.
    par : float64 array (N_DV_PARAMS)
        Its parameter row, :data:`DV_PARAMS` (see :func:`driver_valve_row`).
    handle : int
        :data:`H_RELEASE` (running: charge the pipe to the regulated pressure plus what
        is left of an overcharge), :data:`H_FAST_FILL` (the main reservoir straight into
        the pipe through ``fast_fill_cda`` while the handle is held, up to the regulated
        pressure plus ``overcharge``, which the regulating valve takes up),
        :data:`H_SERVICE` (``reduction`` Pa below the regulated pressure),
        :data:`H_EMERGENCY` (vent), :data:`H_LAP` (hold the equalising reservoir; the
        relay keeps the pipe at it). Out of fast fill the overcharge decays with
        ``overcharge_time``, slowly enough that the control valves, whose reference
        follows the pipe, do not apply (the UIC's insensitivity to slow drops).
    reduction : float
        Service reduction below the regulated pressure, Pa (used in service only).
    gamma, r_gas, temperature, atmosphere, r_lin : float
        As in :func:`control_valve`.
    ds : float64 array (N_DV)
        Written: the states' rates.

    Returns
    -------
    (into_pipe, exhaust, feed) : (float, float, float)
        Net mass flow into the pipe (kg/s; feed minus relay exhaust minus vent), mass
        flow to the atmosphere (kg/s) and the relay's feed from the main reservoir
        into the pipe (kg/s, >= 0, at ``temperature``). The valve's air mass changes at
        ``compressor - into_pipe - exhaust`` (see :func:`driver_valve_compressor`).
    """
    rt = r_gas * temperature
    pm = s[DV_MR]
    pe = s[DV_ER]
    v = min(max(s[DV_VENT], 0.0), 1.0)
    g = min(max(s[DV_GOV], 0.0), 1.0)

    # overcharge of the regulating valve: builds in fast fill, decays otherwise
    oc = s[DV_OC]
    if handle == H_FAST_FILL and par[DVP_OC] > 0.0:
        ds[DV_OC] = (par[DVP_OC] - oc) / par[DVP_TOCCHARGE]
    elif par[DVP_OC] > 0.0:
        ds[DV_OC] = -oc / par[DVP_TOC]
    else:
        ds[DV_OC] = 0.0
    # regulating valve of the equalising reservoir
    f_erc = 0.0
    f_ere = 0.0
    v_target = 0.0
    if handle != H_LAP:
        if handle == H_RELEASE or handle == H_FAST_FILL:
            target = atmosphere + par[DVP_REG] + max(oc, 0.0)
            cda = par[DVP_SERVICE]
        elif handle == H_SERVICE:
            target = max(atmosphere + par[DVP_REG] - reduction, atmosphere)
            cda = par[DVP_SERVICE]
        else:
            target = atmosphere
            cda = par[DVP_EMERG]
            v_target = 1.0
        err = (target - pe) / par[DVP_REGBAND]
        f_erc = _checked(_ramp(err), pm, pe, par[DVP_CHARGE], gamma, r_gas, temperature,
                         r_lin)
        f_ere = _through(_ramp(-err), pe, atmosphere, cda, gamma, r_gas, temperature,
                         r_lin)
    # relay valve: the pipe follows the equalising reservoir
    z = (pe - p_bp) / par[DVP_RELBAND]
    feed = _checked(_ramp(z), pm, p_bp, par[DVP_FEED], gamma, r_gas, temperature, r_lin)
    rex = _through(_ramp(-z), p_bp, atmosphere, par[DVP_EXH], gamma, r_gas, t_bp, r_lin)
    f_vent = _through(v, p_bp, atmosphere, par[DVP_VENT], gamma, r_gas, t_bp, r_lin)
    f_fill = 0.0
    if handle == H_FAST_FILL and par[DVP_FASTFILL] > 0.0:  # (up to the overcharged pressure)
        z_fill = (atmosphere + par[DVP_REG] + par[DVP_OC] - p_bp) / par[DVP_RELBAND]
        f_fill = _checked(_ramp(z_fill), pm, p_bp, par[DVP_FASTFILL], gamma, r_gas,
                          temperature, r_lin)
    ds[DV_VENT] = (v_target - s[DV_VENT]) / par[DVP_TVENT]
    # compressor governor with hysteresis
    comp = 0.0
    if par[DVP_COMP] > 0.0:
        pmg = pm - atmosphere
        pull_on = _ramp((par[DVP_CUTIN] - pmg) / par[DVP_GOVBAND])
        pull_off = _ramp((pmg - par[DVP_CUTOUT]) / par[DVP_GOVBAND])
        g_target = pull_on + (1.0 - pull_on - pull_off) * g
        ds[DV_GOV] = (g_target - s[DV_GOV]) / par[DVP_TGOV]
        comp = g * par[DVP_COMP]
    else:
        ds[DV_GOV] = 0.0
    ds[DV_MR] = rt / par[DVP_VMR] * (comp - f_erc - feed - f_fill)
    ds[DV_ER] = rt / par[DVP_VER] * (f_erc - f_ere)
    return feed + f_fill - rex - f_vent, f_ere + rex + f_vent, feed + f_fill


@njit(cache=True, forceinline=True)
def driver_valve_compressor(s, par):
    """Mass flow the compressor delivers into the main reservoir, kg/s (the air the
    train gains; add it to the conservation balance)."""
    if par[DVP_COMP] <= 0.0:
        return 0.0
    return min(max(s[DV_GOV], 0.0), 1.0) * par[DVP_COMP]


@njit(cache=True)
def control_valve_mass(s, par, r_gas, temperature):
    """Air mass in one control valve's volumes, kg."""
    return (s[CV_AUX] * par[CVP_VAUX] + s[CV_CYL] * par[CVP_VCYL] + s[CV_CTRL] * par[CVP_VCTRL]
            + s[CV_ER] * par[CVP_VER] + s[CV_QS] * par[CVP_VQS] + s[CV_QA] * par[CVP_VQA]
            ) / (r_gas * temperature)


@njit(cache=True)
def driver_valve_mass(s, par, r_gas, temperature):
    """Air mass in one driver's valve's reservoirs, kg."""
    return (s[DV_MR] * par[DVP_VMR] + s[DV_ER] * par[DVP_VER]) / (r_gas * temperature)


# --- parameter rows from presets ----------------------------------------------------------

# preset keys given as an effective diameter (m) -> row entry (Cd x area, m^2)
_CV_ORIFICES = {
    "charge_diameter": "charge_cda",
    "control_diameter": "control_cda",
    "emergency_charge_diameter": "emergency_charge_cda",
    "apply_diameter": "apply_cda",
    "release_diameter": "release_cda",
    "quick_service_diameter": "quick_service_cda",
    "quick_service_vent_diameter": "quick_service_vent_cda",
    "quick_service_cylinder_diameter": "quick_service_cylinder_cda",
    "quick_action_diameter": "quick_action_cda",
    "quick_action_vent_diameter": "quick_action_vent_cda",
    "vent_diameter": "vent_cda",
    "emergency_apply_diameter": "emergency_apply_cda",
    "emergency_build_diameter": "emergency_build_cda",
    "accelerated_release_diameter": "accelerated_release_cda",
}
_DV_ORIFICES = {
    "charge_diameter": "charge_cda",
    "service_diameter": "service_cda",
    "emergency_diameter": "emergency_cda",
    "feed_diameter": "feed_cda",
    "exhaust_diameter": "exhaust_cda",
    "vent_diameter": "vent_cda",
    "fast_fill_diameter": "fast_fill_cda",
}
_POSITIVE_CV = ("auxiliary_volume", "cylinder_volume", "band", "piston_time",
                "quick_service_limit", "trip_band", "emergency_time", "apply_cda",
                "release_cda", "charge_cda")
_POSITIVE_DV = ("main_volume", "equalising_volume", "regulated", "full_reduction",
                "regulating_band", "relay_band", "vent_time", "feed_cda", "service_cda",
                "emergency_cda", "charge_cda", "exhaust_cda", "vent_cda")


def _row(table: dict, names: tuple, orifices: dict, positive: tuple, what: str,
         extra: dict) -> np.ndarray:
    """A float row in the order ``names`` from a preset table (orifice diameters turned
    into Cd x area with the table's ``discharge_coefficient``)."""
    if not isinstance(table, dict):
        raise ValueError(f"{what}: expected a table of keys")  # noqa: TRY004
    allowed = set(names) | set(orifices) | {"discharge_coefficient"} | set(extra)
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ValueError(f"{what}: unknown key {unknown[0]!r}; allowed: "
                         f"{', '.join(sorted(allowed))}")
    cd = float(table.get("discharge_coefficient", 0.8))
    if not 0.0 < cd <= 1.0:
        raise ValueError(f"{what}.discharge_coefficient: {cd} outside (0, 1]")
    values = dict(extra)
    for key, val in table.items():
        if key == "discharge_coefficient":
            continue
        numeric = (key in names or key in orifices) and key != "family"
        if isinstance(val, str) and not numeric:  # (a word: the valve's family)
            values[key] = val
            continue
        if isinstance(val, (bool, str)):  # (float(True) is 1: no pressure or size)
            raise ValueError(f"{what}.{key}: expected a number, got {val!r}")
        try:
            val = float(val)
        except (TypeError, ValueError):
            raise ValueError(f"{what}.{key}: expected a number, got {val!r}") from None
        if not math.isfinite(val) or val < 0.0:
            raise ValueError(f"{what}.{key}: {val} must be a finite number >= 0")
        if key in orifices:
            values[orifices[key]] = cd * math.pi * val * val / 4.0
        else:
            values[key] = val
    row = np.zeros(len(names))
    for i, name in enumerate(names):
        if name in values and not isinstance(values[name], str):
            row[i] = values[name]
    for name in positive:
        if row[names.index(name)] <= 0.0:
            key = name.replace("_cda", "_diameter")
            raise ValueError(f"{what}.{key}: must be given and > 0")
    return row


def control_valve_row(preset: dict) -> np.ndarray:
    """The control-valve parameter row (:data:`CV_PARAMS`, float64) from a preset's
    ``[control_valve]`` table: volumes m^3, orifices as effective diameters m (with one
    ``discharge_coefficient``), pressures Pa gauge, times s, ``family = "uic" | "aar"``.
    Raises ``ValueError`` (one line) on a missing, unknown or out-of-range key."""
    family = preset.get("family") if isinstance(preset, dict) else None
    if family not in ("uic", "aar"):
        raise ValueError(f"control_valve.family: {family!r}; allowed: 'uic', 'aar'")
    row = _row(preset, CV_PARAMS, _CV_ORIFICES, _POSITIVE_CV, "control_valve", {})
    row[CVP_FAMILY] = FAMILY_UIC if family == "uic" else FAMILY_AAR
    if family == "uic":
        for key in ("control_volume", "control_cda", "max_cylinder", "full_drop",
                    "control_cutoff"):
            if row[_CV[key]] <= 0.0:
                raise ValueError(f"control_valve: {key.replace('_cda', '_diameter')} "
                                 "must be given and > 0 for family 'uic'")
        if row[CVP_FULLDROP] <= row[CVP_THRESH]:
            raise ValueError("control_valve.full_drop must exceed control_valve.threshold")
    else:
        if row[CVP_RELTHRESH] <= 0.0 or row[CVP_THRESH] <= 0.0:
            raise ValueError("control_valve: threshold and release_threshold must be "
                             "given and > 0 for family 'aar'")
    if row[CVP_VQA] > 0.0:
        for key in ("quick_action_cda", "trip"):
            if row[_CV[key]] <= 0.0:
                raise ValueError(f"control_valve: {key.replace('_cda', '_diameter')} must "
                                 "be given and > 0 with a quick_action_volume")
    # an orifice into a volume that is not there is closed
    for vol, cdas in ((CVP_VCTRL, (CVP_CTRL,)), (CVP_VER, (CVP_ERCHARGE, CVP_EMAPPLY)),
                      (CVP_VQS, (CVP_QS, CVP_QSVENT)), (CVP_VQA, (CVP_QA, CVP_QAVENT, CVP_VENT))):
        if row[vol] <= 0.0:
            for c in cdas:
                row[c] = 0.0
    return row


def driver_valve_row(preset: dict) -> np.ndarray:
    """The driver's-valve parameter row (:data:`DV_PARAMS`, float64) from a preset's
    ``[driver_valve]`` table (units as in :func:`control_valve_row`)."""
    row = _row(preset, DV_PARAMS, _DV_ORIFICES, _POSITIVE_DV, "driver_valve", {})
    if row[DVP_FULL] >= row[DVP_REG] or row[DVP_MIN] > row[DVP_FULL]:
        raise ValueError("driver_valve: need minimum_reduction <= full_reduction < regulated")
    if row[DVP_COMP] > 0.0:
        if not 0.0 < row[DVP_CUTIN] < row[DVP_CUTOUT]:
            raise ValueError("driver_valve: need 0 < cut_in < cut_out with a compressor")
        if row[DVP_GOVBAND] <= 0.0 or row[DVP_TGOV] <= 0.0:
            raise ValueError("driver_valve: governor_band and governor_time must be > 0 "
                             "with a compressor")
    if row[DVP_MRINIT] <= row[DVP_REG]:
        raise ValueError("driver_valve.main_initial must exceed driver_valve.regulated")
    if row[DVP_OC] > 0.0:
        if row[DVP_FASTFILL] <= 0.0:
            raise ValueError("driver_valve.overcharge needs fast_fill_diameter > 0 (the "
                             "overcharge is what a fast fill leaves)")
        if row[DVP_TOCCHARGE] <= 0.0 or row[DVP_TOC] <= 0.0:
            raise ValueError("driver_valve: overcharge_charge_time and overcharge_time must "
                             "be > 0 with an overcharge")
    return row


def control_valve_init(p_bp_abs: float, par: np.ndarray,
                       atmosphere: float = 101325.0) -> np.ndarray:
    """States (:data:`CV_STATES`) of a control valve charged to the pipe pressure
    ``p_bp_abs`` (Pa abs) and released: reservoirs and chambers at the pipe pressure,
    cylinder and quick-service bulb at ``atmosphere`` (Pa abs), piston in release (-1),
    emergency piston closed (0). Unused volumes (zero in ``par``) hold no air."""
    s = np.empty(N_CV)
    s[CV_AUX] = s[CV_CTRL] = s[CV_ER] = s[CV_QA] = p_bp_abs
    s[CV_CYL] = s[CV_QS] = atmosphere
    s[CV_PISTON] = -1.0
    s[CV_EM] = 0.0
    return s


def driver_valve_init(p_bp_abs: float, par: np.ndarray,
                      atmosphere: float = 101325.0) -> np.ndarray:
    """States (:data:`DV_STATES`) of a driver's valve in release with the pipe charged
    to ``p_bp_abs`` (Pa abs): main reservoir at ``main_initial``, equalising reservoir
    at the pipe pressure, vent closed, compressor governor off, no overcharge."""
    s = np.empty(N_DV)
    s[DV_MR] = atmosphere + par[DVP_MRINIT]
    s[DV_ER] = p_bp_abs
    s[DV_VENT] = 0.0
    s[DV_GOV] = 0.0
    s[DV_OC] = 0.0
    return s


def quick_action_lag(par: np.ndarray, rate: float, p_abs: float, gamma: float = 1.4,
                     r_gas: float = 287.05, temperature: float = 293.15,
                     r_lin: float = 0.995) -> float:
    """Steady lag (Pa) of the quick-action chamber behind a pipe falling steadily at
    ``rate`` (Pa/s) through the pressure ``p_abs`` (Pa abs): the difference at which the
    chamber's choke passes the air that keeps the chamber falling with the pipe,
    ``orifice_flow(p_abs + lag, p_abs) = V_qa rate / (R T)``; ``inf`` if the choke
    cannot pass that flow from any chamber pressure below twice ``p_abs`` (the pipe is
    falling faster than the chamber can follow: it trips after the pipe has fallen about
    ``trip``). The emergency piston trips where the lag exceeds ``trip``; the rate at
    which the steady lag equals ``trip`` is the preset's emergency rate."""
    from scipy.optimize import brentq

    v, cda = par[CVP_VQA], par[CVP_QA]
    if v <= 0.0 or cda <= 0.0 or rate <= 0.0:
        return 0.0 if rate <= 0.0 else math.inf
    need = v * rate / (r_gas * temperature)

    def excess(lag):
        return orifice_flow(p_abs + lag, p_abs, cda, gamma, r_gas, temperature,
                            r_lin) - need

    if excess(p_abs) < 0.0:
        return math.inf
    return float(brentq(excess, 0.0, p_abs, xtol=1e-3))


# --- the fastest rates, for the step limit ------------------------------------------------

def _g(cda, gamma, r_gas, temperature, r_lin):
    return orifice_conductance(cda, gamma, r_gas, temperature, r_lin)


def _choked(cda, p_up, gamma, r_gas, temperature):
    """Choked mass flow through ``cda`` from ``p_up``, kg/s (the most the orifice passes
    at that upstream pressure)."""
    return (cda * p_up * math.sqrt(gamma / (r_gas * temperature))
            * (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (2.0 * (gamma - 1.0))))


def valve_max_rate(par: np.ndarray, kind: str, cell_volume: float, p_max: float,
                   gamma: float = 1.4, r_gas: float = 287.05, temperature: float = 293.15,
                   r_lin: float = 0.995) -> float:
    """Fastest rate, 1/s, of a valve's linearised dynamics (its volumes through its
    orifices near equal pressures, its relaxation times, the proportional loops of its
    pistons), for the explicit integrator's step limit.

    ``kind`` is "control" (a :data:`CV_PARAMS` row) or "driver" (:data:`DV_PARAMS`);
    ``cell_volume`` (m^3) is the pipe cell the valve connects to; ``p_max`` (Pa abs) the
    highest pressure in the system (for the flow a fully open valve passes). An orifice
    with conductance ``G`` between volumes ``V1`` and ``V2`` equalises at the rate
    ``R T G (1/V1 + 1/V2)``; a proportional valve passing at most ``F`` kg/s over the
    band ``b`` Pa into ``V`` closes its loop at ``R T F / (V b)``.
    """
    rt = r_gas * temperature

    def pair(cda, v1, v2):
        if cda <= 0.0:
            return 0.0
        inv = (1.0 / v1 if v1 > 0 else 0.0) + (1.0 / v2 if v2 > 0 else 0.0)
        return rt * _g(cda, gamma, r_gas, temperature, r_lin) * inv

    atmos = 0.0  # the atmosphere, an infinite volume: it adds 1/V = 0
    rates = []
    if kind == "control":
        va, vc, vr, ve = par[CVP_VAUX], par[CVP_VCYL], par[CVP_VCTRL], par[CVP_VER]
        vq, vk = par[CVP_VQS], par[CVP_VQA]
        rates += [pair(par[CVP_CHARGE], cell_volume, va), pair(par[CVP_CTRL], cell_volume, vr),
                  pair(par[CVP_ERCHARGE], cell_volume, ve), pair(par[CVP_APPLY], va, vc),
                  pair(par[CVP_RELEASE], vc, atmos), pair(par[CVP_QS], cell_volume, vq),
                  pair(par[CVP_QSVENT], vq, atmos), pair(par[CVP_QSCYL], cell_volume, vc),
                  pair(par[CVP_QA], cell_volume, vk), pair(par[CVP_QAVENT], vk, atmos),
                  pair(par[CVP_VENT], cell_volume, atmos), pair(par[CVP_EMAPPLY], ve, vc),
                  pair(par[CVP_EMBUILD], ve if ve > 0.0 else va, vc),
                  pair(par[CVP_ACCREL], ve, cell_volume),
                  1.0 / par[CVP_TPISTON], 1.0 / par[CVP_TEM]]
        f_full = _choked(max(par[CVP_APPLY], par[CVP_RELEASE]), p_max, gamma, r_gas, temperature)
        if par[CVP_FAMILY] == FAMILY_UIC:
            rates.append(rt * f_full / (vc * par[CVP_BAND]))
        else:
            rates.append(rt * f_full / (va * par[CVP_BAND]))
    elif kind == "driver":
        vm, ver = par[DVP_VMR], par[DVP_VER]
        rates += [pair(par[DVP_CHARGE], vm, ver), pair(par[DVP_SERVICE], ver, atmos),
                  pair(par[DVP_EMERG], ver, atmos), pair(par[DVP_FEED], vm, cell_volume),
                  pair(par[DVP_EXH], cell_volume, atmos), pair(par[DVP_VENT], cell_volume, atmos),
                  1.0 / par[DVP_TVENT],
                  rt * _choked(par[DVP_CHARGE], p_max, gamma, r_gas, temperature)
                  / (ver * par[DVP_REGBAND]),
                  rt * _choked(max(par[DVP_FEED], par[DVP_EXH]), p_max, gamma, r_gas,
                               temperature) / (cell_volume * par[DVP_RELBAND])]
        if par[DVP_COMP] > 0.0:
            rates.append(1.0 / par[DVP_TGOV])
        rates.append(pair(par[DVP_FASTFILL], vm, cell_volume))
        if par[DVP_OC] > 0.0:
            rates += [1.0 / par[DVP_TOCCHARGE], 1.0 / par[DVP_TOC]]
    else:
        raise ValueError(f"kind {kind!r}; allowed: 'control', 'driver'")
    return float(max(rates))
