"""Friction wedge and table draft gears: energy, stages, Eq. 1 by hand, impacts, reduction."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import ltdsim
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from ltdsim.analysis.gears import drive_deflection, impact, loop_energy, table_from_ratings
from ltdsim.engine.couplers import released_force
from ltdsim.physics.gears.draftgear import wedge_gear_quasistatic
from ltdsim.analysis.reduction import Search, reduce_gear
from ltdsim.scenario import CouplerParams

from conftest import PAPER

HIGH = dict(preset="friction-wedge-high")


def cycle(amplitude=0.08, period=20.0, dt=1e-3):
    t = np.arange(0.0, period + dt / 2, dt)
    return t, amplitude * 0.5 * (1 - np.cos(2 * np.pi * t / period))


def shoelace(x, f):
    """Signed area enclosed by the closed curve (x, f): the loop area, J."""
    return 0.5 * float(np.sum(x * np.roll(f, -1) - np.roll(x, -1) * f))


def by_hand(x, c: CouplerParams, plates: bool, loading: bool):
    """Paper Eq. 1 evaluated with trigonometric functions at zero speed (mu = h1 + h2)."""
    a, b, g = (math.radians(v) for v in (c.alpha_deg, c.beta_deg, c.gamma_deg))
    mu = c.h1 + c.h2
    mu1 = mu * c.S
    G = math.cos(a) * math.cos(g - b) / (math.cos(a + g) * math.cos(b))
    if loading:
        psi = ((1 + math.tan(b + math.atan(mu)) * math.tan(g + math.atan(mu1)))
               / (1 - math.tan(a + math.atan(mu)) * math.tan(g + math.atan(mu1))))
        if plates:
            psi = psi + 2 * (1 - mu1 * math.tan(g)) * mu * (psi - 1) / (mu1 + math.tan(g))
    else:
        psi = ((1 + math.tan(b - math.atan(mu)) * math.tan(g - math.atan(mu1)))
               / (1 - math.tan(a - math.atan(mu)) * math.tan(g - math.atan(mu1))))
        if plates:
            tg = math.tan(g)
            psi = (tg - mu1) * psi / (tg * (1 - 2 * mu1 * mu + 2 * mu1 * mu * psi)
                                      + 2 * mu * psi - 2 * mu - mu1)
    f_sm = c.k_m * (c.x_m0 + G * x)
    f_sr = max(c.k_r * (c.x_r0 - (G - 1) * x), 0.0)
    return psi * f_sm - (psi - 1) * f_sr


def by_hand_moving(x, v, c: CouplerParams, plates: bool):
    """Paper Eq. 1 at gear speed ``v`` (m/s): each friction coefficient from Eq. 3 at its
    sliding speed (Eq. 4: v_i = c_i v; the plates at v on loading, G v on unloading),
    with trigonometric functions and NumPy's exp. Returns (loading, unloading) force, N."""
    a, b, g = (math.radians(w) for w in (c.alpha_deg, c.beta_deg, c.gamma_deg))
    G = math.cos(a) * math.cos(g - b) / (math.cos(a + g) * math.cos(b))
    c1 = math.cos(a) / math.cos(a + g)
    c2 = math.sin(g) / math.cos(a + g)
    c3 = math.cos(a) * math.sin(g) / (math.cos(a + g) * math.cos(b))

    def mu(speed):
        return c.h1 + c.h2 * float(np.exp(-c.h3 * abs(speed)))

    mu1, mu2, mu3 = mu(c1 * v) * c.S, mu(c2 * v), mu(c3 * v)
    tg = math.tan(g)
    out = []
    for sg, mu4 in ((1.0, mu(v)), (-1.0, mu(G * v))):
        psi = ((1 + math.tan(b + sg * math.atan(mu3)) * math.tan(g + sg * math.atan(mu1)))
               / (1 - math.tan(a + sg * math.atan(mu2)) * math.tan(g + sg * math.atan(mu1))))
        if plates and sg > 0:
            psi = psi + 2 * (1 - mu1 * tg) * mu4 * (psi - 1) / (mu1 + tg)
        elif plates:
            psi = (tg - mu1) * psi / (tg * (1 - 2 * mu1 * mu4 + 2 * mu1 * mu4 * psi)
                                      + 2 * mu4 * psi - 2 * mu4 - mu1)
        f_sm = c.k_m * (c.x_m0 + G * x)
        f_sr = max(c.k_r * (c.x_r0 - (G - 1) * x), 0.0)
        out.append(psi * f_sm - (psi - 1) * f_sr)
    return out


