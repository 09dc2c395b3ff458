"""The power of every force on the train and the energy accounting (``solver.energy``).

The fixed-step kernel sums each power's trapezoids over its grid (:func:`_account_first`;
:func:`_account_traction` every step, :func:`_powers` every ``energy_every`` steps;
:func:`_energy_totals`); the adaptive kernel integrates the powers as states with the
motion (:func:`_energy_rates`). The terms are :data:`ltdsim.engine.layout.ENERGY_TERMS`
then one per coupler.
"""

from __future__ import annotations

from numba import njit

from ltdsim.engine.kernel.structs import PW_END, PW_START, PW_SUM
from ltdsim.engine.layout import (
    E_AIR, E_CURVE, E_DAVIS, E_DYN, E_GRADE, E_MOTOR, N_ENERGY, T_EZ, V_CONS, V_SHARE,
)


@njit(cache=True, _nrt=False, forceinline=True)
def _powers(y, tr, w, row, add):
    """The power of each force on the train but traction (W) at state ``y``, from the
    forces the last right-hand-side evaluation left in :class:`Work`: air brakes, Davis,
    grade and curve resistance each the power it takes from the train (the grade's is
    the rate of potential energy gained, < 0 downhill; the Davis term is the vehicles'
    whole resistance less the other three, the forces the motion used); each coupler the
    power it takes, ``T (v_j - v_(j+1))`` (its gears' dissipation plus the rate of what
    they store). Written to ``w.pw[row]`` (the energy terms from ``E_AIR``, then one per
    coupler) unless ``row`` < 0, and added to the running sums ``w.pw[PW_SUM]`` when
    ``add``; both are constants at each call site, so the inlined copies keep only their
    branches. One pass over the vehicles: each speed is read once and each coupler's
    power is taken with its rear vehicle."""
    veh = tr.veh
    n = veh.shape[0]
    tres = w.tres
    res = w.res
    force = w.force
    pw = w.pw
    total = 0.0
    grade = 0.0
    curve = 0.0
    v_ahead = 0.0
    for i in range(n):
        v = y[n + i]
        total += res[i] * v
        grade += tres[i, 0] * v
        curve += tres[i, 1] * abs(v)  # (curve_force's sign rule: it opposes the motion)
        if i > 0:
            p = force[i - 1] * (v_ahead - v)
            if row >= 0:
                pw[row, N_ENERGY + i - 1] = p
            if add:
                pw[PW_SUM, N_ENERGY + i - 1] += p
        v_ahead = v
    air = 0.0
    if w.bforce_on[0]:
        bforce = w.bforce
        for i in range(n):
            air += bforce[i] * y[n + i]
    davis = total - grade - curve - air
    if row >= 0:
        pw[row, E_AIR] = air
        pw[row, E_DAVIS] = davis
        pw[row, E_GRADE] = grade
        pw[row, E_CURVE] = curve
    if add:
        pw[PW_SUM, E_AIR] += air
        pw[PW_SUM, E_DAVIS] += davis
        pw[PW_SUM, E_GRADE] += grade
        pw[PW_SUM, E_CURVE] += curve


@njit(cache=True, _nrt=False, forceinline=True)
def _traction_powers(y, tr, w, f_now, f_held):
    """Power of the traction forces ``f_now`` and ``f_held`` (N per locomotive consist)
    at the rail at state ``y``, W: ``(motoring, dynamic braking)`` of each, split by the
    sign of its power on each powered vehicle (dynamic braking counted as the power the
    locomotive takes back, >= 0)."""
    veh = tr.veh
    n = veh.shape[0]
    motor = 0.0
    dyn = 0.0
    held_m = 0.0
    held_d = 0.0
    for i in tr.powered:
        c = int(veh[i, V_CONS])
        v = y[n + i]
        p = veh[i, V_SHARE] * f_now[c] * v
        if p > 0.0:
            motor += p
        else:
            dyn -= p
        p = veh[i, V_SHARE] * f_held[c] * v
        if p > 0.0:
            held_m += p
        else:
            held_d -= p
    return motor, dyn, held_m, held_d


