"""Runge-Kutta primitives shared by every loop: the stage routine, the step's end, the
finite check, the embedded pair's solution and error, and its step-size controller.

One stage routine, :func:`_stages`, computes the stages of any explicit Runge-Kutta
tableau for any right-hand side passed to it as a compiled function (numba compiles it
once per right-hand side): the train's in :func:`~ltdsim.engine.kernel.stepping.run`
and :func:`~ltdsim.engine.kernel.stepping.run_adaptive`, the gear rig's in
:mod:`ltdsim.engine.rig`. :func:`_advance` ends a fixed step (``run`` and the rig),
written out for three and four stages (ode3, rk4) in one pass over the state.

The embedded pair (bs23, :data:`ltdsim.engine.integrators.BS23`) steps the train's
mechanical states in :func:`~ltdsim.engine.kernel.stepping.run_adaptive` and the fluid
brake's pneumatic states on their own steps
(:func:`~ltdsim.engine.kernel.brakes._air_step`); both form the kept solution with
:func:`pair_solution`, the error estimate with :func:`pair_error` and scale it with
:func:`scaled_error`, and both choose the next step with :func:`step_accepted` or
:func:`step_rejected`: one proportional-integral controller (Gustafsson's), whose
exponents follow from the pair's order.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.engine.integrators import BS23

#: the pair's error estimate shrinks as h^ERROR_ORDER: its lower (second) order plus one,
#: the order of its kept solution
ERROR_ORDER = float(BS23.order)
#: step-size control: the share of the step the error estimate asks for that is taken, -
SAFETY = 0.9
#: the smallest and largest change of the step in one go, -
MIN_FACTOR, MAX_FACTOR = 0.2, 5.0
#: Gustafsson's PI controller: exponents of this step's error and of the last accepted
#: step's, times 1 / ERROR_ORDER (a plain controller: 1 and 0)
PI_ALPHA, PI_BETA = 0.7, 0.4
#: the last accepted step's error counts as at least this (an error of 0 says nothing), -
ERROR_FLOOR = 1e-4
#: the shortest step, s: a step rejected below it ends the run with a non-finite state
MIN_STEP = 1e-12
#: slack edges: locate the points where a coupling meets or leaves its slack edge
#: (:func:`~ltdsim.engine.kernel.slack._edge_crossing`) and end steps there. Off: on 20 s
#: of heavy-haul cruise with couplers chattering at their edges it brought the worst
#: coupler's peak from +19 % to +3.8 % of a converged fixed step at 34x the attempted
#: steps (19x the CPU time, about the fixed step's at 1e-4 s, which is within 3.6 %),
#: and within 1 % only at 1250x (every touch located); measured 2026-12-03
#: (docs/heavy-haul.md, "Locating the slack edges"). With a damped end of the slack and
#: EDGE_SPEED raised to 100 (1 mm/s at speed_atol 1e-5) it is cheap, 7 % more steps
#: over the trip's first hour, but leaves the couplers' peaks as scattered as without
#: it (measured 2026-12-07, same page). True compiles it in.
EDGE_LOCATION = False
#: a step may go on past the first such point by at most this share of its length; a
#: longer one is taken again, cut to end half this share past the point, so that the
#: next step starts in the new regime, -
EDGE_TAIL = 0.02
#: a step no longer than this is not cut at a slack edge (s): what it carries across
#: the edge in the old regime is below any tolerance (100 kN on 65 t for 1e-7 s moves a
#: coupling's speed by 1.5e-7 m/s)
EDGE_MIN_STEP = 1e-7
#: a crossing at a closing or opening speed below this many times the speeds' absolute
#: tolerance is not located: a coupling held at its edge by a force between none and
#: its gear's preload touches and leaves it again and again, ever more slowly (located
#: one by one, its crossings take steps without end), -
EDGE_SPEED = 3.0



# (not cached on its own: it is compiled into each kernel, which is cached. Its argument
# ``f`` is a compiled function, and numba's cache index keys such an argument by the
# function object of the process that wrote it, which another process can neither match
# nor always write back: a process saving a new version into an index that other
# processes had written failed with "ReferenceError: underlying object has vanished")
@njit(_nrt=False, forceinline=True)
def _stages(f, p, t, y, h, A, C, ns, K, ytmp):
    """Stages 2 to ``ns`` of an explicit Runge-Kutta step of size ``h`` (s) from
    ``(t, y)`` of the right-hand side ``f(t, y, dy, p)`` (a compiled function writing
    ``dy/dt`` to ``dy``; ``p`` its other arguments, one tuple), given stage 1 at
    ``K[0:ny]``: stage s is ``f`` at ``t + C[s] h`` and ``y + h sum_j A[s, j] K_j``,
    written to ``K[s * ny:(s + 1) * ny]``; ``ytmp`` (``ny`` elements) holds the stage
    state. The one stage routine of :func:`run`, :func:`run_adaptive` and the gear rig
    (:mod:`ltdsim.analysis.gears`)."""
    ny = y.shape[0]
    for s in range(1, ns):
        # (loops over the state innermost, one pass per nonzero coefficient: vectorised)
        first = True
        for j in range(s):
            wt = h * A[s, j]
            if wt != 0.0:
                o = j * ny
                if first:
                    for q in range(ny):
                        ytmp[q] = y[q] + wt * K[o + q]
                    first = False
                else:
                    for q in range(ny):
                        ytmp[q] += wt * K[o + q]
        if first:
            for q in range(ny):
                ytmp[q] = y[q]
        f(t + C[s] * h, ytmp, K[s * ny:(s + 1) * ny], p)


@njit(cache=True, inline="always")
def _advance(y, h, B, ns, K, inc):
    """End of a Runge-Kutta step of size ``h`` (s): ``y += h sum_s B[s] K_s`` over the
    ``ns`` stages at ``K[s * ny:(s + 1) * ny]``, the increment summed first (from 0, in
    stage order) for accuracy. The step's end for :func:`run` and the gear rig.

    Three and four stages (ode3, rk4) are written out, one pass over the state; other
    methods sum in ``inc`` (``ny`` elements), a pass per stage. Both forms add the same
    terms in the same order (the leading ``0.0 +`` included), so the result does not
    depend on the form."""
    ny = y.shape[0]
    if ns == 3:
        w0, w1, w2 = h * B[0], h * B[1], h * B[2]
        for q in range(ny):
            y[q] += ((0.0 + w0 * K[q]) + w1 * K[ny + q]) + w2 * K[2 * ny + q]
        return
    if ns == 4:
        w0, w1, w2, w3 = h * B[0], h * B[1], h * B[2], h * B[3]
        for q in range(ny):
            y[q] += (((0.0 + w0 * K[q]) + w1 * K[ny + q]) + w2 * K[2 * ny + q]) \
                + w3 * K[3 * ny + q]
        return
    for q in range(ny):
        inc[q] = 0.0
    for s in range(ns):
        wt = h * B[s]
        o = s * ny
        for q in range(ny):
            inc[q] += wt * K[o + q]
    for q in range(ny):
        y[q] += inc[q]


@njit(cache=True, inline="always")
def _finite(y):
    """True when every element of ``y`` is finite (their sum is; a sum overflowing to
    inf counts as not finite). A state that is not finite stays so: every later step
    adds to it, so checking now and then finds it at the next check."""
    total = 0.0
    for q in range(y.shape[0]):
        total += y[q]
    return total - total == 0.0


@njit(cache=True, inline="always")
def pair_solution(y, K, o, h, B, lo, hi, out):
    """The embedded pair's kept solution over a step of size ``h`` (s) from ``y``: its
    three stages (rates, units of the state per s) at ``K[o[i] + q]`` (``o`` the three
    offsets into the flat array ``K``) with the weights ``B`` (an array of three),
    ``y + h (B_0 k_1 + B_1 k_2 + B_2 k_3)``, into ``out[lo:hi]``; True when every element
    is finite (a flag, not a running sum: no chain of dependent additions).

    How it is written is measured (callgrind, the heavy-haul train over 20 s): the
    stages as four array slices cost 2.9 % more instructions (the slices spilled to the
    stack); the weights read once before the caller's loop over the steps, as numbers
    that then live through the whole right-hand side, cost 2.0 % (spilled, reloaded at
    every element). Read here, just before this loop, they stay in registers."""
    o0, o1, o2 = o
    b0, b1, b2 = B[0], B[1], B[2]
    finite = True
    for q in range(lo, hi):
        v = y[q] + h * (b0 * K[o0 + q] + b1 * K[o1 + q] + b2 * K[o2 + q])
        out[q] = v
        finite &= (v - v) == 0.0
    return finite


@njit(cache=True, inline="always")
def pair_error(q, K, o, h, e):
    """Error estimate of element ``q`` over a step of size ``h`` (s), units of the state:
    ``h sum_i e_i k_i`` over the three stages and the rates at the step's end, at
    ``K[o[i] + q]`` (four offsets; ``e`` the four error weights as numbers: the kept
    solution minus the embedded one)."""
    return h * (e[0] * K[o[0] + q] + e[1] * K[o[1] + q] + e[2] * K[o[2] + q]
                + e[3] * K[o[3] + q])


@njit(cache=True, inline="always")
def max_scaled_error(K, o, h, E, lo, hi, y, ynew, atol, rtol):
    """The largest scaled error (:func:`scaled_error`, 1 at the tolerance) of the
    elements ``lo`` to ``hi - 1`` over a step of size ``h`` (s) from ``y`` to ``ynew``:
    :func:`pair_error` with the stages at the four offsets ``o`` into ``K`` and the error
    weights ``E`` (an array of four, read here as :func:`pair_solution` reads its
    weights), on the scales ``atol``, ``rtol``. A NaN error is not larger than any: the
    caller checks the result."""
    e = (E[0], E[1], E[2], E[3])
    err = 0.0
    for q in range(lo, hi):
        s = scaled_error(pair_error(q, K, o, h, e), q, y, ynew, atol, rtol)
        if s > err:
            err = s
    return err


@njit(cache=True, inline="always")
def scaled_error(e, q, y, ynew, atol, rtol):
    """The error ``e`` (units of the state) of element ``q`` on its scale
    ``atol + rtol max(|y|, |ynew|)`` at the step's ends: 1 is at the tolerance."""
    return abs(e) / (atol[q] + rtol[q] * max(abs(y[q]), abs(ynew[q])))