@settings(max_examples=200, deadline=None)
@given(preset=st.sampled_from(["friction-wedge-low", "friction-wedge-high"]),
       v=st.one_of(st.floats(0.0, 0.05), st.floats(0.0, 3.0), st.floats(-3.0, 0.0)),
       x=st.floats(0.0, 0.08), plates=st.booleans())
def test_the_curves_at_speed_are_equation_1_with_each_friction_at_its_sliding_speed(
        preset, v, x, plates):
    """The compiled curves of a moving gear (friction laws at the sliding speeds of
    Eq. 4, the exponentials by series: below about 0.05 m/s all of them from the
    series' head at once) equal Eq. 1 and 3 by hand, to 1e-9."""
    from ltdsim.physics.gears.draftgear import wedge_curves

    c = CouplerParams(preset=preset)
    a, b, g = (math.radians(w) for w in (c.alpha_deg, c.beta_deg, c.gamma_deg))
    G = math.cos(a) * math.cos(g - b) / (math.cos(a + g) * math.cos(b))
    c1 = math.cos(a) / math.cos(a + g)
    c2 = math.sin(g) / math.cos(a + g)
    c3 = math.cos(a) * math.sin(g) / (math.cos(a + g) * math.cos(b))
    engaged = 1.0 if plates else 0.0
    f_l, f_u, _, _ = wedge_curves(x, v, (math.tan(a), math.tan(b), math.tan(g), G, c1, c2, c3),
                                  (c.h1, c.h2, c.h3), c.S, (c.k_m, c.x_m0, c.k_r, c.x_r0),
                                  engaged, engaged)
    assert_allclose([f_l, f_u], by_hand_moving(x, v, c, plates), rtol=1e-9)


@pytest.mark.parametrize("params", [
    dict(preset="friction-wedge-high", slack=0.0),
    dict(preset="friction-wedge-low", slack=0.0, k_locked=4e7),
    dict(model="table", k_locked=5e7, loading=[[0, 5e4], [0.05, 1.2e6], [0.08, 2.4e6]],
         unloading=[[0, 2e4], [0.05, 0.6e6], [0.08, 1.6e6]]),
])
def test_energy_absorbed_per_cycle_is_the_positive_loop_area(params):
    c = CouplerParams(**params)
    t, d = cycle()
    ds = drive_deflection(c, t, d)
    work = loop_energy(ds)  # integral of F dx/dt over time
    area = shoelace(ds.deflection.values, ds.force.values)  # enclosed area of the loop
    assert work > 0.0
    assert_allclose(work, abs(area), rtol=0.01)


def test_a_frictionless_wedge_gear_returns_the_energy_it_stores():
    c = CouplerParams(preset="friction-wedge-high", slack=0.0, h1=0.0, h2=0.0)
    t, d = cycle()
    ds = drive_deflection(c, t, d)
    half = ds.time.values <= 10.0
    stored = np.trapezoid(ds.force.values[half], ds.deflection.values[half])
    assert abs(loop_energy(ds)) < 0.01 * stored
    # and at zero friction psi is the lever ratio G: Eq. 1 equals virtual work
    x = 0.05
    assert_allclose(by_hand(x, c, plates=True, loading=True),
                    by_hand(x, c, plates=False, loading=False), rtol=1e-12)


def stage(x, f, c, tol=0.01):
    """Which of the four stage curves (by hand) the force lies on, or 0 (locked)."""
    curves = {1: by_hand(x, c, False, True), 2: by_hand(x, c, True, True),
              3: by_hand(x, c, False, False), 4: by_hand(x, c, True, False)}
    on = [k for k, v in curves.items() if abs(f - v) <= tol * v]
    return on[0] if len(on) == 1 else 0


