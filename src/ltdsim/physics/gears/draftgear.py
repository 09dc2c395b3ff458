"""Friction draft gears: the four-stage wedge-spring gear (paper Eq. 1-7) and table gears.

Both are hysteretic: the force lies between an unloading curve ``f_u`` and a loading
curve ``f_l`` of the gear deflection ``x >= 0`` (and speed). Which curve acts depends on
history, and history must not hide inside a right-hand side that a Runge-Kutta method
evaluates several times per step. So the gear carries an
internal force ``F1`` in the ODE state, and the force used is ``F = clip(F1, f_u, f_l)``
(paper Eq. 7). Its rate is

    dF1/dt = (k_locked + s_band) v + K (F - F1)

where ``s_band`` is the slope of the band at the gear's place in it (the unloading
curve's slope at ``f_u``, the loading curve's at ``f_l``, interpolated between). On a
curve the anti-windup term (rate ``K``, 1/s) holds ``F1`` on it; after a reversal the
gear is "locked" (Eq. 5-6) and crosses the band at ``k_locked`` relative to it, joining
the other curve after a deflection ``(f_l - f_u) / k_locked``. Where a curve steps (a
stage change) the force stays continuous and rejoins the curve the same way.

This departs from the plain ``dF1/dt = k_locked v`` (docs/model.md#friction-draft-gear):
with the study's high set ``k_locked`` (8 MN/m) is below the loading curve's slope (about
30 MN/m), and the plain form would never reach the loading curve and would drag the force
along the unloading curve while loading (docs/draftgear.md). A gear in its slack extends fully and
its wedges come free, so it meets the next load on its loading curve.

The movable plates of the wedge gear engage after a gap ``x_gap``. Their displacement
``p`` is a second state: the follower pushes them on loading; on unloading they stay
put (friction) until the spring seat, returning by the backlash ``delta``, picks them
up and carries them home. This gives the paper's four stages in their order:
loading 1 (follower short of the plates), loading 2 (pushing the plates), unloading 1
(plates at rest), unloading 2 (plates carried back by the main spring).

The third state ``v0`` latches the closing speed at the moment of impact (while the
coupling is in its slack it follows the closing speed; in contact it holds), the
"initial impact velocity" of the lubrication factor ``S(v0, x)`` of Eq. 2.

All functions take magnitudes: ``x = |e| >= 0`` and ``v = d|e|/dt`` (> 0 loading); the
sign of draft or buff comes from :func:`ltdsim.physics.gears.couplers.gear_deflection`. What
every hysteretic gear shares lives here beside the curves: :func:`gear_force` (solid
closure, the band, :func:`hysteresis`) and :func:`relax` (the states' return to rest in
the slack); ``ltdsim.engine.couplers._gear`` only picks each model's curves.
"""

from __future__ import annotations

import math

import numpy as np

from numba import njit

from ltdsim.physics.gears.couplers import solid_closure
from ltdsim.physics.decay import HEAD_LIMIT, exp_neg_small, series_head



@njit(cache=True, inline="always")
def friction_coefficient(h1, h2, h3, v):
    """Velocity-dependent friction ``mu = h1 + h2 exp(-h3 |v|)`` (paper Eq. 3), -.

    ``h1`` kinetic part, ``h2`` static excess, ``h3`` decay, s/m; ``v`` sliding speed, m/s.
    """
    return h1 + h2 * exp_neg_small(h3 * abs(v))


@njit(cache=True, inline="always")
def wedge_geometry(alpha, beta, gamma):
    """``(tan a, tan b, tan g, G, c1, c2, c3)`` for wedge angles in rad.

    ``G = cos a cos(g - b) / (cos(a + g) cos b)`` is the main-spring lever ratio; c1..c3
    turn the gear speed into the sliding speeds v1..v3 of paper Eq. 4.
    """
    cag = math.cos(alpha + gamma)
    big_g = math.cos(alpha) * math.cos(gamma - beta) / (cag * math.cos(beta))
    c1 = math.cos(alpha) / cag
    c2 = math.sin(gamma) / cag
    c3 = math.cos(alpha) * math.sin(gamma) / (cag * math.cos(beta))
    return math.tan(alpha), math.tan(beta), math.tan(gamma), big_g, c1, c2, c3


