"""Running resistances of a rail vehicle (paper Eq. 11-14).

Sign convention: a returned force is positive when it acts *against* the direction of
travel (the +x direction, front of the train). It is subtracted from the vehicle's
force balance ``m a = F_traction - F_resist - T_i + T_(i-1)``.
"""

from __future__ import annotations

from numba import njit

from ltdsim.physics._lazy import vectorize_when_used

#: inverse standstill speed (s/m) that gives the pure sign: every speed counted as
#: moving (>= 1e-12 m/s) reaches the full constant term; finite, so that a speed of 0
#: times it is 0, not NaN, even where the product is computed ahead of the test
PURE_SIGN = 1e12

_F8_3 = ["float64(float64, float64, float64)"]
_F8_5 = ["float64(float64, float64, float64, float64, float64)"]


@njit(cache=True, inline="always")
def davis_force(v, a, b, c, inv_v0):
    """:func:`davis_resistance` with the standstill speed given as its inverse
    ``inv_v0 = 1 / v0`` (s/m; ``PURE_SIGN`` for the pure sign), as the kernel stores it: a
    multiplication per vehicle instead of a division, N."""
    s = abs(v)
    if s < 1e-12:  # at rest (and no endless decay into subnormal speeds, which are slow)
        return 0.0
    f = a * min(s * inv_v0, 1.0) + b * s + c * s * s
    if v < 0.0:
        return -f
    return f


@vectorize_when_used(_F8_5, cache=True)
def davis_resistance(v, a, b, c, v0):
    """Propulsion (rolling plus aerodynamic) resistance by the Davis formula, N.

    ``F = a sat(v / v0) + b v + c v |v|`` (paper Eq. 12), so that it always opposes
    motion and is zero at standstill. ``sat`` clips to [-1, 1]: below the standstill
    speed ``v0`` the constant term fades linearly to zero, the usual regularisation of
    the sign function, so that a vehicle at rest does not chatter between +a and -a.
    ``v0 = 0`` gives the pure sign. Below 1e-12 m/s a vehicle counts as at rest.

    Parameters
    ----------
    v : float or array
        Vehicle speed, m/s (+ forwards).
    a : float
        Constant term, N.
    b : float
        Linear term, N s/m.
    c : float
        Quadratic (aerodynamic) term, N s^2/m^2.
    v0 : float
        Standstill speed below which the constant term is scaled down, m/s.
    """
    return davis_force(v, a, b, c, 1.0 / v0 if v0 > 1e-12 else PURE_SIGN)


@njit(cache=True, error_model="numpy")
def grade_force(mass, grade, g):
    """:func:`grade_resistance` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    return mass * g * grade


@vectorize_when_used(_F8_3, cache=True)
def grade_resistance(mass, grade, g):
    """Gravitational component along a grade, N (paper Eq. 13).

    ``F = m g grade`` with ``grade`` the rise over run (a grade "1 : kappa" is
    ``1 / kappa``; 0.005 is 0.5 %). Positive uphill, so it resists forward motion on a
    climb and pushes the vehicle forward on a descent. The paper's small-slope form is
    kept (``sin(atan(grade)) ~ grade`` to 1e-5 relative below 0.5 %).

    Parameters
    ----------
    mass : float or array
        Mass whose weight acts on the grade (the static mass), kg.
    grade : float or array
        Rise over run, dimensionless, + uphill in the direction of travel.
    g : float
        Gravitational acceleration, m/s^2.
    """
    return grade_force(mass, grade, g)


@njit(cache=True, error_model="numpy")
def curve_force(v, mass, curvature, h, g):
    """:func:`curve_resistance` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    f = mass * g * h * abs(curvature) / 1000.0
    if v > 0.0:
        return f
    if v < 0.0:
        return -f
    return 0.0


@vectorize_when_used(_F8_5, cache=True)
def curve_resistance(v, mass, curvature, h, g):
    """Curving resistance, N (paper Eq. 14).

    The specific resistance ``h / R`` is read as newtons per kilonewton of weight
    (docs/model.md#running-resistance), so
    ``F = m g h / (1000 R) = m g h curvature / 1000``, opposing motion and zero at
    standstill.

    Parameters
    ----------
    v : float or array
        Vehicle speed, m/s (only its sign is used).
    mass : float or array
        Static mass of the vehicle, kg.
    curvature : float or array
        Track curvature ``1 / R`` at the vehicle, 1/m (0 on straight track).
    h : float
        Dimensionless curve-resistance constant (500-1200; 540 in the study).
    g : float
        Gravitational acceleration, m/s^2.
    """
    return curve_force(v, mass, curvature, h, g)
