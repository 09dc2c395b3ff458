"""The train's right-hand side ``dy/dt``: one function per subsystem, in this order:
:func:`_resistance` (running, grade and curve resistance per vehicle), the brakes
(:mod:`~ltdsim.engine.kernel.brakes`), traction and the induction drives
(:mod:`~ltdsim.engine.kernel.traction`), :func:`_couplers` (each coupler's force through
the registry's dispatch :func:`ltdsim.engine.couplers.coupler_force`) and
:func:`_force_balance` (each vehicle's acceleration). They pass their results through
the :class:`~ltdsim.engine.kernel.structs.Work` arrays (``res``, ``bforce``, ``fcons``,
``force``, ``defl``, ``sig``) and write their states' rates to ``dy``.

A vehicle's grade force and curve resistance are worked out when it enters a piece of
track and kept in the Work (``tkey``, ``tres``), not at every evaluation; couplers that
all share the simplified model (``CouplerArrays.uniform``) run a loop of their own, in
which the compiler knows the model and drops the dispatch.
"""

from __future__ import annotations

from numba import njit

from ltdsim.engine.couplers import M_SIMPLIFIED, P_D0, coupler_force
from ltdsim.engine.kernel.brakes import _brakes, _brakes_split
from ltdsim.engine.kernel.energy import _energy_rates
from ltdsim.engine.features import when
from ltdsim.engine.kernel.tables import _segment
from ltdsim.engine.kernel.traction import _induction, _traction
from ltdsim.engine.layout import T_G, V_CONS, V_DA, V_DB, V_DC, V_DIV0, V_P0, V_SHARE, V_WMASS
from ltdsim.physics.resistance import curve_force, davis_force, grade_force


@njit(cache=True, _nrt=False, forceinline=True)
def _resistance(y, tr, w):
    """Running resistance of every vehicle (N, + opposing forward motion) at state ``y``:
    Davis terms at its speed, grade and curve resistance of the track segment under it.
    Writes ``w.res`` and the total to ``w.sig["resistance"]``; returns the total, N.

    A vehicle's grade force and curve resistance depend on its segment only (and on the
    sign of its speed): they are worked out when it enters a segment and kept in
    ``w.tres`` (the same numbers, computed once instead of at every evaluation)."""
    veh = tr.veh
    hints = w.hints
    tkey = w.tkey
    tres = w.tres
    res = w.res
    n = veh.shape[0]
    g = tr.trac[T_G]
    rtot = 0.0
    for i in range(n):
        v = y[n + i]
        p = veh[i, V_P0] + y[i]
        r = davis_force(v, veh[i, V_DA], veh[i, V_DB], veh[i, V_DC], veh[i, V_DIV0])
        kt = _segment(tr.track_pos, p, hints[i])
        hints[i] = kt
        if kt != tkey[i]:
            wm = veh[i, V_WMASS]
            tkey[i] = kt
            tres[i, 0] = grade_force(wm, tr.track_grade[kt], g)
            tres[i, 1] = curve_force(1.0, wm, tr.track_curv[kt], tr.curve_h, g)  # (> 0)
        r += tres[i, 0]
        c = tres[i, 1]
        r += c if v > 0.0 else (-c if v < 0.0 else 0.0)  # curve_force's sign rule
        rtot += r
        res[i] = r
    w.sig[0]["resistance"] = rtot
    return rtot


@njit(cache=True, inline="always")
def _coupler(j, model, y, n, cpl, ctab, kinds, w, dy):
    """Force (N, + tension) and deflection (m, + draft) of coupler ``j`` of model code
    ``model`` into ``w.force[j]`` and ``w.defl[j]`` (see :func:`_couplers`)."""
    d = y[j] - y[j + 1] + cpl[j, P_D0]
    dd = y[n + j] - y[n + j + 1]
    w.force[j] = coupler_force(j, model, d, dd, y, 2 * n, dy, 2 * n, cpl, ctab, kinds)
    w.defl[j] = d