@njit(cache=True, inline="always")
def spring_forces(x, big_g, k_m, x_m0, k_r, x_r0):
    """Main and release spring forces at gear deflection ``x``, N (paper Eq. 1).

    ``F_sm = k_m (x_m0 + G x)``; ``F_sr = k_r (x_r0 + x_rdg)`` with
    ``x_rdg = -x (G - 1)`` (the release spring extends as the gear closes). A release
    spring extended past its free length carries no force (``F_sr >= 0``).
    """
    fsr = k_r * (x_r0 - (big_g - 1.0) * x)
    return k_m * (x_m0 + big_g * x), fsr if fsr > 0.0 else 0.0


@njit(cache=True, inline="always")
def _psi_pair(ta, tb, tg, mu1, mu2, mu3, plates, mu4, loading):
    """Force ratio psi of one curve of paper Eq. 1 as ``(numerator, denominator)``.

    Without the plates (``plates = 0``): loading psi_1 =
    ``(1 + tan(b + atan mu3) tan(g + atan mu1)) / (1 - tan(a + atan mu2) tan(g + atan mu1))``;
    unloading psi_3 the same with every ``+ atan mu`` turned into ``- atan mu``. With the
    movable plates engaged by ``plates`` (0-1, their friction ``mu4`` scaled by it):
    psi_2 = ``psi_1 + 2 (1 - mu1 tg) mu4 (psi_1 - 1) / (mu1 + tg)`` and psi_4 =
    ``(tg - mu1) psi_3 / (tg (1 - 2 mu1 mu4 + 2 mu1 mu4 psi_3) + 2 mu4 psi_3 - 2 mu4 - mu1)``.
    Each ``tan(x + atan mu) = (tan x + mu) / (1 - mu tan x)`` and each inner quotient is
    multiplied out, so one division remains for the caller. ``ta, tb, tg`` are the
    tangents of the wedge angles; all quantities are dimensionless.
    """
    sg = 1.0 if loading else -1.0  # + atan mu on loading, - atan mu on unloading
    a = 1.0 - sg * mu1 * tg
    b = tg + sg * mu1
    c = 1.0 - sg * mu3 * tb
    e = tb + sg * mu3
    f = 1.0 - sg * mu2 * ta
    h = ta + sg * mu2
    num = (c * a + e * b) * f
    den = c * (f * a - h * b)
    if plates > 0.0:
        m4 = plates * mu4
        if loading:  # psi + 2 (1 - mu1 tg) mu4 (psi - 1) / (mu1 + tg)
            q = mu1 + tg
            num, den = num * q + 2.0 * (1.0 - mu1 * tg) * m4 * (num - den), den * q
        else:  # (tg - mu1) psi / (tg (1 - 2 mu1 mu4 + 2 mu1 mu4 psi) + 2 mu4 psi - 2 mu4 - mu1)
            num, den = ((tg - mu1) * num,
                        tg * ((1.0 - 2.0 * mu1 * m4) * den + 2.0 * mu1 * m4 * num)
                        + 2.0 * m4 * num - (2.0 * m4 + mu1) * den)
    return num, den


