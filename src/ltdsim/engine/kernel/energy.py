"""The power of every force on the train and the energy accounting (``solver.energy``).

The fixed-step kernel sums each power's trapezoids over its grid (:func:`_account_fixed`,
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
def _powers(y, tr, w, row):
    """The power of each force on the train (W) at state ``y`` into ``w.pw[row]`` (the
    energy terms ``E_*``, then one per coupler), from the forces the last
    right-hand-side evaluation left in :class:`Work`: traction at the rail split into
    motoring and dynamic braking (:func:`_traction_powers`); air brakes, Davis, grade
    and curve resistance each the power it takes from the train (the grade's is the
    rate of potential energy gained, < 0 downhill; the Davis term is the vehicles' whole
    resistance less the other three, the forces the motion used); each coupler the power
    it takes, ``T (v_j - v_(j+1))`` (its gears' dissipation plus the rate of what they
    store)."""
    veh = tr.veh
    n = veh.shape[0]
    tres = w.tres
    res = w.res
    pw = w.pw
    pw[row, E_MOTOR], pw[row, E_DYN] = _traction_powers(y, tr, w, w.fcons)
    total = 0.0
    grade = 0.0
    curve = 0.0
    for i in range(n):
        v = y[n + i]
        total += res[i] * v
        grade += tres[i, 0] * v
        curve += tres[i, 1] * abs(v)  # (curve_force's sign rule: it opposes the motion)
    air = 0.0
    if w.bforce_on[0]:
        bforce = w.bforce
        for i in range(n):
            air += bforce[i] * y[n + i]
    pw[row, E_AIR] = air
    pw[row, E_DAVIS] = total - grade - curve - air
    pw[row, E_GRADE] = grade
    pw[row, E_CURVE] = curve
    force = w.force
    for j in range(n - 1):
        pw[row, N_ENERGY + j] = force[j] * (y[n + j] - y[n + j + 1])


@njit(cache=True, _nrt=False, forceinline=True)
def _traction_powers(y, tr, w, f_trac):
    """Power of the traction force ``f_trac`` (N per locomotive consist) at the rail at
    state ``y``, W: ``(motoring, dynamic braking)``, split by the sign of its power on
    each powered vehicle (dynamic braking counted as the power the locomotive takes
    back, >= 0)."""
    veh = tr.veh
    n = veh.shape[0]
    motor = 0.0
    dyn = 0.0
    for i in tr.powered:
        p = veh[i, V_SHARE] * f_trac[int(veh[i, V_CONS])] * y[n + i]
        if p > 0.0:
            motor += p
        else:
            dyn -= p
    return motor, dyn


@njit(cache=True, _nrt=False, forceinline=True)
def _account_fixed(first, h, y, tr, w):
    """The energy accounting of :func:`run` at the start of a step, after the right-hand
    side at ``(t, y)`` (so the forces in :class:`Work` are this state's).

    On a fixed grid the trapezoids of a power over the steps sum to ``h (the sum of all
    its samples - (first + latest) / 2)``, so each step only adds the powers now to their
    running sums (``w.pw[PW_SUM]``; the first samples in ``w.pw[PW_START]``) and
    :func:`_energy_totals` forms the totals where they are recorded. Traction is the
    exception: the driver's demand is held over a step and jumps where the controller
    samples, so each step's trapezoid takes its end with the force held over that step
    (``w.fprev``) and is added here."""
    pw = w.pw
    e = w.energy
    _powers(y, tr, w, PW_END)  # this state's powers, traction with its force now
    if not first:
        held_m, held_d = _traction_powers(y, tr, w, w.fprev)
        half = 0.5 * h
        e[E_MOTOR] += half * (pw[PW_START, E_MOTOR] + held_m)
        e[E_DYN] += half * (pw[PW_START, E_DYN] + held_d)
    pw[PW_START, E_MOTOR] = pw[PW_END, E_MOTOR]
    pw[PW_START, E_DYN] = pw[PW_END, E_DYN]
    for c in range(w.fcons.shape[0]):
        w.fprev[c] = w.fcons[c]
    if first:
        for q in range(E_AIR, pw.shape[1]):  # (E_MOTOR, E_DYN first: layout.ENERGY_TERMS)
            pw[PW_START, q] = pw[PW_END, q]
            pw[PW_SUM, q] = pw[PW_END, q]
        return
    for q in range(E_AIR, pw.shape[1]):
        pw[PW_SUM, q] += pw[PW_END, q]


@njit(cache=True, _nrt=False, forceinline=True)
def _energy_totals(h, w):
    """The energy totals of :func:`run` at the state just accounted
    (:func:`_account_fixed`, which left its powers in ``w.pw[PW_END]``) into
    ``w.energy`` (J): each continuous power's running sum over the grid of step ``h``
    (s) less half its first and its latest sample, times ``h`` (the trapezoids' sum);
    the traction terms are summed step by step."""
    pw = w.pw
    for q in range(E_AIR, pw.shape[1]):  # (E_MOTOR, E_DYN first: layout.ENERGY_TERMS)
        w.energy[q] = h * (pw[PW_SUM, q] - 0.5 * (pw[PW_START, q] + pw[PW_END, q]))


@njit(cache=True, _nrt=False, forceinline=True)
def _energy_rates(y, tr, w, dy):
    """For :func:`run_adaptive`: the powers (:func:`_powers`, W) as the rates of the
    energy states at ``y[ez:]`` (the trac slot ``T_EZ``; nothing when it is -1), which
    the embedded pair integrates with the motion, stage by stage: its steps are long,
    and a coupler's impact inside one is seen only by its stages."""
    ez = int(tr.trac[T_EZ])
    if ez < 0:
        return
    _powers(y, tr, w, PW_START)
    pw = w.pw
    for q in range(pw.shape[1]):
        dy[ez + q] = pw[PW_START, q]
