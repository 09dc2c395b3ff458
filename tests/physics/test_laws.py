"""Force laws against closed forms, published numbers and physical laws over ranges."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from ltdsim.physics import (
    adhesion_limit, coupler_linear, coupler_simplified, curve_resistance, davis_resistance,
    grade_resistance, traction_limit,
)

fin = dict(allow_nan=False, allow_infinity=False)
INF = np.inf  # no gear travel limit
speeds = st.floats(-80.0, 80.0, **fin)
pos = st.floats(0.0, 1e5, **fin)


def test_davis_matches_the_quadratic_with_the_study_coefficients():
    v = np.array([1.0, 10.0, 16.72, 30.0])
    expected = 8202.0 + 106.56 * v + 11.9322 * v**2
    assert_allclose(davis_resistance(v, 8202.0, 106.56, 11.9322, 0.01), expected, rtol=1e-14)


@settings(deadline=None)  # (the first call may compile the ufunc: see physics._lazy)
@given(v=speeds, a=pos, b=pos, c=st.floats(0.0, 1e3, **fin), v0=st.floats(0.0, 1.0, **fin))
def test_davis_opposes_motion_is_odd_and_zero_at_standstill(v, a, b, c, v0):
    f = davis_resistance(v, a, b, c, v0)
    assert f * v >= 0.0
    assert davis_resistance(-v, a, b, c, v0) == -f
    assert davis_resistance(0.0, a, b, c, v0) == 0.0


def test_grade_force_of_a_wagon_on_one_in_two_hundred():
    # paper Eq. 13 with kappa = 200: m g / kappa
    assert_allclose(grade_resistance(90000.0, 1.0 / 200.0, 9.81), 90000.0 * 9.81 / 200.0)
    assert grade_resistance(90000.0, -0.005, 9.81) < 0.0  # a descent pushes forward


def test_curve_resistance_is_h_over_r_newtons_per_kilonewton():
    # h = 540, R = 300 m -> 1.8 N per kN of weight; a 90 t wagon weighs 882.9 kN
    f = curve_resistance(10.0, 90000.0, 1.0 / 300.0, 540.0, 9.81)
    assert_allclose(f, 1.8 * 90000.0 * 9.81 / 1000.0, rtol=1e-14)
    assert curve_resistance(0.0, 90000.0, 1.0 / 300.0, 540.0, 9.81) == 0.0
    assert curve_resistance(-3.0, 90000.0, 1.0 / 300.0, 540.0, 9.81) == -f


def test_adhesion_coefficient_at_standstill_is_the_uic_maximum():
    # Curtius-Kniffler at 0 km/h: 0.161 + 7.5/44 = 0.3315, the ~0.33 the paper cites
    mu0 = adhesion_limit(0.0, 1.0, 1.0)
    assert_allclose(mu0, 0.33, rtol=0.01)
    # at 100 km/h: 0.161 + 7.5 / 144
    assert_allclose(adhesion_limit(100 / 3.6, 1.0, 1.0), 0.161 + 7.5 / 144.0, rtol=1e-12)


@given(v=speeds, fmax=st.floats(1e3, 1e7, **fin), pmax=st.floats(1e4, 1e8, **fin),
       madh=st.floats(1e3, 1e7, **fin))
def test_traction_curve_is_the_least_of_its_three_limits(v, fmax, pmax, madh):
    lim = traction_limit(v, fmax, pmax, madh, 9.81)
    candidates = [fmax, adhesion_limit(v, madh, 9.81)]
    if v != 0.0:
        candidates.append(pmax / abs(v))
    assert_allclose(lim, min(candidates), rtol=1e-12)


def test_traction_curve_of_the_study_meets_power_limit_at_v_pmax():
    fmax, pmax = 8.63e5, 8.63e5 * 16.72
    v = np.array([5.0, 16.72, 25.0])
    lim = traction_limit(v, fmax, pmax, 8.7663e5, 9.81)
    assert_allclose(lim, [fmax, fmax, pmax / 25.0], rtol=1e-12)


slack = st.floats(0.0, 0.1, **fin)
stiff = st.floats(1e4, 1e8, **fin)


@given(d=st.floats(-0.2, 0.2, **fin), dd=st.floats(-2, 2, **fin), s=slack, k=stiff,
       c=st.floats(0, 1e5, **fin))
def test_simplified_coupler_without_k2_and_with_k1_equal_k3_is_the_linear_coupler(d, dd, s, k, c):
    a = coupler_simplified(d, dd, s, 0.0, c, k, 0.0, k, 0.5, False, INF, 0.0)
    b = coupler_linear(d, dd, s, k, c, INF, 0.0)
    assert_allclose(a, b, rtol=1e-12, atol=1e-9)


@given(d=st.floats(-0.2, 0.2, **fin), dd=st.floats(-2, 2, **fin), s=st.floats(1e-4, 0.1, **fin),
       k1=stiff, k2=stiff, k3=stiff, b=st.floats(0, 1e5, **fin), p=st.floats(0, 1e5, **fin),
       by_rate=st.booleans())
def test_couplers_with_slack_are_unilateral_and_silent_in_the_dead_band(d, dd, s, k1, k2, k3, b, p,
                                                                       by_rate):
    f = coupler_simplified(d, dd, s, p, b, k1, k2, k3, 0.6, by_rate, INF, 0.0)
    if abs(d) <= s / 2:
        assert f == 0.0
    elif d > 0:
        assert f >= 0.0  # a gear in draft only pulls
    else:
        assert f <= 0.0  # a gear in buff only pushes


@given(e=st.floats(1e-5, 0.1, **fin), v1=st.floats(0, 2, **fin), v2=st.floats(0, 2, **fin))
def test_nonlinear_stiffness_read_on_the_rate_fades_as_the_gear_slides_faster(e, v1, v2):
    # draft branch with zero damping: force at equal deflection falls with |rate|
    lo, hi = sorted([v1, v2])
    f_slow = coupler_simplified(e, lo, 0.0, 0.0, 0.0, 3e6, 2e6, 3e6, 0.6, True, INF, 0.0)
    f_fast = coupler_simplified(e, hi, 0.0, 0.0, 0.0, 3e6, 2e6, 3e6, 0.6, True, INF, 0.0)
    assert f_fast <= f_slow
    assert_allclose(coupler_simplified(e, 0.0, 0.0, 0.0, 0.0, 3e6, 2e6, 3e6, 0.6, True, INF,
                                       0.0), 5e6 * e)


@given(e=st.floats(1e-5, 0.3, **fin), v=st.floats(-2, 2, **fin), vc=st.floats(0.05, 2.0, **fin))
def test_nonlinear_stiffness_read_on_the_deflection_is_the_printed_eq9(e, v, vc):
    # Eq. 9 as printed, without damping: P + (k3 + k2 exp(-e / v)) e, whatever the rate
    k2, k3 = 1.856364e6, 3.4748e6
    f = coupler_simplified(e, v, 0.0, 0.0, 0.0, 8.265776e6, k2, k3, vc, False, INF, 0.0)
    # (the kernel's fast exponential: within 5e-12 of numpy's, ltdsim.physics.decay)
    assert_allclose(f, (k3 + k2 * np.exp(-e / vc)) * e, rtol=1e-11)


@settings(max_examples=300, deadline=None)  # (the first call compiles: physics._lazy)
@given(z=st.one_of(st.floats(0.0, 0.125), st.floats(0.125, 1.0), st.floats(0.0, 700.0),
                   st.floats(-5.0, 0.0)))
def test_fast_decay_is_the_exponential_to_the_last_bits(z):
    """exp(-z) as the friction and stiffness fades take it, against numpy's exponential:
    within 2 units in the last place from the series below 1/8, 20 from the series
    squared three times below 1, 5e-12 relative from 13 squarings beyond."""
    from ltdsim.physics.decay import exp_neg_small_ufunc, exp_neg_ufunc

    ref = np.exp(-z)
    if 0.0 <= z < 0.125:
        tol, tol_small = 2 * np.spacing(ref), 2 * np.spacing(ref)
    elif 0.0 <= z < 1.0:
        tol, tol_small = 20 * np.spacing(ref), 5e-12 * ref
    else:
        tol = tol_small = 5e-12 * ref
    assert abs(exp_neg_ufunc(z) - ref) <= tol
    assert abs(exp_neg_small_ufunc(z) - ref) <= tol_small


@settings(max_examples=300, deadline=None)  # (the first call compiles: physics._lazy)
@given(z=st.one_of(st.floats(0.0, 1.0 / 32.0, exclude_max=True),
                   st.floats(0.0, 2.0 ** -10), st.floats(0.0, 1e-8)))
def test_below_1_32_the_series_tail_changes_no_bit(z):
    """exp_neg_small returns the series' head alone below 1/32: the tail it leaves out
    (under 2.3e-17) is below half a unit in the last place of the head, so the whole
    series, evaluated with its tail added, is the same double."""
    from ltdsim.physics.decay import HEAD_LIMIT, exp_neg_small_ufunc, exp_series_ufunc

    assert HEAD_LIMIT == 1.0 / 32.0
    got = np.float64(exp_neg_small_ufunc(z))
    assert got.view(np.int64) == np.float64(exp_series_ufunc(z)).view(np.int64)
    assert abs(got - np.exp(-z)) <= 2 * np.spacing(np.exp(-z))


def test_fast_decay_passes_nan_and_infinity_through():
    from ltdsim.physics.decay import exp_neg_small_ufunc, exp_neg_ufunc

    for f in (exp_neg_ufunc, exp_neg_small_ufunc):
        with np.errstate(over="ignore"):  # exp(+inf) overflows, as it should
            got = f(np.array([np.nan, np.inf, -np.inf]))
        assert np.isnan(got[0]) and got[1] == 0.0 and got[2] == np.inf