@njit(cache=True, inline="always")
def wedge_curves(x, v, geometry, friction, s_factor, springs, plates_loading,
                 plates_unloading):
    """Loading and unloading forces ``(f_l, f_u)`` of the wedge gear at ``x`` (m, a
    magnitude) (N) and their slopes ``(df_l/dx, df_u/dx)`` (N/m).

    ``v`` is the gear speed magnitude, m/s; ``geometry`` the tuple ``(tan alpha, tan
    beta, tan gamma, G, c1, c2, c3)`` of :func:`wedge_geometry` (-); ``friction`` the
    friction law's ``(h1, h2, h3)`` (-, -, s/m; Eq. 3); ``s_factor`` the lubrication
    factor S on mu1 (-); ``springs`` ``(k_m, x_m0, k_r, x_r0)`` (N/m, m, N/m, m;
    :func:`spring_forces`); ``plates_loading`` / ``plates_unloading`` (0-1) say how far
    the movable plates take part (stage 2 / stage 4) on each curve: their friction
    coefficient mu4 is scaled by it, so the curves change continuously as the plates
    engage and disengage.
    """
    ta, tb, tg, big_g, c1, c2, c3 = geometry
    h1, h2, h3 = friction
    k_m, x_m0, k_r, x_r0 = springs
    s = abs(v)
    # the exponents h3 |v_i| (s/m times m/s) of the friction laws at the sliding speeds
    # v1..v3 (paper Eq. 4) and at the plates' speeds s (loading) and G s (unloading)
    z1 = h3 * abs(c1 * s)
    z2 = h3 * abs(c2 * s)
    z3 = h3 * abs(c3 * s)
    z4 = h3 * abs(s)
    z5 = h3 * abs(big_g * s)
    if 0.0 <= max(max(max(z1, z2), max(z3, z4)), z5) < HEAD_LIMIT:
        # all small (the gear's usual state): each exponential is the series' head,
        # bit for bit what friction_coefficient gives, with one test for all of them
        # instead of one per law
        mu1 = (h1 + h2 * series_head(z1)) * s_factor
        mu2 = h1 + h2 * series_head(z2)
        mu3 = h1 + h2 * series_head(z3)
        mu4l = h1 + h2 * series_head(z4) if plates_loading > 0.0 else 0.0
        mu4u = h1 + h2 * series_head(z5) if plates_unloading > 0.0 else 0.0
    else:
        mu1 = friction_coefficient(h1, h2, h3, c1 * s) * s_factor
        mu2 = friction_coefficient(h1, h2, h3, c2 * s)
        mu3 = friction_coefficient(h1, h2, h3, c3 * s)
        mu4l = friction_coefficient(h1, h2, h3, s) if plates_loading > 0.0 else 0.0
        mu4u = friction_coefficient(h1, h2, h3, big_g * s) if plates_unloading > 0.0 else 0.0
    nl, dl = _psi_pair(ta, tb, tg, mu1, mu2, mu3, plates_loading, mu4l, True)
    nu, du = _psi_pair(ta, tb, tg, mu1, mu2, mu3, plates_unloading, mu4u, False)
    # both quotients with one division
    r = 1.0 / (dl * du)
    pl = nl * du * r
    pu = nu * dl * r
    fsm, fsr = spring_forces(x, big_g, k_m, x_m0, k_r, x_r0)
    dsm = k_m * big_g  # d F_sm / dx
    dsr = -k_r * (big_g - 1.0) if fsr > 0.0 else 0.0  # d F_sr / dx
    return (pl * fsm - (pl - 1.0) * fsr, pu * fsm - (pu - 1.0) * fsr,
            pl * dsm - (pl - 1.0) * dsr, pu * dsm - (pu - 1.0) * dsr)


@njit(cache=True, inline="always")
def hysteresis(f1, f_l, f_u, s_l, s_u, v, k_locked, rate):
    """Force in the hysteresis band and the rate of the internal force.

    Returns ``(F, dF1/dt)``: ``F = clip(F1, f_u, f_l)`` (N) and
    ``(k_locked + s_band) v + rate (F - F1)`` (N/s) with ``s_band`` the band's slope
    (N/m) at F's place between the curves. ``v = dx/dt`` (m/s), ``rate`` in 1/s.
    """
    if f1 >= f_l:  # on the loading curve (also where the curves meet)
        f = f_l
        s_band = s_l
    elif f1 <= f_u:  # on the unloading curve
        f = f_u
        s_band = s_u
    else:  # locked between them (no division on the curves, where gears mostly are)
        f = f1
        s_band = s_u + (f1 - f_u) / (f_l - f_u) * (s_l - s_u)
    return f, (k_locked + s_band) * v + rate * (f - f1)


@njit(cache=True, inline="always")
def relax(z, z_rest, rate):
    """Rate (units of ``z`` per s) that pulls a gear state ``z`` towards ``z_rest`` at
    ``rate`` (1/s): how every hysteretic gear's internal states return to rest while the
    coupling is in its slack (the internal force to the released force, the impact
    speed to the closing speed)."""
    return rate * (z_rest - z)


@njit(cache=True, inline="always")
def gear_force(f1, f_l, f_u, s_l, s_u, v, x, travel, solid_stiffness, k_locked, rate):
    """Force of a hysteretic gear from its curves, and the rate of its internal force.

    The part every hysteretic gear shares once it has its loading and unloading curves
    at deflection ``x`` (m, a magnitude): ``f_l``, ``f_u`` (N) and their slopes ``s_l``,
    ``s_u`` (N/m). Beyond ``travel`` (m) the gear is solid and both curves rise by
    :func:`~ltdsim.physics.gears.couplers.solid_closure` (``solid_stiffness``, N/m); an
    unloading curve never lies above the loading curve; the force is the internal force
    ``f1`` (N) clipped to the band (:func:`hysteresis`, ``v`` = dx/dt m/s, ``k_locked``
    N/m, ``rate`` 1/s) and never negative (a gear only pushes back). Returns
    ``(F N, dF1/dt N/s)``.
    """
    solid = solid_closure(x, travel, solid_stiffness)
    if solid > 0.0:  # closed solid
        f_l += solid
        f_u += solid
        s_l += solid_stiffness
        s_u += solid_stiffness
    if f_u > f_l:
        f_u = f_l
    f, df1 = hysteresis(f1, f_l, f_u, s_l, s_u, v, k_locked, rate)
    if f < 0.0:
        f = 0.0
    return f, df1


