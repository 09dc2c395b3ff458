"""Look-ups in the engine's tables, compiled: the segment of a sorted abscissa that holds
a value (from a search cursor, so a slowly moving argument costs O(1)), linear
interpolation and step functions, on separate arrays or on a flat store of
``m`` abscissae followed by ``m`` values.
"""

from __future__ import annotations

from numba import njit



@njit(cache=True, inline="always")
def _segment(xs, x, hint):
    """Index k of the segment ``xs[k] <= x < xs[k+1]`` (0 before the first point).

    Starts from the previous answer ``hint``, so a slowly moving argument costs O(1).
    The answer does not depend on the hint: it only speeds up the search.
    """
    k = hint
    m = xs.shape[0]
    while k + 1 < m and xs[k + 1] <= x:
        k += 1
    while k > 0 and xs[k] > x:
        k -= 1
    return k


@njit(cache=True, inline="always")
def _interp(xs, ys, x, hints, slot):
    """Linear interpolation of ``(xs, ys)`` at ``x``, constant beyond the ends."""
    k = _segment(xs, x, hints[slot])
    hints[slot] = k
    if x <= xs[0]:
        return ys[0]
    if k + 1 >= xs.shape[0]:
        return ys[k]
    w = (x - xs[k]) / (xs[k + 1] - xs[k])
    return ys[k] + w * (ys[k + 1] - ys[k])


@njit(cache=True, inline="always")
def _held(xs, ys, x, hints, slot):
    """Value of the step function ``(xs, ys)`` at ``x``: ``ys[k]`` from ``xs[k]`` on."""
    k = _segment(xs, x, hints[slot])
    hints[slot] = k
    return ys[k]


@njit(cache=True, inline="always")
def _held_at(tab, off, m, x):
    """Step function stored as ``m`` abscissae then ``m`` values from ``tab[off]``."""
    k = 0
    while k + 1 < m and tab[off + k + 1] <= x:
        k += 1
    return tab[off + m + k]


@njit(cache=True, inline="always")
def _interp_at(tab, off, m, x):
    """Linear interpolation of ``m`` points stored as abscissae then values from
    ``tab[off]``, constant beyond the ends."""
    if x <= tab[off]:
        return tab[off + m]
    k = 0
    while k + 1 < m and tab[off + k + 1] <= x:
        k += 1
    if k + 1 >= m:
        return tab[off + m + k]
    x0 = tab[off + k]
    w = (x - x0) / (tab[off + k + 1] - x0)
    return tab[off + m + k] + w * (tab[off + m + k + 1] - tab[off + m + k])
