"""The adaptive kernel's treatment of hysteretic draft gears: the error of the force a gear
exerts (rather than of its internal force, which may run ahead of the force by the
gear's relaxation lag), the exact relaxation of a gear's states over a step spent
wholly in its slack, where they relax to constants and act on nothing, and the location
of the first point along a step where a coupling meets or leaves its slack edge (any
coupler model with slack; used with ``rk.EDGE_LOCATION``), and the couplings held at
their slack edges (``solver.hold_speed``, at the end of this module).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.engine.couplers import P_D0, P_F0, P_RATE, P_SLACK, WG_BACK, WG_GAP
from ltdsim.engine.layout import N_ENERGY
from ltdsim.physics.gears.draftgear import plate_rate, relax


@njit(cache=True, inline="always")
def _exerted_error(f1, e, f, f0):
    """Error estimate (N) of the force a hysteretic gear exerts, from the estimate ``e``
    (N, the kept solution minus the embedded one) of its internal force ``f1`` (N) at the
    step's end, where the gear exerts ``f`` (N, a magnitude); ``f0`` (N) its released
    force.

    The gear exerts ``f1`` clipped to its band between the unloading and the loading
    curve. Above the loading curve (``f1 > f``) the internal force runs ahead of the
    force by the gear's relaxation lag, and its error changes the force only as far as
    the embedded solution ``f1 - e`` falls below the curve; below the unloading curve
    likewise; locked in the band (``f1 == f``) the error is ``e`` itself. In the slack
    (``f == 0``) the internal force relaxes to ``f0`` and sets the force the gear meets
    the next load with, ``f1`` clipped to the band at closure, whose top is ``f0``
    (the released gear's loading curve): what counts is the error of ``min(f1, f0)``."""
    f_lo = f1 - e
    if f > 0.0:
        if f1 > f:
            return max(f - f_lo, 0.0)
        if f1 < f:
            return max(f_lo - f, 0.0)
        return abs(e)
    return abs(min(f1, f0) - min(f_lo, f0))


@njit(cache=True, inline="always")
def _in_slack(d, slack):
    """Is a coupling of free play ``slack`` (m) at deflection ``d`` (m) in its slack
    (as :func:`ltdsim.physics.gears.couplers.gear_deflection` decides)?"""
    return slack > 0.0 and abs(d) <= 0.5 * slack


@njit(cache=True, inline="always")
def _slack_throughout(j, y, ynew, K, ny, w10, w20, w21, cpl):
    """Was coupler ``j`` in its slack at the start of a step of the three-stage pair
    from ``y``, at its stages 2 and 3 (positions ``y + h sum A K``; ``w10 = h A[1, 0]``,
    ``w20 = h A[2, 0]``, ``w21 = h A[2, 1]``, s) and at its end ``ynew``? (Positions
    are the first states of ``y``, m; each stage position is summed as
    :func:`_stages` sums it.)"""
    slack = cpl[j, P_SLACK]
    d0 = cpl[j, P_D0]
    if not (_in_slack(y[j] - y[j + 1] + d0, slack)
            and _in_slack(ynew[j] - ynew[j + 1] + d0, slack)):
        return False
    a = y[j] + w10 * K[j]
    b = y[j + 1] + w10 * K[j + 1]
    if not _in_slack(a - b + d0, slack):
        return False
    a = y[j] + w20 * K[j] + w21 * K[ny + j]
    b = y[j + 1] + w20 * K[j + 1] + w21 * K[ny + j + 1]
    return _in_slack(a - b + d0, slack)


@njit(cache=True, inline="always")
def _relax_in_slack(j, q, qp, y, ynew, dyend, decay, cpl):
    """Relax the states of hysteretic gear ``j`` exactly over a step spent in its
    slack, from ``y`` into ``ynew``, and their rates at the step's end into ``dyend``
    (the first-same-as-last stage): its internal force (state ``q``, N) to the released
    force, its plates (state ``qp``, m; -1 none) home, each at the gear's relaxation
    rate (1/s), as :func:`ltdsim.engine.couplers.coupler_force` gives them in the slack
    (the plates stop within 1e-12 m of home, as there). ``decay`` is ``exp(-rate h)``
    for the step's size ``h`` (s)."""
    rate = cpl[j, P_RATE]
    f0 = cpl[j, P_F0]
    ynew[q] = f0 + (y[q] - f0) * decay
    dyend[q] = relax(ynew[q], f0, rate)
    if qp >= 0:
        p = y[qp]
        if p > 1e-12:
            p = max(p * decay, 1e-12)
        ynew[qp] = p
        dyend[qp] = plate_rate(-cpl[j, WG_GAP], p, 0.0, cpl[j, WG_BACK], rate) \
            if p > 1e-12 else 0.0


@njit(cache=True, inline="always")
def _regime(d, half):
    """The regime of a coupling at deflection ``d`` (m) with half its free play ``half``
    (m): 0 in the slack (as :func:`_in_slack`), 1 in draft, -1 in buff."""
    if d > half:
        return 1
    if d < -half:
        return -1
    return 0


@njit(cache=True, inline="always")
def _hermite(a, b, c, e, s):
    """The cubic ``a + s (b + s (c + s e))`` at ``s`` (the step's fraction, -)."""
    return a + s * (b + s * (c + s * e))


@njit(cache=True)
def _edge_crossing(j, y, ynew, n, h, v_min, cpl):
    """The first point of a step of size ``h`` (s) from ``y`` to ``ynew`` at which
    coupler ``j`` changes regime (:func:`_regime`: it meets or leaves a slack edge), as
    a fraction of the step (-), or 2.0 when it stays in its regime throughout.

    The deflection (m) along the step is the cubic Hermite interpolant of its values and
    rates at the step's ends (positions are ``y[0:n]``, speeds ``y[n:2n]``), third
    order like the pair's kept solution, so that a touch that begins and ends between
    the pair's stages is seen too. The cubic is monotone between its turning points:
    the first piece that ends in another regime holds the crossing, located there by
    bisection to 1e-7 of the step (the fraction returned is the upper end of the
    bracket: the cubic is in the new regime there). A crossing at a closing or opening
    speed below ``v_min`` (m/s) does not count: a coupling that creeps to its edge
    (one held at it by a force between none and the gear's preload, which touches and
    leaves it again and again) meets it with an impulse below the speeds' tolerance."""
    slack = cpl[j, P_SLACK]
    if not slack > 0.0:
        return 2.0
    half = 0.5 * slack
    d0 = cpl[j, P_D0]
    da = y[j] - y[j + 1] + d0
    db = ynew[j] - ynew[j + 1] + d0
    va = h * (y[n + j] - y[n + j + 1])
    vb = h * (ynew[n + j] - ynew[n + j + 1])
    r0 = _regime(da, half)
    c2 = 3.0 * (db - da) - 2.0 * va - vb
    c3 = 2.0 * (da - db) + va + vb
    # turning points: va + 2 c2 s + 3 c3 s^2 = 0 in (0, 1)
    s1 = 2.0
    s2 = 2.0
    if c3 != 0.0:
        disc = c2 * c2 - 3.0 * c3 * va
        if disc > 0.0:
            q = np.sqrt(disc)
            u = (-c2 - q) / (3.0 * c3)
            v = (-c2 + q) / (3.0 * c3)
            s1 = min(u, v)
            s2 = max(u, v)
    elif c2 != 0.0:
        s1 = -va / (2.0 * c2)
    lo = 0.0
    for k in range(3):
        hi = s1 if k == 0 else (s2 if k == 1 else 1.0)
        if not (hi > lo and hi < 1.0) and k < 2:
            continue
        pb = _hermite(da, va, c2, c3, hi)
        if _regime(pb, half) != r0:
            pa = _hermite(da, va, c2, c3, lo)
            if r0 == 0:
                level = half if pb > pa else -half
            else:
                level = r0 * half
            # bisection on the monotone piece [lo, hi] for the cubic's crossing of level
            up = pb > pa
            a = lo
            b = hi
            for _ in range(24):
                m = 0.5 * (a + b)
                if (_hermite(da, va, c2, c3, m) > level) == up:
                    b = m
                else:
                    a = m
            if abs(va + b * (2.0 * c2 + 3.0 * c3 * b)) < v_min * h:
                return 2.0
            return b
        lo = hi
    return 2.0


# ---------------------------------------------------------------- held slack edges
# A preloaded gear with a rigid end (no edge_stiffness) exerts nothing in its slack and
# its released force the instant the slack closes. A coupling pressed against its edge
# by less than that force has no motion of its own in the exact solution: it stays at
# the edge (the sliding mode of a discontinuous right-hand side, Filippov's), carrying
# the force that keeps its two sides together. A time-stepping solution instead
# touches and leaves the edge over and over, its force alternating between none and the
# preload. With solver.hold_speed run_adaptive holds such a coupling (w.held).

#: how far a coupling released from its edge into its gear is put past the edge, m:
#: far enough that the gear's law carries it (at the edge exactly it is in its slack),
#: too little to change any force (1e-9 m at a locked gear's 1e9 N/m is 1 N)
HOLD_NUDGE = 1e-9


@njit(cache=True)
def _hold_exit(y, n, ftol, w):
    """Release every held coupling whose force (``w.force``, N, at the state ``y``) has
    left its range by more than ``ftol`` (N): below none, into its slack; beyond
    ``w.hold_f``, into its gear (put :data:`HOLD_NUDGE` past the edge, every vehicle
    behind it moved with it). (Within ``ftol`` it stays held: a force that only flickers
    about the end of its range, as where a vehicle's resistance changes sign with its
    speed at a standstill, would otherwise let it go and take it again at every step.)
    Returns how many were released."""
    held = w.held
    force = w.force
    out = 0
    for j in range(n - 1):
        s = held[j]
        if s == 0:
            continue
        f = s * force[j]
        if f < -ftol:
            held[j] = 0
            out += 1
        elif f > w.hold_f[j] + ftol:
            held[j] = 0
            out += 1
            for k in range(j + 1, n):
                y[k] -= s * HOLD_NUDGE
    return out


@njit(cache=True)
def _hold_enter(y0, y1, n, vc, cpl, inv_m, ez, w):
    """Hold every coupling that may be held (``w.hold_f > 0``) and, over the step from
    ``y0`` to ``y1``, met or left its slack edge (:func:`_regime` changed between the
    slack and one side) with its two vehicles closing or opening slower than ``vc``
    (m/s) at the step's end. The bodies on its two sides (a vehicle, or a run of
    vehicles already held) take their common speed, momentum kept: a plastic touch,
    whose kinetic energy (J) goes to the coupling's work when the energy is accounted
    (``y1[ez + N_ENERGY + j]``; ``ez`` -1: it is not). The coupling is put exactly at
    the edge, every vehicle behind it moved by what it lacked (less than ``vc`` times
    the step). Changes ``y1``; returns how many were held."""
    held = w.held
    got = 0
    for j in range(n - 1):
        if held[j] != 0 or not w.hold_f[j] > 0.0:
            continue
        half = 0.5 * cpl[j, P_SLACK]
        d0 = cpl[j, P_D0]
        r0 = _regime(y0[j] - y0[j + 1] + d0, half)
        d1 = y1[j] - y1[j + 1] + d0
        r1 = _regime(d1, half)
        if r0 == r1 or r0 * r1 != 0:  # (no edge met; or the whole slack crossed)
            continue
        if not abs(y1[n + j] - y1[n + j + 1]) < vc:
            continue
        s = r1 if r1 != 0 else r0
        a = j
        while a > 0 and held[a - 1] != 0:
            a -= 1
        b = j + 1
        while b < n - 1 and held[b] != 0:
            b += 1
        p = 0.0
        m = 0.0
        e = 0.0
        for i in range(a, b + 1):
            mi = 1.0 / inv_m[i]
            v = y1[n + i]
            p += mi * v
            m += mi
            e += 0.5 * mi * v * v
        v = p / m
        for i in range(a, b + 1):
            y1[n + i] = v
        if ez >= 0:
            y1[ez + N_ENERGY + j] += e - 0.5 * m * v * v
        delta = s * half - d1
        for k in range(j + 1, n):
            y1[k] -= delta
        held[j] = s
        got += 1
    return got


@njit(cache=True)
def _hold_crossing(n, ftol, w):
    """The first point of the step (its fraction, -) at which a held coupling's force
    left its range by more than ``ftol`` (N), by linear interpolation between its force
    at the step's start (``w.hold_fs``) and at its end (``w.force``); 2.0 if none did."""
    held = w.held
    theta = 2.0
    for j in range(n - 1):
        s = held[j]
        if s == 0:
            continue
        f1 = s * w.force[j]
        f0 = s * w.hold_fs[j]
        top = w.hold_f[j]
        if f1 < -ftol and f0 > 0.0:
            th = f0 / (f0 - f1)
        elif f1 > top + ftol and f0 < top:
            th = (top - f0) / (f1 - f0)
        else:
            continue
        if th < theta:
            theta = th
    return theta


@njit(cache=True)
def _hold_keep(n, w):
    """Keep the couplings' forces (``w.force``, N) as the next step's start forces."""
    for j in range(n - 1):
        w.hold_fs[j] = w.force[j]