def test_slow_compression_and_release_visit_the_four_stages_in_order():
    # a gear that slides soon after a reversal (stiff lock), cycled very slowly
    c = CouplerParams(preset="friction-wedge-high", slack=0.0, k_locked=2e9, plate_backlash=0.01)
    t, d = cycle(amplitude=0.08, period=200.0, dt=5e-3)
    ds = drive_deflection(c, t, d, dt=1e-3)
    x, f = ds.deflection.values, ds.force.values
    # the stage of every sample, then the runs that last (a force crossing the band
    # after a reversal passes other curves' values for an instant)
    stages = [stage(xi, fi, c) for xi, fi in zip(x, f)]
    seq = []
    start = 0
    for k in range(1, len(stages) + 1):
        if k == len(stages) or stages[k] != stages[start]:
            lasting = abs(x[k - 1] - x[start]) >= 1e-3  # held over 1 mm of travel
            if stages[start] and lasting and (not seq or seq[-1] != stages[start]):
                seq.append(stages[start])
            start = k
    assert seq[:4] == [1, 2, 3, 4], seq  # loading 1, loading 2, unloading 1, unloading 2
    # inside the envelope of the four curves, and continuous
    lo = np.minimum.reduce([[by_hand(xi, c, p, False) for xi in x] for p in (False, True)])
    hi = np.maximum.reduce([[by_hand(xi, c, p, True) for xi in x] for p in (False, True)])
    closed = x > 1e-4  # (at zero deflection the preload flips with the direction)
    assert np.all(f[closed] >= lo[closed] * (1 - 1e-6))
    assert np.all(f[closed] <= hi[closed] * (1 + 1e-6))
    inner = x[1:] > 1e-4  # (the preload step at first contact is the gear's, not a stage's)
    step = np.abs(np.diff(f))[inner]
    dx = np.abs(np.diff(x))[inner]
    # no jump beyond what the locked stiffness gives over one sample, to within 0.5 % of
    # the peak force (the internal force trails the curve it follows by k v / K); a stage
    # switch without continuity would jump by the 150-250 kN between the stage curves
    assert np.all(step <= (c.k_locked + 1e8) * dx + 0.005 * f.max())


def test_quasi_static_force_equals_equation_1_by_hand():
    c = CouplerParams(preset="friction-wedge-high", slack=0.0)
    t = np.linspace(0.0, 100.0, 100001)
    d = 0.025 * t / 100.0  # 0.25 mm/s, below the plate gap: loading stage 1
    ds = drive_deflection(c, t, d, dt=1e-3)
    for x in (0.005, 0.015, 0.024):
        f = np.interp(x, ds.deflection.values, ds.force.values)
        assert_allclose(f, by_hand(x, c, plates=False, loading=True), rtol=0.01)
    # and the library's quasi-static curve is the same equation
    a, b, g = np.radians([c.alpha_deg, c.beta_deg, c.gamma_deg])
    for plates in (0.0, 1.0):
        for loading in (0.0, 1.0):
            lib = wedge_gear_quasistatic(0.06, loading, (a, b, g), (c.h1, c.h2, c.h3), c.S,
                                         (c.k_m, c.x_m0, c.k_r, c.x_r0), c.plate_gap,
                                         c.plate_backlash, plates)
            assert_allclose(lib, by_hand(0.06, c, bool(plates), bool(loading)), rtol=1e-9)


@pytest.mark.parametrize("speed", [0.5, 1.5, 2.2])
def test_wagon_impact_conserves_momentum_and_accounts_for_every_joule(speed):
    r = impact(CouplerParams(**HIGH), speed)
    assert r["separated"]
    assert abs(r["momentum_after"] - r["momentum_before"]) <= 1e-9 * abs(r["momentum_before"])
    assert_allclose(r["kinetic_energy_lost_J"], r["energy_absorbed_J"], rtol=0.01)
    assert r["energy_absorbed_J"] > 0.0


def test_no_hidden_state_ode3_and_rk4_agree_on_the_peak_impact_force():
    peaks = [impact(CouplerParams(**HIGH), 1.8, method=m, dt=1e-4)["peak_force_N"]
             for m in ("ode3", "rk4")]
    assert_allclose(peaks[0], peaks[1], rtol=0.005)


def test_scalar_s_and_a_constant_s_table_give_the_same_gear():
    scalar = CouplerParams(**HIGH)
    table = CouplerParams(**HIGH, S_table={"velocity": [0.0, 5.0], "deflection": [0.0, 0.1],
                                           "values": [[scalar.S, scalar.S], [scalar.S, scalar.S]]})
    a, b = (impact(c, 1.2)["peak_force_N"] for c in (scalar, table.model_copy(update={"S": None})))
    assert a == b


