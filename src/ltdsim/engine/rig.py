"""The single-gear rig: one coupler, its deflection prescribed or a mass on it driven by a
force, integrated with the train kernel's coupler code and stage routine.

The rig uses the train's own coupler code (:func:`ltdsim.engine.couplers.coupler_force`,
the coupler lowered by :func:`~ltdsim.engine.couplers.lower_coupler`), Runge-Kutta
tableaux and stage routine (:func:`ltdsim.engine.kernel._stages`, given the rig's
right-hand side), so a gear behaves here exactly as it does in a train. The compiled rig
:func:`_rig` takes named structures: the state, the :class:`Rig` (the coupler and its
drive), the step (:class:`ltdsim.engine.kernel.FixedStep`), its :class:`RigWork` and
:class:`RigOutputs`. The analyses of a gear on the rig (loops, the study's model-reduction
excitation, impacts) are in :mod:`ltdsim.analysis.gears`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ltdsim.engine.couplers import (
    N_GEAR_STATES,
    coupler_force,
    lower_coupler,
    released_force,
)
from ltdsim.engine.features import ALL_KINDS
from ltdsim.engine.integrators import get_tableau
from ltdsim.engine.kernel import CouplerArrays, FixedStep, _advance, _interp, _stages

RIG_DEFLECTION, RIG_FORCE = 0, 1
#: the rig's state ``y``: deflection m (+ draft), its rate m/s, then the gear's states
#: from ``Y_GEAR`` on (as in a train, :mod:`ltdsim.engine.kernel`)
Y_D, Y_V, Y_GEAR = 0, 1, 2
#: search cursors of the drive's lookups (:class:`RigWork` ``hints``): deflection,
#: deflection rate, force
HINT_D, HINT_V, HINT_F = 0, 1, 2


class Rig(NamedTuple):
    """One coupler on the rig and what drives it."""

    couplers: CouplerArrays  # the coupler, as coupler 0 of a train (kernel.CouplerArrays)
    tables: np.ndarray  # the table store its parameters point into (kernel.Train.tables)
    mode: int  # RIG_DEFLECTION or RIG_FORCE
    mass: float  # driven mass, kg (force mode)
    t: np.ndarray  # times of the drive's samples, s
    a: np.ndarray  # deflection d(t), m (deflection mode), or force F(t), N (force mode)
    b: np.ndarray  # deflection rate d'(t), m/s (deflection mode)


class RigWork(NamedTuple):
    """Scratch arrays of :func:`_rig`."""

    K: np.ndarray  # stage derivatives, stage s at K[s * ny:(s + 1) * ny]
    ytmp: np.ndarray  # (ny,) stage state, then the step's increment
    hints: np.ndarray  # (3,) int64 search cursors, H_* slots


class RigOutputs(NamedTuple):
    """The rig's record, one element per step (and the final state)."""

    t: np.ndarray  # time, s
    d: np.ndarray  # deflection, m (+ draft)
    v: np.ndarray  # deflection rate, m/s
    f: np.ndarray  # gear force, N (+ tension)


@njit(cache=True, _nrt=False, forceinline=True)
def _rig_rhs(t, y, dy, p):
    """Right-hand side of the rig at ``(t, y)`` (in the form :func:`ltdsim.engine.kernel._stages`
    calls, ``p = (rig, hints)``), written to ``dy``. Deflection mode: the deflection and
    its rate are the drive's, ``y[Y_D]``/``y[Y_V]`` stay still; force mode: the mass
    ``m d'' = F(t) - T(d, d')``. Returns the deflection (m), its rate (m/s) and the gear
    force (N, + tension)."""
    rig, hints = p
    cp = rig.couplers
    # the coupler's index typed int64, not as the literal 0 (a type of its own): the rig
    # then uses the gear function the train kernels compiled (coupler_models._gear)
    j = np.int64(0)
    if rig.mode == RIG_DEFLECTION:
        d = _interp(rig.t, rig.a, t, hints, HINT_D)
        dd = _interp(rig.t, rig.b, t, hints, HINT_V)
    else:
        d = y[Y_D]
        dd = y[Y_V]
    f = coupler_force(j, cp.model[j], d, dd, y, Y_GEAR, dy, Y_GEAR, cp.par, rig.tables,
                      cp.kinds)
    if rig.mode == RIG_DEFLECTION:
        dy[Y_D] = 0.0
        dy[Y_V] = 0.0
    else:
        dy[Y_D] = dd
        dy[Y_V] = (_interp(rig.t, rig.a, t, hints, HINT_F) - f) / rig.mass
    return d, dd, f


