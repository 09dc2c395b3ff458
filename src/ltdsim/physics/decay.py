"""``exp(-z)`` for the friction and stiffness fades, fast where they mostly live.

The friction laws (``mu = h1 + h2 exp(-h3 v)``) and the simplified coupler's fading
stiffness (``k2 exp(-|v| / v_c)``) are evaluated for every coupler at every stage of
every step, and the sliding speeds in a train are small most of the time (in the
study's run 95 % of the couplers' deflection rates stay below 0.07 m/s), so most
arguments are small. For ``0 <= z < 1/8`` the Taylor series of ``exp(-z)`` to ``z^10``
leaves a remainder below ``z^11 / 11! < 3e-18``, far under the rounding of a double
(1.1e-16 relative near 1), and its eleven multiply-adds have no call and no range
reduction; larger arguments go to ``math.exp``.
"""

from __future__ import annotations

import math

from numba import njit, vectorize

#: below this argument the series is used, -
SERIES_LIMIT = 0.125

_C = (1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 720, 1.0 / 5040, 1.0 / 40320,
      1.0 / 362880, 1.0 / 3628800)


@njit(cache=True, inline="always")
def exp_neg(z):
    """``exp(-z)`` for ``z >= 0`` (any z is accepted: beyond the series' range, and
    for negative or non-finite z, ``math.exp(-z)``), -."""
    if 0.0 <= z < SERIES_LIMIT:
        # Estrin's scheme: the powers and the pairs in parallel, five levels deep
        u = -z
        u2 = u * u
        u4 = u2 * u2
        q0 = (1.0 + u) + u2 * (_C[2] + _C[3] * u)
        q1 = (_C[4] + _C[5] * u) + u2 * (_C[6] + _C[7] * u)
        q2 = (_C[8] + _C[9] * u) + u2 * _C[10]
        return (q0 + u4 * q1) + (u4 * u4) * q2
    return math.exp(-z)


@vectorize(["float64(float64)"], cache=True)
def exp_neg_ufunc(z):
    """:func:`exp_neg` over arrays (for checks and plots), -."""
    return exp_neg(z)