@pytest.mark.parametrize("fade, v_c", [("deflection", 0.05), ("rate", 0.6)])
def test_reduction_recovers_a_simplified_coupler(fade, v_c):
    # a fade constant that the chain of sines resolves: 50 mm of deflection (k2 fades by
    # e^-1 within the rig's travel) or 0.6 m/s of rate
    true = CouplerParams(model="simplified", slack=0.025, damping=2512.0, k1=8.265776e6,
                         k2=1.856364e6, k3=3.4748e6, v_c=v_c, travel=0.08, fade=fade)
    segments = ((1e6, np.pi / 2, 4.0), (1e6, 2 * np.pi, 1.0), (1e7, 10 * np.pi, 0.2))
    r = reduce_gear(true, segments=segments, dt=1e-3, search=Search(popsize=10, maxiter=300),
                    fade=fade)
    for k, v in r.parameters.items():
        assert_allclose(v, getattr(true, k), rtol=0.02, err_msg=k)
    assert r.fit_percent > 99.9


def test_reduction_search_is_bounded_by_its_estimate_and_blind_to_its_processes():
    # tol = 0: the search cannot converge, so it runs every generation; the estimate's
    # count of rig runs, (maxiter + 1) popsize n plus the polish, must bound what scipy did
    seen = []
    segments = ((1e6, np.pi / 2, 2.0), (1e7, 10 * np.pi, 0.2))
    runs = [reduce_gear(CouplerParams(preset="friction-wedge-high"), segments=segments,
                        dt=1e-3, workers=w, search=Search(tol=0.0, maxiter=6, popsize=5),
                        before_search=seen.append) for w in (1, 2)]
    n = 5  # fitted parameters
    assert all(e.max_runs >= r.evaluations >= 7 * 5 * n for e, r in zip(seen, runs))
    assert runs[0].generations == runs[1].generations == 6
    assert seen[0].seconds_per_run > 0.0
    # every candidate of a generation is evaluated before the population changes, so the
    # processes used cannot change the result
    assert runs[0].parameters == runs[1].parameters


def test_a_train_of_friction_gears_pulls_away_under_newton():
    sc = ltdsim.load_scenario(PAPER, case="LHHL").with_overrides(
        {"couplers.default": {"preset": "friction-wedge-high"}, "solver.t_end": 20.0})
    ds = ltdsim.simulate(sc)
    m = np.array([v.mass for v in sc.vehicles])
    v = ds.velocity.values
    moving = np.all(v > 0.01, axis=1)  # beyond the Davis standstill fade
    assert moving.sum() > 1000
    # the gears are internal forces: sum of m a = traction - Davis (level, straight track)
    davis = (8202.0 + 106.56 * v + 11.9322 * v * v).sum(axis=1)
    ma = ds.acceleration.values @ m
    assert_allclose(ma[moving], (ds.traction_force.values - davis)[moving], atol=1e-6 * 8.63e5)
    assert np.all(np.isfinite(ds.coupler_force.values))
    assert ds.coupler_force.max() > 5e5  # the gears do carry the train