@njit(cache=True, inline="always")
def step_accepted(sp, err, h, h_try, hit):
    """Count an accepted step of size ``h_try`` (s) with scaled error ``err`` (<= 1) in the
    stepper record ``sp`` (fields ``accepted``, ``last_error``, ``last_rejected``) and
    return the next step size, s. The PI controller's factor
    ``SAFETY err^(-PI_ALPHA / q) last^(PI_BETA / q)`` (``q = ERROR_ORDER``) is kept within
    ``[MIN_FACTOR, MAX_FACTOR]`` and does not grow the step right after a rejection. A
    step shortened to land on a target (``hit``) says little about the next one: then
    the step ``h`` (s) that was asked for is kept unless the factor shrinks it."""
    sp["accepted"] += 1
    if err == 0.0:
        fac = MAX_FACTOR
    else:
        fac = SAFETY * err ** (-PI_ALPHA / ERROR_ORDER) \
            * max(sp["last_error"], ERROR_FLOOR) ** (PI_BETA / ERROR_ORDER)
        fac = min(MAX_FACTOR, max(MIN_FACTOR, fac))
    if sp["last_rejected"]:
        fac = min(fac, 1.0)
    sp["last_error"] = err
    sp["last_rejected"] = False
    if not hit or fac < 1.0:
        return h_try * fac
    return max(h, h_try * fac)


@njit(cache=True, inline="always")
def step_rejected(sp, err, h_try):
    """Count a rejected step of size ``h_try`` (s) with scaled error ``err`` (> 1, inf for
    a state that is not finite) in the stepper record ``sp`` and return the step to try
    next, s: ``SAFETY err^(-1 / q)`` of it, at least ``MIN_FACTOR`` of it."""
    sp["rejected"] += 1
    sp["last_rejected"] = True
    if err == np.inf:
        return h_try * MIN_FACTOR
    return h_try * max(MIN_FACTOR, SAFETY * err ** (-1.0 / ERROR_ORDER))
