"""Quasi-static curving laws: derailment limits, cant deficiency and the lateral balance
of a vehicle body loaded by its couplers.

These laws are evaluated after a run on the recorded positions, speeds and coupler forces
(:mod:`ltdsim.results.safety`), not inside the compiled kernel: they are plain numpy functions
that broadcast over arrays. All quantities are SI (m, s, kg, N, rad).

Lateral sign convention inside this module: ``+`` to the left of the direction of travel;
curvature ``+`` for a curve turning left (its centre on the left).
"""

from __future__ import annotations

import numpy as np


def nadal_limit(flange_angle, friction):
    """Nadal's single-wheel flange-climb limit of the wheel's lateral to vertical force
    ratio L/V, -.

    ``(tan g - mu) / (1 + mu tan g)``: the ratio at which the flange contact force and
    the friction force on the flange, sliding down, balance the wheel load (Nadal, 1908).
    It gives 1.13 for a 75 deg flange and mu = 0.5 (the AAR's figure) and 1.2 for a
    70 deg flange and mu = 0.36 (the basis of EN 14363's limit).

    Parameters
    ----------
    flange_angle : float or array
        Maximum flange contact angle g, rad (0 < g < pi/2).
    friction : float or array
        Wheel-rail friction coefficient mu at the flange, - (>= 0).
    """
    t = np.tan(flange_angle)
    return (t - friction) / (1.0 + friction * t)


def prudhomme_limit(axle_load, alpha=1.0):
    """Prud'homme's limit of the wheelset's lateral force (the track-shifting limit), N.

    ``alpha (10 kN + P / 3)`` with ``P`` the static axle load in N (SNCF, Prud'homme
    1970; EN 14363 takes alpha = 0.85 for freight wagons). For a 22.5 t axle
    (P = 220.7 kN) and alpha = 1: 83.6 kN.

    Parameters
    ----------
    axle_load : float or array
        Static axle load (weight on the axle), N.
    alpha : float
        Factor for the track's and the vehicle's condition, - (1: the original limit).
    """
    return alpha * (10.0e3 + np.asarray(axle_load, dtype=float) / 3.0)


def lateral_acceleration(speed, curvature, cant, rail_spacing, g):
    """Unbalanced lateral acceleration in the plane of the track, m/s^2, + to the left.

    The centrifugal acceleration ``v^2 k`` (outwards) less the component of gravity down
    the cant (inwards): ``-(v^2 k cos(phi) - g sin(phi))`` with ``sin(phi) = cant /
    rail_spacing``. ``cant`` is the height of the outer rail over the inner, m (>= 0); it
    tilts the track towards the centre of the curve, on whichever side that is. Its
    magnitude over ``g / rail_spacing`` is the cant deficiency.

    Parameters
    ----------
    speed : float or array
        Vehicle speed, m/s.
    curvature : float or array
        Track curvature 1/R, 1/m, + turning left.
    cant : float or array
        Cant (superelevation) of the outer rail, m.
    rail_spacing : float
        Distance between the wheel-rail contact points of a wheelset, m (1.5 for
        standard gauge).
    g : float
        Gravitational acceleration, m/s^2.
    """
    k = np.asarray(curvature, dtype=float)
    sphi = np.asarray(cant, dtype=float) / rail_spacing
    cphi = np.sqrt(1.0 - sphi * sphi)
    side = np.sign(k)  # the centre of the curve: + left
    return -(np.asarray(speed, dtype=float) ** 2 * k * cphi - g * sphi * side)


def cant_deficiency(speed, curvature, cant, rail_spacing, g):
    """Cant deficiency, m: the cant that would balance the centrifugal force at this
    speed less the cant there is, ``rail_spacing v^2 |k| / g - cant`` (negative: excess
    cant).

    Parameters as :func:`lateral_acceleration`.
    """
    k = np.abs(np.asarray(curvature, dtype=float))
    return rail_spacing * np.asarray(speed, dtype=float) ** 2 * k / g - cant


def body_lateral_balance(front_lateral, rear_lateral, bogie_force_front, bogie_force_rear,
                         half_bogie_spacing, pivot_overhang):
    """Bogie lateral forces that hold a vehicle body in quasi-static lateral and yaw
    equilibrium, N (+ left).

    The body is a beam along its axis (the chord between its bogie centres). On it act:
    the lateral components of the coupler forces at the front and rear pivots, which lie
    ``half_bogie_spacing + pivot_overhang`` ahead of and behind the body's centre; lateral
    loads at the bogie centres (the share of the unbalanced centrifugal force and the
    gravity down the cant carried there); and the unknown forces the bogies put on the
    body. The lateral sum and the yaw moment about the centre are zero:

    ``Yf + Yr + Cf + Cr + Bf + Br = 0`` and
    ``e (Yf + Bf - Yr - Br) + (e + a) (Cf - Cr) = 0`` (e = half the bogie spacing,
    a = the overhang).

    Parameters
    ----------
    front_lateral, rear_lateral : float or array
        Lateral component of the coupler force on the body at its front and rear pivot, N.
    bogie_force_front, bogie_force_rear : float or array
        Lateral load applied at the front and rear bogie centre (mass share times the
        unbalanced acceleration), N.
    half_bogie_spacing : float or array
        Half the distance between the bogie centres, m.
    pivot_overhang : float or array
        Distance from a bogie centre to the coupler pivot beyond it, m.

    Returns
    -------
    (Yf, Yr) : tuple of arrays
        Lateral force of the front and of the rear bogie on the body, N (+ left); the
        bogie pushes the track with the opposite force.
    """
    e = np.asarray(half_bogie_spacing, dtype=float)
    lever = e + pivot_overhang
    s = front_lateral + rear_lateral + bogie_force_front + bogie_force_rear
    m = lever * (front_lateral - rear_lateral) + e * (bogie_force_front - bogie_force_rear)
    diff = -m / e  # Yf - Yr
    yf = 0.5 * (-s + diff)
    yr = 0.5 * (-s - diff)
    return yf, yr


def wheel_l_over_v(wheelset_force, wheel_load_left, wheel_load_right):
    """L/V of the flanging wheel, -: the wheelset's lateral force on the track taken
    whole by the wheel it pushes against (the left one for ``+``), over that wheel's
    vertical load.

    Parameters
    ----------
    wheelset_force : float or array
        Lateral force of the wheelset on the track, N (+ left).
    wheel_load_left, wheel_load_right : float or array
        Vertical load of the left and right wheel, N.
    """
    h = np.asarray(wheelset_force, dtype=float)
    q = np.where(h >= 0.0, wheel_load_left, wheel_load_right)
    # a wheel with no load left (lifted by the roll moment) has no finite L/V
    return np.divide(np.abs(h), q, out=np.full(np.broadcast(h, q).shape, np.inf),
                     where=q > 0.0)
