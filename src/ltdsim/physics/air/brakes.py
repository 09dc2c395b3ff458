"""Air-brake retarding force of one vehicle (tread brakes).

The retarding force is ``F = fill x cylinder_force x rigging_ratio x mu(v, K)``: the
brake cylinder's fill (0 released, 1 full application) times the piston force at full
application, times the rigging ratio (total shoe force over piston force), times the
shoe-wheel friction coefficient. It opposes the motion and fades linearly to zero
below a standstill speed, so that a stopped vehicle is held, not pushed backwards.
"""

from __future__ import annotations

from numba import njit

from ltdsim.physics._lazy import vectorize_when_used

#: shoe friction models (codes in the compiled arrays)
FRICTION_KARWATZKI, FRICTION_CONSTANT, FRICTION_TABLE = 0, 1, 2


@njit(cache=True, error_model="numpy")
def karwatzki_mu(v, shoe_force):
    """:func:`karwatzki` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    k = 1e-3 * shoe_force
    s = 3.6 * abs(v)
    return 0.6 * (16.0 * k + 100.0) / (80.0 * k + 100.0) * (s + 100.0) / (5.0 * s + 100.0)


@vectorize_when_used(["float64(float64, float64)"], cache=True)
def karwatzki(v, shoe_force):
    """Friction coefficient of a cast-iron brake shoe (Karwatzki's formula), -.

    ``mu = 0.6 (16 K + 100) / (80 K + 100) * (V + 100) / (5 V + 100)`` with ``K`` the
    force on one shoe in kN and ``V`` the speed in km/h.

    Parameters
    ----------
    v : float or array
        Vehicle speed, m/s (its magnitude is used).
    shoe_force : float or array
        Normal force on one shoe, N.
    """
    return karwatzki_mu(v, shoe_force)


@njit(cache=True, error_model="numpy")
def retarding_force(v, full_force, standstill_speed):
    """:func:`brake_retardation` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    if abs(v) < 1e-12:  # at rest (no endless decay into slow subnormal speeds)
        return 0.0
    r = v / standstill_speed
    if r > 1.0:
        r = 1.0
    elif r < -1.0:
        r = -1.0
    return -full_force * r


@vectorize_when_used(["float64(float64, float64, float64)"], cache=True)
def brake_retardation(v, full_force, standstill_speed):
    """Signed braking force on a vehicle, N: ``-full_force`` in the direction of motion,
    faded linearly to zero between ``+-standstill_speed`` (m/s); zero below 1e-12 m/s.

    Parameters
    ----------
    v : float or array
        Vehicle speed, m/s.
    full_force : float or array
        Retarding force magnitude while moving (fill x shoe force x mu), N.
    standstill_speed : float
        Fade speed, m/s (> 0).
    """
    return retarding_force(v, full_force, standstill_speed)
