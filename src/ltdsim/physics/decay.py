"""``exp(-z)`` for the friction and stiffness fades, fast where they mostly live.

The friction laws (``mu = h1 + h2 exp(-h3 v)``) and the simplified coupler's fading
stiffness (``k2 exp(-|v| / v_c)``) are evaluated for every coupler at every stage of
every step, inside the kernel's innermost loop, and there a call to the C library's
``exp`` costs more than the exponential itself (the registers live across the call
are saved and restored around it). Most arguments are small, so:

* ``0 <= z < 1/8``: the Taylor series of ``exp(-z)`` to ``z^10`` (remainder ``z^11 /
  11! < 3e-18``, far under the rounding of a double), by Estrin's scheme (powers and
  pairs side by side, five levels deep): within 2 units in the last place (ulp);
* ``1/8 <= z < 1`` (:func:`exp_neg` only): the series at ``z / 8``, squared three
  times; each squaring doubles the relative rounding error: within 20 ulp (5e-15
  relative);
* beyond, and for negative or non-finite ``z``: ``math.exp``.

Which ranges pay depends on the caller: the wedge gear's friction speeds put 95 % of
its arguments below 1/8 in the study's run, so it uses :func:`exp_neg_small` (the
middle tier there only costs); the simplified coupler's ``|v| / v_c`` lies between
1/8 and 1 three times in four, so it uses :func:`exp_neg`.
"""

from __future__ import annotations

import math

from numba import njit, vectorize

#: below this argument the series is used, -
SERIES_LIMIT = 0.125

_C = (1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 720, 1.0 / 5040, 1.0 / 40320,
      1.0 / 362880, 1.0 / 3628800)


@njit(cache=True, inline="always")
def _series(z):
    """Taylor series of ``exp(-z)`` to ``z^10`` by Estrin's scheme (powers and pairs
    side by side, five levels deep), for ``0 <= z < 1/8``."""
    u = -z
    u2 = u * u
    u4 = u2 * u2
    q0 = (1.0 + u) + u2 * (_C[2] + _C[3] * u)
    q1 = (_C[4] + _C[5] * u) + u2 * (_C[6] + _C[7] * u)
    q2 = (_C[8] + _C[9] * u) + u2 * _C[10]
    return (q0 + u4 * q1) + (u4 * u4) * q2


@njit(cache=True, inline="always")
def exp_neg(z):
    """``exp(-z)``, -: within 2 ulp for ``0 <= z < 1/8``, 20 ulp below 1, ``math.exp``
    beyond (see the module)."""
    if 0.0 <= z < SERIES_LIMIT:
        return _series(z)
    if 0.0 <= z < 1.0:
        p = _series(z * 0.125)
        p *= p
        p *= p
        return p * p
    return math.exp(-z)


@njit(cache=True, inline="always")
def exp_neg_small(z):
    """``exp(-z)``, -, for mostly small arguments: within 2 ulp for ``0 <= z < 1/8``,
    ``math.exp`` beyond (see the module)."""
    if 0.0 <= z < SERIES_LIMIT:
        return _series(z)
    return math.exp(-z)


@vectorize(["float64(float64)"], cache=True)
def exp_neg_ufunc(z):
    """:func:`exp_neg` over arrays (for checks and plots), -."""
    return exp_neg(z)


@vectorize(["float64(float64)"], cache=True)
def exp_neg_small_ufunc(z):
    """:func:`exp_neg_small` over arrays (for checks), -."""
    return exp_neg_small(z)