@njit(cache=True, inline="always")
def edge_structure(f, x, v, stiffness, damping):
    """Force across a coupling's structure at the end of its slack, N (a magnitude).

    Below its preload a friction gear does not move, so the force rises from nothing at
    the end of the slack to the gear's through what is in series with it: the coupler
    shank and knuckle, the yoke, the draft sill. That structure is a spring of
    ``stiffness`` (N/m) and a dashpot of ``damping`` (N s/m) on the deflection ``x`` (m
    beyond the slack, a magnitude) and its rate ``v`` (m/s, > 0 closing) for as long as
    its spring carries less than the gear's force ``f`` (N); from there on the gear
    deflects and carries ``f``. The dashpot only pushes (contact is one-sided: the
    faces part where the force comes to nothing, before ``x`` is back at 0) and never
    lifts the force above the gear's. ``stiffness = 0`` is a rigid structure: the force
    steps from 0 to the gear's at the edge and ``f`` is returned unchanged.
    """
    if stiffness <= 0.0:
        return f
    spring = stiffness * x
    if spring >= f:
        return f
    g = spring + damping * v
    if g <= 0.0:
        return 0.0
    return g if g < f else f


#: contact tolerance between follower, spring seat and plates, m. The plate state tracks
#: the follower exactly while pushed; without a tolerance the test "follower at the
#: plates" would flip from step to step on rounding.
PLATE_TOL = 1e-4


@njit(cache=True, inline="always")
def plates_pushed(u, p):
    """Is the follower (at ``u = x - x_gap``, m) pushing the plates (at ``p``, m)?"""
    return u >= p - PLATE_TOL


@njit(cache=True, inline="always")
def plates_out(p, ramp):
    """Engagement (0-1) of the plates on the loading curve: they count as soon as they
    are displaced from home (loading from there pushes them again within the backlash;
    dropping them at every reversal would drop the force without motion), fading in
    over the first ``ramp`` metres of their travel."""
    return min(p / ramp, 1.0) if p > 0.0 else 0.0


@njit(cache=True, inline="always")
def plates_carried(u, p, delta):
    """Is the returning spring seat carrying the plates home (backlash ``delta``, m)?"""
    # (``&``, not ``and``: both tests are made and combined without a jump; which way
    # such a jump goes depends on the data and the processor guesses it wrong often)
    return (p > PLATE_TOL) & (u <= p - delta + PLATE_TOL)


@njit(cache=True, inline="always")
def plate_rate(u, p, v, delta, rate):
    """d p/dt of the movable plates: pushed by the follower (``u = x - x_gap >= p``),
    carried home by the spring seat (``u <= p - delta``), else at rest; plus a pull of
    rate ``rate`` (1/s) onto that admissible band so the state cannot drift."""
    lo = u if u > 0.0 else 0.0
    up = u + delta
    hi = up if up > 0.0 else 0.0
    # Without jumps: the direction of motion flips at every reversal of the gear, and
    # a jump on it (or on the plates' contacts) is the wedge gear's most often
    # mispredicted one; both conditions are evaluated in full (``&``, ``|``) and the
    # rate is selected, every result bit as with the jumps.
    moves = ((v > 0.0) & plates_pushed(u, p)) | ((v < 0.0) & plates_carried(u, p, delta))
    dp = v if moves else 0.0
    gap = min(max(p, lo), hi) - p
    # (within 1e-12 m of its band the pull stops: an endless exponential decay to 0
    # would end in subnormal numbers, which cost a hundred times a normal operation;
    # dp + 0.0 is dp bit for bit, as dp is never -0.0)
    pull = rate * gap if abs(gap) > 1e-12 else 0.0
    return dp + pull