@njit(cache=True, _nrt=False, forceinline=True)
def _couplers(y, tr, cp, w, dy):
    """Force (N, + tension) and deflection (m, + draft) of every coupler at state
    ``y``, written to ``w.force`` and ``w.defl``; the hysteretic gears' state rates go
    to ``dy`` (:func:`coupler_force`).

    A train whose couplers all share the simplified model (``cp.uniform``) runs a loop
    of its own, in which the compiler knows the model and drops the dispatch; the
    arithmetic is the same. The loop with the dispatch is compiled only for a train
    that needs it (``cp.kinds.dispatch``)."""
    u = cp.uniform
    if u == M_SIMPLIFIED:
        cpl = cp.par
        ctab = tr.tables
        n = tr.veh.shape[0]
        kinds = cp.kinds
        for j in range(n - 1):
            _coupler(j, u, y, n, cpl, ctab, kinds, w, dy)
    else:
        when(cp.kinds.dispatch, _dispatched_couplers, None, y, tr, cp, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _dispatched_couplers(y, tr, cp, w, dy):
    """:func:`_couplers` of a train with couplers of several models (or one model but
    the simplified): each coupler's law chosen by its model code."""
    cpl = cp.par
    ctab = tr.tables
    n = tr.veh.shape[0]
    kinds = cp.kinds
    for j in range(n - 1):
        _coupler(j, cp.model[j], y, n, cpl, ctab, kinds, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _force_balance(y, tr, w, dy):
    """Newton's second law for every vehicle: its share of its consist's force, minus
    its resistance and brake force, plus the coupler forces from its neighbours (all N)
    over its mass gives its acceleration (m/s^2), written to ``dy[n:2n]``; its speed
    (m/s) is its displacement's rate, ``dy[0:n]``."""
    veh = tr.veh
    inv_m = tr.inv_m
    fcons = w.fcons
    res = w.res
    force = w.force
    n = veh.shape[0]
    for i in range(n):
        # (an unpowered vehicle has share 0 and reads consist 0: no branch in the loop)
        f = veh[i, V_SHARE] * fcons[int(veh[i, V_CONS])] - res[i]
        if i < n - 1:
            f -= force[i]
        if i > 0:
            f += force[i - 1]
        dy[i] = y[n + i]
        dy[n + i] = f * inv_m[i]
    _held_blocks(tr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _held_blocks(tr, w, dy):
    """The couplings held at their slack edges (``w.held``, solver.hold_speed): each run
    of them binds its vehicles into one rigid body, whose acceleration (m/s^2) each of
    them takes in ``dy[n:2n]``, and the held couplings carry the forces (N, into
    ``w.force``) that make it so: along the run from its front, each one's force is the
    one ahead plus its front vehicle's own force (traction share less resistance and
    brake) less that vehicle's mass times the body's acceleration. The couplings at the
    run's two ends keep their laws' forces. The speeds of a held run are equal
    (:func:`ltdsim.engine.kernel.slack._hold_enter` makes them so), so its positions
    stay apart as they were."""
    held = w.held
    veh = tr.veh
    inv_m = tr.inv_m
    fcons = w.fcons
    res = w.res
    force = w.force
    n = veh.shape[0]
    nh = held.shape[0]  # (0 without solver.hold_speed: no iteration)
    j = 0
    while j < nh:
        if held[j] == 0:
            j += 1
            continue
        a = j
        while j < nh and held[j] != 0:
            j += 1
        b = j  # vehicles a..b, joined by the held couplers a..b-1
        f_ahead = force[a - 1] if a > 0 else 0.0
        f_behind = force[b] if b < n - 1 else 0.0
        m_body = 0.0
        f_body = 0.0
        for i in range(a, b + 1):
            m_body += 1.0 / inv_m[i]
            f_body += veh[i, V_SHARE] * fcons[int(veh[i, V_CONS])] - res[i]
        acc = (f_ahead - f_behind + f_body) / m_body
        f = f_ahead
        for i in range(a, b):
            f += veh[i, V_SHARE] * fcons[int(veh[i, V_CONS])] - res[i] - acc / inv_m[i]
            force[i] = f
        for i in range(a, b + 1):
            dy[n + i] = acc


@njit(cache=True, _nrt=False, forceinline=True)
def rhs(t, y, a_dem, n_events, tr, cp, dr, events, w, dy):
    """Right-hand side ``dy/dt`` at ``(t, y)``, written to ``dy`` (``len(y)`` elements):
    resistance, brakes, traction, couplers, force balance, in that order.

    ``tr``, ``cp``, ``dr``: :class:`Train`, :class:`CouplerArrays`, :class:`DriverArrays`;
    ``a_dem`` the demanded acceleration held by the speed controller (m/s^2);
    ``events[:n_events]`` the brake commands issued so far. Also fills, in the
    :class:`Work` ``w``: ``force``/``defl`` (coupler force N, deflection m), ``res``
    (resistance per vehicle, N), ``bforce`` (air-brake force per vehicle, N, + opposing
    forward motion), ``fcons`` (force of each locomotive consist, N) and the signals
    ``sig`` (total traction force N, traction demand before the traction-curve limits
    N, total resistance N). ``w.hints`` holds search cursors (``[0, n)`` track, ``n``
    driver profile, ``n + 1`` speed profile); they change only how fast a lookup is,
    never its result.
    """
    rtot = _resistance(y, tr, w)
    _brakes(t, y, events, n_events, tr, dr, w, dy)
    _traction(t, y, a_dem, rtot, tr, dr, w, dy)
    when(tr.features.drive, _induction, None, y, tr, w, dy)
    _couplers(y, tr, cp, w, dy)
    _force_balance(y, tr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def rhs_split(t, y, a_dem, n_events, tr, cp, dr, events, w, dy):
    """:func:`rhs` for :func:`run_adaptive`, which advances the fluid brake's pneumatic
    states on their own steps: with ``brake.model = "fluid"``, ``y`` and ``dy`` hold
    the mechanical states only (those before ``tr.air.index[I_PIPE]``) and the brakes
    read the pneumatic step's interpolant (:func:`_brakes_split`). Otherwise the same
    as :func:`rhs`, operation for operation."""
    rtot = _resistance(y, tr, w)
    _brakes_split(t, y, events, n_events, tr, dr, w, dy)
    _traction(t, y, a_dem, rtot, tr, dr, w, dy)
    when(tr.features.drive, _induction, None, y, tr, w, dy)
    _couplers(y, tr, cp, w, dy)
    _force_balance(y, tr, w, dy)
    when(tr.features.energy, _energy_rates, None, y, tr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _train_rhs(t, y, dy, p):
    """:func:`rhs` in the form :func:`_stages` calls: ``p = (a_dem, n_events, tr, cp,
    dr, events, w)``, its arguments after ``y``."""
    a_dem, n_events, tr, cp, dr, events, w = p
    rhs(t, y, a_dem, n_events, tr, cp, dr, events, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _train_rhs_split(t, y, dy, p):
    """:func:`rhs_split` in the form :func:`_stages` calls (as :func:`_train_rhs`)."""
    a_dem, n_events, tr, cp, dr, events, w = p
    rhs_split(t, y, a_dem, n_events, tr, cp, dr, events, w, dy)
