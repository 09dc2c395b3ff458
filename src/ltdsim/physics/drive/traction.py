"""Traction and dynamic-brake limits of a locomotive (paper §4, Eq. 15-16)."""

from __future__ import annotations

from numba import njit

from ltdsim.physics._lazy import vectorize_when_used

#: Curtius-Kniffler adhesion coefficient ``mu = C0 + C1 / (v_kmh + C2)``.
CURTIUS_KNIFFLER = (0.161, 7.5, 44.0)
_C0, _C1, _C2 = CURTIUS_KNIFFLER


@njit(cache=True, inline="always")
def braking_share(v, fade):
    """Share of a braking demand the motors give at the speed ``v`` (m/s, + forward), -,
    signed: ``clip(v / fade, -1, 1)``. A dynamic brake opposes the motion and gives
    nothing at rest (the motors' voltage, and their braking, vanish with their speed),
    so its force is the demand times this share: full above the fade speed ``fade`` (m/s,
    > 0), linear below it, zero at standstill and turned with the motion when the train
    runs backwards. It cannot push a standing train."""
    r = v / fade
    return 1.0 if r > 1.0 else (-1.0 if r < -1.0 else r)


@njit(cache=True, error_model="numpy")
def adhesion_max(v, adhesion_mass, g):
    """:func:`adhesion_limit` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    return adhesion_mass * g * (_C0 + _C1 / (3.6 * abs(v) + _C2))


@vectorize_when_used(["float64(float64, float64, float64)"], cache=True)
def adhesion_limit(v, adhesion_mass, g):
    """Largest tractive (or braking) force the wheel-rail contact transmits, N.

    Curtius-Kniffler (paper Eq. 15): ``F = m_adh g (0.161 + 7.5 / (v_kmh + 44))``
    with ``v_kmh = 3.6 |v|``.

    Parameters
    ----------
    v : float or array
        Locomotive speed, m/s.
    adhesion_mass : float
        Mass on the driven wheels, kg (the study uses the whole train's static mass).
    g : float
        Gravitational acceleration, m/s^2.
    """
    return adhesion_max(v, adhesion_mass, g)


@njit(cache=True, error_model="numpy")
def traction_max(v, max_force, max_power, adhesion_mass, g):
    """:func:`traction_limit` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    f = max_force
    s = abs(v)
    if s * f > max_power:
        f = max_power / max(s, 1e-12)  # (s > 0 here; the guard keeps speculation quiet)
    # adhesion m g (c0 + c1 / (3.6 s + c2)) below f? Decided without the division (the
    # denominator is positive), which is then paid only where adhesion limits
    mg = adhesion_mass * g
    if (f - mg * _C0) * (3.6 * s + _C2) > mg * _C1:
        f = adhesion_max(s, adhesion_mass, g)
    return f


@vectorize_when_used(["float64(float64, float64, float64, float64, float64)"], cache=True)
def traction_limit(v, max_force, max_power, adhesion_mass, g):
    """Traction curve: the largest force magnitude available at speed ``v``, N.

    ``min(F_max, P_max / |v|, F_adhesion(v))`` (paper §4). Dynamic braking mirrors it:
    the braking force is limited by the same value.

    Parameters
    ----------
    v : float or array
        Locomotive speed, m/s.
    max_force : float
        Force limit ``F_max``, N.
    max_power : float
        Power limit ``P_max = F_max v_Pmax``, W.
    adhesion_mass : float
        Mass on the driven wheels, kg.
    g : float
        Gravitational acceleration, m/s^2.
    """
    return traction_max(v, max_force, max_power, adhesion_mass, g)