@njit(cache=True)
def s_table_lookup(tab, off, nv, nx, v0, x):
    """Bilinear lookup of the lubrication factor S(v0, x) stored flat in ``tab``:
    ``nv`` impact speeds (m/s), ``nx`` deflections (m), then ``nv x nx`` values (row per
    speed). Clamped at the table edges."""
    vs = tab[off:off + nv]
    xs = tab[off + nv:off + nv + nx]
    vals = tab[off + nv + nx:off + nv + nx + nv * nx]
    i, wi = _bracket(vs, v0)
    j, wj = _bracket(xs, x)
    i1 = min(i + 1, nv - 1)
    j1 = min(j + 1, nx - 1)
    a = vals[i * nx + j] * (1.0 - wj) + vals[i * nx + j1] * wj
    b = vals[i1 * nx + j] * (1.0 - wj) + vals[i1 * nx + j1] * wj
    return a * (1.0 - wi) + b * wi


@njit(cache=True, inline="always")
def _bracket(xs, x):
    """Index ``k`` and weight ``w`` with ``x ~ xs[k] (1-w) + xs[k+1] w``, clamped."""
    m = xs.shape[0]
    if m == 1 or x <= xs[0]:
        return 0, 0.0
    if x >= xs[m - 1]:
        return m - 1, 0.0
    k = 0
    while xs[k + 1] < x:
        k += 1
    return k, (x - xs[k]) / (xs[k + 1] - xs[k])


@njit(cache=True)
def table_curve(tab, off, n, x):
    """Force (N) and slope (N/m) of a force-deflection curve stored as ``n`` deflections
    (m) then ``n`` forces (N) at ``tab[off:]``; linear between points, constant beyond."""
    xs = tab[off:off + n]
    f = tab[off + n:off + 2 * n]
    k, w = _bracket(xs, x)
    if k + 1 >= n or x <= xs[0]:
        return f[min(k, n - 1)], 0.0
    slope = (f[k + 1] - f[k]) / (xs[k + 1] - xs[k])
    return f[k] * (1.0 - w) + f[k + 1] * w, slope


@njit(cache=True)
def _wedge_static(x, loading, geometry, friction, s_factor, springs, gap, backlash, plates):
    """:func:`wedge_gear_quasistatic` at one deflection ``x`` (m), N."""
    if plates < 0.0:
        engaged = 1.0 if (x > gap if loading > 0.5 else x > gap + backlash) else 0.0
    else:
        engaged = plates
    f_l, f_u, _, _ = wedge_curves(x, 0.0, geometry, friction, s_factor, springs, engaged,
                                  engaged)
    return f_l if loading > 0.5 else f_u


def wedge_gear_quasistatic(x, loading, angles, friction, s_factor, springs, gap=0.0,
                           backlash=0.0, plates=-1.0):
    """Quasi-static force of the wedge gear (paper Eq. 1 at zero speed), N.

    Parameters
    ----------
    x : float or array
        Gear deflection, m (>= 0).
    loading : float
        1 for the loading curve, 0 for the unloading curve.
    angles : (float, float, float)
        Wedge angles alpha, beta, gamma, rad.
    friction : (float, float, float)
        Friction law coefficients h1, h2, h3 (Eq. 3), -, -, s/m.
    s_factor : float
        Lubrication factor S on mu_1, -.
    springs : (float, float, float, float)
        Main and release spring stiffness (N/m) and pre-deflection (m): ``(k_m, x_m0,
        k_r, x_r0)``.
    gap, backlash : float
        Plate gap and backlash, m (used only to decide ``plates`` when it is < 0).
    plates : float
        Engagement of the movable plates, 1 (stage 2 or 4) to 0 (stage 1 or 3), or -1
        to decide from ``x > gap`` (loading) or ``x > gap + backlash`` (unloading).
    """
    geometry = wedge_geometry(*(float(a) for a in angles))
    fr = tuple(float(h) for h in friction)
    sp = tuple(float(k) for k in springs)
    xs = np.asarray(x, dtype=float)
    out = np.array([_wedge_static(float(xi), float(loading), geometry, fr, float(s_factor),
                                  sp, float(gap), float(backlash), float(plates))
                    for xi in xs.ravel()]).reshape(xs.shape)
    return float(out) if out.ndim == 0 else out


__all__ = [
    "friction_coefficient", "wedge_geometry", "spring_forces", "wedge_curves",
    "hysteresis", "edge_structure", "plate_rate", "plates_pushed", "plates_out",
    "plates_carried", "PLATE_TOL", "s_table_lookup", "table_curve",
    "wedge_gear_quasistatic",
]