def close_and_release(c: CouplerParams, travel: float):
    """One slow closing to ``travel`` and release: (peak force N, energy taken in
    closing J, share of it absorbed over the cycle)."""
    t = np.linspace(0.0, 20.0, 20001)
    ds = drive_deflection(c, t, travel * 0.5 * (1 - np.cos(2 * np.pi * t / 20.0)), dt=1e-3)
    taken = loop_energy(ds.isel(time=slice(0, len(t) // 2 + 1)))
    return float(ds.force.max()), taken, loop_energy(ds) / taken


# the manufacturers' published ratings (TB/T 2915 gears): force at full travel N,
# capacity J, travel m, absorptivity
@pytest.mark.parametrize("preset, force, capacity, travel, absorptivity", [
    ("mt-2", 2.27e6, 50e3, 0.083, 0.80),
    ("mt-3", 2.0e6, 45e3, 0.083, 0.80),
])
def test_table_presets_reproduce_their_published_ratings(preset, force, capacity, travel,
                                                         absorptivity):
    c = CouplerParams(preset=preset, slack=0.0)
    assert c.travel == travel
    peak, taken, share = close_and_release(c, travel)
    assert_allclose(peak, force, rtol=0.01)
    assert_allclose(taken, capacity, rtol=0.01)
    assert_allclose(share, absorptivity, atol=0.01)


@settings(max_examples=15, deadline=None)
@given(travel=st.floats(0.05, 0.12), force=st.floats(5e5, 4e6), fill=st.floats(0.15, 0.6),
       absorptivity=st.floats(0.3, 0.9), preload=st.floats(0.0, 0.1),
       series=st.sampled_from([1, 2]))
def test_a_table_gear_built_from_ratings_meets_them_on_the_rig(travel, force, fill,
                                                               absorptivity, preload, series):
    """Over a range of ratings (capacity as a share of force x travel), the gear built
    from them closes at the rated force and takes and absorbs the rated energies; two in
    series travel twice as far and take twice the energy at the same force."""
    p = preload * fill * force  # below the mean force
    capacity = fill * force * travel
    gear = table_from_ratings(travel, force, capacity, absorptivity, preload=p, series=series)
    c = CouplerParams(**{k: v for k, v in gear.items() if k != "exponent"})
    peak, taken, share = close_and_release(c, series * travel)
    assert_allclose(peak, force, rtol=0.01)
    assert_allclose(taken, series * capacity, rtol=0.01)
    assert_allclose(share, absorptivity, atol=0.01)


@settings(max_examples=200, deadline=None)
@given(alpha=st.floats(20.0, 55.0), beta=st.floats(0.0, 10.0), gamma=st.floats(5.0, 25.0),
       h1=st.floats(0.0, 0.15), h2=st.floats(0.0, 0.05), s=st.floats(0.1, 2.0),
       x=st.floats(0.0, 0.08), plates=st.sampled_from([0.0, 1.0]),
       loading=st.sampled_from([0.0, 1.0]))
def test_the_library_curves_are_equation_1_over_its_geometry_and_friction(
        alpha, beta, gamma, h1, h2, s, x, plates, loading):
    """The compiled curves (psi's multiplied out to one division) equal Eq. 1 written
    with tan and atan, at any unlocked geometry and friction, to 1e-9."""
    mu = h1 + h2
    a, g = math.radians(alpha), math.radians(gamma)
    m = max(mu, mu * s)
    assume(math.tan(a + math.atan(m)) * math.tan(g + math.atan(m)) < 0.95)  # not locked
    c = CouplerParams(preset="friction-wedge-high", slack=0.0, alpha_deg=alpha, beta_deg=beta,
                      gamma_deg=gamma, h1=h1, h2=h2, S=s, x_m0=0.01, x_r0=0.0)
    lib = wedge_gear_quasistatic(x, loading, (a, math.radians(beta), g), (c.h1, c.h2, c.h3),
                                 c.S, (c.k_m, c.x_m0, c.k_r, c.x_r0), c.plate_gap,
                                 c.plate_backlash, plates)
    assert_allclose(lib, by_hand(x, c, bool(plates), bool(loading)), rtol=1e-9)


@settings(max_examples=300, deadline=None)
@given(preset=st.sampled_from(["friction-wedge-low", "friction-wedge-high"]),
       x=st.floats(1e-4, 0.1), v=st.one_of(st.floats(-0.05, 0.05), st.floats(-3.0, 3.0)),
       share=st.floats(-0.5, 1.5), p=st.floats(0.0, 0.03), draft=st.booleans())
def test_the_kernel_gear_force_is_the_internal_force_clipped_to_both_curves(
        preset, x, v, share, p, draft):
    """The kernel's force of a wedge gear in contact is Eq. 7: ``F1`` clipped between
    both curves of :func:`wedge_curves` (solid closure on both, the unloading curve
    never above the loading curve, never negative), for internal forces below, inside
    and above the band, in draft and buff, with the plates anywhere (the plates on the
    unloading curve only while the spring seat carries them)."""
    from ltdsim.engine.couplers import (
        P_KSOLID, P_TRAVEL, WG_BACK, WG_C1, WG_C2, WG_C3, WG_G, WG_GAP, WG_H1, WG_H2, WG_H3, WG_KM,
        WG_KR, WG_S, WG_TA, WG_TB, WG_TG, WG_XM0, WG_XR0, coupler_force, lower_coupler,
    )
    from ltdsim.engine.features import ALL_KINDS
    from ltdsim.physics.gears.couplers import solid_closure
    from ltdsim.physics.gears.draftgear import plates_carried, plates_out, wedge_curves

    c = CouplerParams(preset=preset, slack=0.0)
    tables = []
    low = lower_coupler(c, tables)
    r = low.row
    delta = r[WG_BACK]
    engaged = plates_out(p, max(delta, 1e-3))
    carried = engaged if plates_carried(x - r[WG_GAP], p, delta) else 0.0
    f_l, f_u, _, _ = wedge_curves(x, v, (r[WG_TA], r[WG_TB], r[WG_TG], r[WG_G], r[WG_C1],
                                          r[WG_C2], r[WG_C3]), (r[WG_H1], r[WG_H2], r[WG_H3]),
                                  r[WG_S], (r[WG_KM], r[WG_XM0], r[WG_KR], r[WG_XR0]), engaged,
                                  carried)
    solid = solid_closure(x, r[P_TRAVEL], r[P_KSOLID])
    f_l += solid
    f_u = min(f_u + solid, f_l)
    f1 = f_u + share * (f_l - f_u)
    y = np.array([f1, p])
    dy = np.zeros(2)
    sgn = 1.0 if draft else -1.0
    force = coupler_force(0, low.code, sgn * x, sgn * v, y, 0, dy, 0, r[None, :],
                          np.asarray(tables + [0.0]), ALL_KINDS)
    assert_allclose(sgn * force, max(min(max(f1, f_u), f_l), 0.0), rtol=1e-13, atol=1e-9)


def _restitution(zeta: float) -> float:
    """Coefficient of restitution of a linear spring-dashpot contact whose faces part
    where its force comes to nothing (not where the spring is back at rest), damping
    ratio ``zeta`` < 1/sqrt(2): Schwager & Poeschel, "Coefficient of restitution and
    linear-dashpot model revisited", Granular Matter 9 (2007) 465-469, their Eq. 13."""
    if zeta == 0.0:
        return 1.0
    w = math.sqrt(1.0 - zeta**2)  # damped over natural frequency
    return math.exp(-zeta / w * (math.pi - math.atan(2.0 * zeta * w / (1.0 - 2.0 * zeta**2))))


@settings(max_examples=8, deadline=None)
@given(speed=st.floats(1e-3, 5e-3), zeta=st.floats(0.0, 0.6),
       stiffness=st.sampled_from([5e7, 1e8, 2e8]))
@example(speed=3e-3, zeta=0.0, stiffness=1e8)  # (the undamped peak's closed form, always)
def test_a_slow_touch_rings_on_the_structure_at_the_end_of_the_slack(speed, zeta, stiffness):
    # a touch too slow to reach the gear's released force stays on the structure in
    # series with it: two 90 t wagons (reduced mass 45 t) on a spring-dashpot, so the
    # peak force of an undamped touch is v sqrt(k mu) and the wagons part with the
    # restitution of the linear dashpot model
    mu = 45000.0
    c = 2.0 * zeta * math.sqrt(stiffness * mu)
    gear = CouplerParams(**HIGH, edge_stiffness=stiffness, edge_damping=c)
    r = impact(gear, speed, dt=2e-5, t_max=1.0)
    assert r["separated"]
    assert r["peak_force_N"] < 0.5 * released_force(gear)  # never reached the gear
    v = r["dataset"].velocity.values[-1]
    assert_allclose((v[0] - v[1]) / speed, _restitution(zeta), atol=0.01)
    if zeta == 0.0:
        assert_allclose(r["peak_force_N"], speed * math.sqrt(stiffness * mu), rtol=0.01)


def test_a_fast_run_in_meets_the_gear_through_a_stiff_structure_as_through_a_rigid_one():
    # a run-in at 1.5 m/s carries the gear to its full travel: the millimetre of the
    # structure below the gear's released force changes the peak force by little
    rigid = impact(CouplerParams(**HIGH), 1.5)["peak_force_N"]
    edge = impact(CouplerParams(**HIGH, edge_stiffness=1e8, edge_damping=2e6),
                  1.5)["peak_force_N"]
    assert_allclose(edge, rigid, rtol=0.02)