@njit(cache=True, _nrt=False)
def _rig(y, rig, fs, w, out):
    """Integrate the rig from ``y`` (``[d, d', gear states]``, updated in place) with
    the fixed-step method ``fs`` (:class:`ltdsim.engine.kernel.FixedStep`; its ``record_every``
    is not read: the rig records every step), ``rig`` a :class:`Rig`, ``w`` its
    :class:`RigWork`; writes the :class:`RigOutputs` ``out`` at every step and at the
    end. The stages are the train kernels' (:func:`ltdsim.engine.kernel._stages`)."""
    ny = y.shape[0]
    ns = fs.b.shape[0]
    dt = fs.dt
    K = w.K
    p = (rig, w.hints)
    for k in range(fs.n_steps + 1):
        t = k * dt
        d, dd, f = _rig_rhs(t, y, K[0:ny], p)
        out.t[k] = t
        out.d[k] = d
        out.v[k] = dd
        out.f[k] = f
        if k == fs.n_steps:
            break
        _stages(_rig_rhs, p, t, y, dt, fs.A, fs.c, ns, K, w.ytmp)
        _advance(y, dt, fs.b, ns, K, w.ytmp)


def _lowered_gear(params):
    """Kernel arrays for one coupler: its model code, its row of the coupler table
    (shape ``(1, N_CCOL)``) and the table store, lowered by
    :func:`ltdsim.engine.couplers.lower_coupler` as a train's coupler is (neutral
    start)."""
    tables = [0.0]
    one = lower_coupler(params, tables)
    return one.code, one.row.reshape(1, -1).copy(), np.array(tables, dtype=float)


@dataclass
class _Run:
    time: np.ndarray
    deflection: np.ndarray
    rate: np.ndarray
    force: np.ndarray


def rig_args(model, cpl, ctab, mode, t_tab, a_tab, b_tab, mass, t_end, dt, method,
             f0=0.0) -> tuple:
    """Arguments of :func:`_rig` for :func:`integrate_rig`: ``(y, rig, step, work,
    outputs)``, the last a :class:`RigOutputs` (time s, deflection m, rate m/s, force
    N)."""
    tab = get_tableau(method)
    n_steps = int(round(t_end / dt))
    ny = Y_GEAR + N_GEAR_STATES
    y = np.zeros(ny)
    y[Y_GEAR] = f0
    rig = Rig(couplers=CouplerArrays(model=np.array([model], dtype=np.int64), par=cpl,
                                uniform=int(model), kinds=ALL_KINDS),
              tables=ctab, mode=int(mode), mass=float(mass),
              t=np.ascontiguousarray(t_tab, dtype=float),
              a=np.ascontiguousarray(a_tab, dtype=float),
              b=np.ascontiguousarray(b_tab, dtype=float))
    fs = FixedStep(dt=float(dt), n_steps=n_steps, record_every=1, energy_every=1, A=tab.A,
                   b=tab.b, c=tab.c)
    work = RigWork(K=np.zeros(tab.stages * ny), ytmp=np.zeros(ny),
                   hints=np.zeros(3, dtype=np.int64))
    out = RigOutputs(*(np.empty(n_steps + 1) for _ in range(4)))
    return y, rig, fs, work, out


def integrate_rig(model, cpl, ctab, mode, t_tab, a_tab, b_tab, mass, t_end, dt, method,
                  f0=0.0) -> _Run:
    """Run the rig for lowered coupler arrays (``_lowered_gear``); ``f0`` is the initial
    internal force of a hysteretic gear, N."""
    args = rig_args(model, cpl, ctab, mode, t_tab, a_tab, b_tab, mass, t_end, dt, method, f0)
    _rig(*args)
    out = args[-1]
    return _Run(out.t, out.d, out.v, out.f)


def run_rig(params, mode, t_tab, a_tab, b_tab, mass, t_end, dt, method) -> _Run:
    model, cpl, ctab = _lowered_gear(params)
    # a released hysteretic gear starts on its loading curve (its internal force, the
    # first state)
    f0 = released_force(params)
    return integrate_rig(model, cpl, ctab, mode, t_tab, a_tab, b_tab, mass, t_end, dt, method,
                         f0)