@njit(cache=True, _nrt=False, forceinline=True)
def _account_first(y, tr, w):
    """The energy accounting of :func:`run` at its first step, after the right-hand side
    at ``(0, y)``: the powers now (W) are every power's first sample (``w.pw[PW_START]``),
    its latest (``w.pw[PW_END]``) and its running sum (``w.pw[PW_SUM]``), and the
    traction force now is the one held over the step (``w.fprev``)."""
    pw = w.pw
    pw[PW_END, E_MOTOR], pw[PW_END, E_DYN], _, _ = _traction_powers(y, tr, w, w.fcons,
                                                                    w.fcons)
    _powers(y, tr, w, PW_END, False)
    for q in range(pw.shape[1]):
        pw[PW_START, q] = pw[PW_END, q]
        pw[PW_SUM, q] = pw[PW_END, q]
    for c in range(w.fcons.shape[0]):
        w.fprev[c] = w.fcons[c]


@njit(cache=True, _nrt=False, forceinline=True)
def _account_traction(h, y, tr, w):
    """The traction's energy accounting of :func:`run` at the start of every later step
    of ``h`` (s), after the right-hand side at ``(t, y)`` (so the force in :class:`Work`
    is this state's): the driver's demand is held over a step and jumps where the
    controller samples, so each step's trapezoid takes its end with the force held over
    that step (``w.fprev``) and its start from the step before (``w.pw[PW_START]``, W),
    and is added to ``w.energy`` (J) here, step by step."""
    pw = w.pw
    e = w.energy
    motor, dyn, held_m, held_d = _traction_powers(y, tr, w, w.fcons, w.fprev)
    half = 0.5 * h
    e[E_MOTOR] += half * (pw[PW_START, E_MOTOR] + held_m)
    e[E_DYN] += half * (pw[PW_START, E_DYN] + held_d)
    pw[PW_START, E_MOTOR] = motor
    pw[PW_START, E_DYN] = dyn
    for c in range(w.fcons.shape[0]):
        w.fprev[c] = w.fcons[c]


@njit(cache=True, _nrt=False, forceinline=True)
def _energy_totals(h, w):
    """The energy totals of :func:`run` at a recorded state, whose powers :func:`_powers`
    left in ``w.pw[PW_END]`` (and added to the running sums), into ``w.energy`` (J):
    each power but traction's, sampled every ``h`` (s: the steps between samples,
    ``FixedStep.energy_every``, times the step), is its running sum less half its first
    and its latest sample, times ``h`` (the trapezoids' sum on that grid); the traction
    terms are summed step by step (:func:`_account_traction`)."""
    pw = w.pw
    for q in range(E_AIR, pw.shape[1]):  # (E_MOTOR, E_DYN first: layout.ENERGY_TERMS)
        w.energy[q] = h * (pw[PW_SUM, q] - 0.5 * (pw[PW_START, q] + pw[PW_END, q]))


@njit(cache=True, _nrt=False, forceinline=True)
def _energy_rates(y, tr, w, dy):
    """For :func:`run_adaptive`: the powers (:func:`_traction_powers`, :func:`_powers`, W) as the rates of the
    energy states at ``y[ez:]`` (the trac slot ``T_EZ``; nothing when it is -1), which
    the embedded pair integrates with the motion, stage by stage: its steps are long,
    and a coupler's impact inside one is seen only by its stages."""
    ez = int(tr.trac[T_EZ])
    if ez < 0:
        return
    pw = w.pw
    pw[PW_START, E_MOTOR], pw[PW_START, E_DYN], _, _ = _traction_powers(y, tr, w, w.fcons,
                                                                        w.fcons)
    _powers(y, tr, w, PW_START, False)
    for q in range(pw.shape[1]):
        dy[ez + q] = pw[PW_START, q]
