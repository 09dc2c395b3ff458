"""``exp(-z)`` for the friction and stiffness fades, without a library call.

The friction laws (``mu = h1 + h2 exp(-h3 v)``) and the simplified coupler's fading
stiffness (``k2 exp(-|v| / v_c)``) are evaluated for every coupler at every stage of
every step, inside the kernel's innermost loop. A call to the C library's ``exp``
there costs more than the exponential itself: the registers live across the call are
saved and restored around it, even where the call is rarely taken. So these
exponentials are made of multiply-adds only:

* ``0 <= z < 1/8``: the Taylor series of ``exp(-z)`` to ``z^10`` (remainder ``z^11 /
  11! < 3e-18``, far under the rounding of a double), by Estrin's scheme (powers and
  pairs side by side, five levels deep): within 2 units in the last place (ulp). Its
  last step adds the tail ``z^8 (1/8! - z/9! + z^2/10!)`` to the head (the terms to
  ``z^7``); below ``z = 1/32`` (:data:`HEAD_LIMIT`, :func:`exp_neg_small` only) that
  tail is under ``2^-40 / 8! < 2.3e-17``, less than half an ulp of the head (which
  lies between 0.96 and 1, where an ulp is ``2^-53 = 1.1e-16``), so adding it changes
  no bit and the head alone is returned: the same double, seven operations fewer;
* ``1/8 <= z < 1`` (:func:`exp_neg` only): the series at ``z / 8``, squared three
  times; each squaring doubles the relative rounding error: within 20 ulp (5e-15
  relative);
* beyond: the series at ``z / 8192``, squared thirteen times (``z`` first clamped to
  +-1000, where the result is 0 or infinite anyway): within 5e-12 relative, where the
  fade has long become small.

Which tiers pay depends on the caller: the wedge gear's friction speeds put 95 % of
its arguments below 1/8 in the study's run (97-100 % below 1/32 in the 1 ms samples
of its 270 s with either friction-wedge set), so it uses :func:`exp_neg_small` (a
middle tier there only costs a branch), and takes the head alone for all its
friction laws at once when every argument is below 1/32
(:func:`ltdsim.physics.gears.draftgear.wedge_curves`); the simplified coupler's
``|v| / v_c`` lies between 1/8 and 1 three times in four, so it uses
:func:`exp_neg`. The tests compare both with NumPy's ``exp``.
"""

from __future__ import annotations

from numba import njit

from ltdsim.physics._lazy import vectorize_when_used

#: below this argument the series is used, -
SERIES_LIMIT = 0.125
#: below this argument the series' tail changes no bit of its head (see the module), -
HEAD_LIMIT = 1.0 / 32.0

_C = (1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 720, 1.0 / 5040, 1.0 / 40320,
      1.0 / 362880, 1.0 / 3628800)


@njit(cache=True, inline="always")
def _head(z):
    """``(u, u2, u4, head)``: ``u = -z``, its square and fourth power, and the Taylor
    series of ``exp(-z)`` to ``z^7`` exactly as :func:`_series` evaluates it before it
    adds the tail (Estrin's scheme), -."""
    u = -z
    u2 = u * u
    u4 = u2 * u2
    q0 = (1.0 + u) + u2 * (_C[2] + _C[3] * u)
    q1 = (_C[4] + _C[5] * u) + u2 * (_C[6] + _C[7] * u)
    return u, u2, u4, q0 + u4 * q1


@njit(cache=True, inline="always")
def series_head(z):
    """``exp(-z)`` for ``0 <= z < 1/32`` (:data:`HEAD_LIMIT`), -: the head of the series,
    bit for bit what :func:`exp_neg_small` returns there (see the module)."""
    return _head(z)[3]


@njit(cache=True, inline="always")
def _series(z):
    """Taylor series of ``exp(-z)`` to ``z^10`` by Estrin's scheme (powers and pairs
    side by side, five levels deep), for ``0 <= z < 1/8``."""
    u, u2, u4, head = _head(z)
    q2 = (_C[8] + _C[9] * u) + u2 * _C[10]
    return head + (u4 * u4) * q2


@njit(cache=True, inline="always")
def _square_thrice(p):
    """``p`` squared three times, ``p^8``, one multiplication after the other."""
    p *= p
    p *= p
    return p * p


@njit(cache=True, inline="always")
def _wide(z):
    """``exp(-z)`` for any ``z`` from the series at ``z / 8192`` squared 13 times, -."""
    if z != z:  # NaN stays NaN
        return z
    p = _series(min(max(z, -1000.0), 1000.0) * (1.0 / 8192.0))
    # (unrolled: a loop here, even in a branch rarely taken, slows the caller's loop)
    p = _square_thrice(_square_thrice(_square_thrice(_square_thrice(p))))
    return p * p



@njit(cache=True, inline="always")
def exp_neg(z):
    """``exp(-z)``, -: within 2 ulp for ``0 <= z < 1/8``, 20 ulp below 1, 5e-12 relative
    beyond (see the module)."""
    if 0.0 <= z < SERIES_LIMIT:
        return _series(z)
    if 0.0 <= z < 1.0:
        p = _series(z * 0.125)
        p *= p
        p *= p
        return p * p
    return _wide(z)


@njit(cache=True, inline="always")
def exp_neg_small(z):
    """``exp(-z)``, -, for mostly small arguments: within 2 ulp for ``0 <= z < 1/8``
    (below 1/32 without the series' tail, which changes no bit there), 5e-12 relative
    beyond (see the module)."""
    if 0.0 <= z < HEAD_LIMIT:
        return _head(z)[3]
    if 0.0 <= z < SERIES_LIMIT:
        return _series(z)
    return _wide(z)


@vectorize_when_used(["float64(float64)"], cache=True)
def exp_neg_ufunc(z):
    """:func:`exp_neg` over arrays (for checks and plots), -."""
    return exp_neg(z)


@vectorize_when_used(["float64(float64)"], cache=True)
def exp_neg_small_ufunc(z):
    """:func:`exp_neg_small` over arrays (for checks), -."""
    return exp_neg_small(z)


@vectorize_when_used(["float64(float64)"], cache=True)
def exp_series_ufunc(z):
    """The whole series (tail included, for ``0 <= z < 1/8``) over arrays (for checks), -."""
    return _series(z)
