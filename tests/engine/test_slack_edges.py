"""The adaptive kernel's location of slack edges along a step
(:func:`ltdsim.engine.kernel.slack._edge_crossing`) against the roots of the same cubic
found by numpy's companion-matrix solver."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ltdsim.engine.couplers import N_COMMON, P_D0, P_SLACK
from ltdsim.engine.kernel.slack import _edge_crossing

SLACK = 0.02  # m


def _first_change(da, db, va, vb, half):
    """The first fraction of the step at which the Hermite cubic of the deflection
    changes regime (slack, draft, buff), from the real roots of ``p - half`` and
    ``p + half`` in (0, 1]; 2.0 when none does."""
    c2 = 3.0 * (db - da) - 2.0 * va - vb
    c3 = 2.0 * (da - db) + va + vb

    def regime(d):
        return 1 if d > half else (-1 if d < -half else 0)

    def p(s):
        return da + s * (va + s * (c2 + s * c3))

    r0 = regime(da)
    roots = []
    coef = [c3, c2, va]
    while coef and abs(coef[0]) < 1e-15:  # (a vanishing lead: a lower degree)
        coef.pop(0)
    for level in (half, -half):
        for r in np.roots(coef + [da - level]):
            if abs(r.imag) < 1e-9 and 0.0 < r.real <= 1.0:
                roots.append(r.real)
    if abs(da) == half:  # (starting on an edge: it may leave it at once)
        roots.append(0.0)
    # a root where the cubic only touches a level does not change the regime
    for r in sorted(roots):
        if regime(p(min(r + 1e-6, 1.0))) != r0 or regime(p(r)) != r0:
            return r
    return 2.0


@settings(max_examples=400, deadline=None)
@given(da=st.floats(-0.02, 0.02, allow_subnormal=False),
       db=st.floats(-0.02, 0.02, allow_subnormal=False),
       va=st.floats(-0.03, 0.03, allow_subnormal=False),
       vb=st.floats(-0.03, 0.03, allow_subnormal=False))
@example(da=0.01, db=0.01, va=0.015625, vb=0.0078125)  # (starts on the draft edge, leaves at once)
def test_the_first_edge_along_a_step_is_the_cubic_s_first_root(da, db, va, vb):
    n, h = 2, 0.01  # two vehicles, a 10 ms step; rates va, vb are per step (m)
    cpl = np.zeros((1, N_COMMON + 4))
    cpl[0, P_SLACK] = SLACK
    cpl[0, P_D0] = 0.0
    y = np.array([da, 0.0, va / h, 0.0])
    ynew = np.array([db, 0.0, vb / h, 0.0])
    got = _edge_crossing(0, y, ynew, n, h, 0.0, cpl)
    want = _first_change(da, db, va, vb, 0.5 * SLACK)
    if want == 2.0:
        # no crossing, but one where the cubic grazes an edge within rounding
        assert got == 2.0 or abs(abs(_cubic(da, db, va, vb, got)) - 0.5 * SLACK) < 1e-9
    else:
        # the bracket's upper end, within the bisection's 1e-7 of the step past the root
        assert want - 1e-9 <= got <= want + 2e-7, (got, want)


def _cubic(da, db, va, vb, s):
    c2 = 3.0 * (db - da) - 2.0 * va - vb
    c3 = 2.0 * (da - db) + va + vb
    return da + s * (va + s * (c2 + s * c3))


def test_a_crossing_slower_than_the_speed_floor_is_not_located():
    # a coupling 0.1 mm inside its slack closing at 2 mm/s over a 0.1 s step, no
    # acceleration: it meets its draft edge after 0.05 s, half the step, at 2 mm/s
    n, h, v = 2, 0.1, 2e-3
    cpl = np.zeros((1, N_COMMON + 4))
    cpl[0, P_SLACK] = SLACK
    d0 = 0.5 * SLACK - 1e-4
    y = np.array([d0, 0.0, v, 0.0])
    ynew = np.array([d0 + v * h, 0.0, v, 0.0])
    assert abs(_edge_crossing(0, y, ynew, n, h, 1e-3, cpl) - 0.5) < 1e-6
    assert _edge_crossing(0, y, ynew, n, h, 3e-3, cpl) == 2.0
