"""Strength events (ltdsim.results.strength) against a closed form and the shipped
heavy-haul emergency, and the strength table's numbers against their published figures.

The closed form: a force F(t) rising slowly on the lead of a train of N equal masses,
joined by linear couplers without slack and without resistances, accelerates the train
as one body, F / (N m); coupler k (behind vehicle k, counted from 1) pulls the N - k
vehicles behind it, so it carries F (N - k) / N. A limit L is first reached by coupler k
when F(t) = L N / (N - k).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import ltdsim
from ltdsim.data import load_preset, preset_names
from ltdsim.results.io import load_result, save_result
from ltdsim.results.strength import (
    ATTR,
    event_lines,
    stored_events,
    strength_events,
)
from ltdsim.scenario import CouplerParams, Scenario
from ltdsim.scenario.couplers import STRENGTH_KEYS, strength_limits

from conftest import ROOT

LBF = 4.4482216152605  # N per pound-force (exact: 0.45359237 kg x 9.80665 m/s^2)

N, MASS, F_MAX, RAMP = 5, 5.0e4, 5.0e5, 20.0   # vehicles, kg, N, s (force ramp 0 -> F_MAX)
PROOF, ULTIMATE = 2.5e5, 3.5e5                   # N, inline strength of every coupler


def _train(strength) -> Scenario:
    return Scenario.from_dict({
        "name": "strength-ramp",
        "solver": {"method": "rk4", "dt": 1e-3, "t_end": 24.0, "output_interval": 0.01},
        "vehicles": [{"name": "lead", "mass": MASS, "length": 15.0, "powered": True},
                     {"name": "wagon", "count": N - 1, "mass": MASS, "length": 15.0}],
        "couplers": {"default": {"model": "linear", "slack": 0.0, "stiffness": 5.0e7,
                                 "damping": 2.0e6, "strength": strength}},
        "traction": {"max_force": 2.0 * F_MAX, "max_power": 1.0e9, "adhesion_mass": 1.0e6},
        "driver": {"mode": "force",
                   "force_profile": [[0.0, 0.0], [RAMP, F_MAX], [24.0, F_MAX]]},
    })


@pytest.fixture(scope="module")
def ramp():
    sc = _train({"draft_proof": PROOF, "draft_ultimate": ULTIMATE})
    return sc, ltdsim.simulate(sc)


def _closed_form_time(k: int, limit: float) -> float:
    """When F(t) (N - k) / N first reaches ``limit`` on the ramp F = F_MAX t / RAMP."""
    return limit * N / (N - k) / F_MAX * RAMP


def test_quasi_static_coupler_forces_are_the_closed_form(ramp):
    _, ds = ramp
    f = ds.coupler_force.values
    t = ds.time.values
    hold = t > RAMP + 2.0  # the ramp's end transient has died out (damping ratio ~0.5)
    for k in range(1, N):
        np.testing.assert_allclose(f[hold, k - 1], F_MAX * (N - k) / N, rtol=2e-3)


def test_events_name_the_couplers_over_their_limits_and_when(ramp):
    """400, 300, 200, 100 kN against proof 250 and ultimate 350 kN: coupler 1 goes over
    both, coupler 2 over its proof only, couplers 3 and 4 over neither."""
    sc, ds = ramp
    ev = strength_events(ds, sc)
    got = {(r.coupler, r.kind, r.direction) for r in ev.itertuples()}
    assert got == {(1, "ultimate", "tension"), (1, "proof", "tension"),
                   (2, "proof", "tension")}
    # the most severe first: coupler 1's break before the yields
    assert (ev.coupler[0], ev.kind[0]) == (1, "ultimate")
    t = ds.time.values
    for r in ev.itertuples():
        f = ds.coupler_force.values[:, r.coupler - 1]
        # the recorded force's first crossing, found here independently
        i = int(np.argmax(f >= r.limit_N))
        assert f[i - 1] < r.limit_N <= f[i]
        assert t[i - 1] <= r.time_s <= t[i]
        crossing = t[i - 1] + (r.limit_N - f[i - 1]) / (f[i] - f[i - 1]) * (t[i] - t[i - 1])
        assert r.time_s == pytest.approx(crossing, abs=1e-9)
        # and it is the closed form's time (the train lags the ramp by far less than 0.1 s)
        assert r.time_s == pytest.approx(_closed_form_time(r.coupler, r.limit_N), abs=0.05)
        assert r.force_N == pytest.approx(F_MAX * (N - r.coupler) / N, rel=5e-3)
        assert not r.between_samples and r.grade == "inline"


def test_the_result_carries_its_events_through_a_saved_file(ramp, tmp_path):
    sc, ds = ramp
    path = save_result(ds, tmp_path / "ramp.nc")
    back = stored_events(load_result(path))
    fresh = strength_events(ds, sc)
    assert back is not None and ATTR in ds.attrs
    assert list(back.coupler) == list(fresh.coupler)
    np.testing.assert_allclose(back.time_s, fresh.time_s)
    lines = event_lines(back)
    assert lines[0].startswith("strength: 1 coupler over an ultimate load (would break), 2 "
                               "over a proof load")
    assert lines[1].startswith("  coupler 1 breaks in tension: peak 400 kN over its ultimate "
                               "load 350 kN (inline), first at 17.5")
    assert "; over its proof load 250 kN from 12.5" in lines[1]
    assert lines[2].startswith("  coupler 2 yields in tension: peak 300 kN over its proof "
                               "load 250 kN (inline), first at 16.6") and len(lines) == 3


def test_no_strength_no_events():
    sc = _train(None)
    ds = ltdsim.simulate(sc.with_overrides({"solver.t_end": 2.0}))
    assert strength_events(ds, sc).empty and stored_events(ds).empty


def test_shipped_heavy_haul_fluid_emergency_breaks_grade_e_couplers():
    """The 2 + 105 + 2 + 105 train's emergency from the lead under the fluid brake (its
    first 40 s), one gear per coupling as the scenario has it: the run-out after the
    run-in drives tens of couplers past a grade E knuckle's 650 kip (4-4.5 MN with the
    staged emergency build-up; 19-20 MN before it); the run says they would have broken,
    and exactly those couplers."""
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "heavy-haul-fluid.toml",
                              case="emergency-lead")
    assert sc.coupler(0).strength == "aar-e" and sc.coupler(5).strength == "aar-e"
    ds = ltdsim.simulate(sc.with_overrides({"solver.t_end": 40.0}))
    ev = stored_events(ds)
    ult = ev[ev.kind == "ultimate"]
    assert len(ult) > 20 and (ult.grade == "aar-e").all() and (ult.direction == "tension").all()
    knuckle = 650_000 * LBF
    np.testing.assert_allclose(ult.limit_N, knuckle, rtol=1e-6)
    # each event's force is that coupler's peak, over the limit; the first time over it
    # is after the application at 2 s, not after the peak, and after the proof load's
    proof = ev[(ev.kind == "proof") & (ev.direction == "tension")].set_index("coupler")
    peak_tension = ds.max_coupler_force.values
    for r in ult.itertuples():
        assert r.force_N == pytest.approx(peak_tension[r.coupler - 1]) and r.force_N >= knuckle
        assert 2.0 <= r.time_s <= r.peak_time_s + 1e-9
        assert proof.time_s[r.coupler] <= r.time_s
    # every coupler the peaks put over the knuckle's ultimate load has its event, no other
    assert set(ult.coupler) == set(np.flatnonzero(peak_tension >= knuckle) + 1)


def test_the_head_end_emergency_with_a_gear_at_each_car_end_breaks_no_coupler():
    """The same fluid-brake emergency with the real car's two draft gears per coupling
    (one in each car end, in series: twice the travel and the capacity): peaks of about
    2.2-2.5 MN, under the grade E knuckle's ultimate load, so no coupler breaks (some
    exceed the 400 kip proof load, and the run says which)."""
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "heavy-haul-fluid.toml",
                              case="emergency-lead")
    ds = ltdsim.simulate(sc.with_overrides({"solver.t_end": 60.0, "couplers.default.gears": 2}))
    ev = stored_events(ds)
    peak = float(ds.max_coupler_force.max())
    assert 400_000 * LBF < peak < 650_000 * LBF
    assert ev[ev.kind == "ultimate"].empty
    proof = ev[(ev.kind == "proof") & (ev.direction == "tension")]
    assert set(proof.coupler) == set(np.flatnonzero(
        ds.max_coupler_force.values >= 400_000 * LBF) + 1)


def test_shipped_heavy_haul_emergency_stays_below_grade_e():
    """The same train's emergency under the simple brake model peaks at about 1.5 MN in
    tension and 1.1 MN in compression (40 s): below the knuckle's proof load (400 kip,
    1.78 MN), so no coupler has a load event."""
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "heavy-haul.toml", case="emergency")
    ds = ltdsim.simulate(sc.with_overrides({"solver.t_end": 40.0}))
    assert float(ds.max_coupler_force.max()) < 400_000 * LBF
    ev = stored_events(ds)
    assert ev[ev.kind != "solid"].empty


# ---------------------------------------------------------------- the table
def test_every_strength_number_carries_a_source():
    names = preset_names("strength")
    assert {"aar-e", "aar-e-body", "en15566-1000", "en15566-1200", "en15566-1500",
            "uic-850"} <= set(names)
    for name in names:
        grade = load_preset("strength", name)
        given = [k for k in STRENGTH_KEYS if k in grade]
        assert given, name
        for k in given:
            assert isinstance(grade["sources"].get(k), str) and len(grade["sources"][k]) > 20, \
                (name, k)
        limits = strength_limits(name)  # validates: positive, proof <= ultimate
        assert all(getattr(limits, k) == grade.get(k) for k in STRENGTH_KEYS)


def test_aar_figures_are_the_published_pounds():
    """AAR publishes kip: knuckle 400 / 650, body 700 / 900, yoke 750 / 900 (M-211, M-205)."""
    e, body = load_preset("strength", "aar-e"), load_preset("strength", "aar-e-body")
    for got, kip in ((e["draft_proof"], 400), (e["draft_ultimate"], 650),
                     (body["draft_proof"], 700), (body["draft_ultimate"], 900),
                     (e["parts"]["yoke"]["proof"], 750), (e["parts"]["yoke"]["ultimate"], 900),
                     (e["parts"]["coupler_body"]["ultimate"], 900)):
        assert got == pytest.approx(kip * 1e3 * LBF, abs=1.0)
    # the coupling is as strong as its weakest part, the knuckle
    assert e["draft_ultimate"] == min(p["ultimate"] for p in e["parts"].values())
    for c in (1000, 1200, 1500):
        assert load_preset("strength", f"en15566-{c}")["draft_ultimate"] == c * 1e3
    assert "ltdsim's reading" in e["sources"]["buff_proof"]


def test_strength_key_is_checked_and_survives_a_preset_override():
    with pytest.raises(Exception, match="unknown coupler strength grade 'aar-x'"):
        CouplerParams(model="linear", stiffness=1e6, strength="aar-x")
    with pytest.raises(Exception, match="a coupling yields before it breaks"):
        CouplerParams(model="linear", stiffness=1e6,
                      strength={"draft_proof": 2e6, "draft_ultimate": 1e6})
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "heavy-haul-fluid.toml")
    assert sc.coupler(0).model == "polymer" and sc.coupler(0).strength == "aar-e"
    assert ltdsim.load_scenario(ROOT / "scenarios" / "uic-freight.toml").coupler(0).strength \
        == "en15566-1000"
    assert math.isclose(strength_limits("uic-850").draft_ultimate, 8.5e5)


def test_first_time_over_uses_the_step_peak_between_coarse_samples():
    """A pulse rising 220 MN/s to 19 MN at 26.08 s and falling 10 MN/s, sampled every
    0.5 s: the first sample over 2.89 MN (26.5 s) comes after the peak; with the
    step-by-step peak the crossing is on the rising edge, exactly (the edge is a line
    through the sample at 26.0 s and the peak)."""
    from ltdsim.results.strength import _first_over

    t = np.arange(0.0, 40.0, 0.5)
    tp, peak, up, down, limit = 26.08, 1.9e7, 2.2e8, 1.0e7, 2.89e6
    s = np.clip(np.where(t < tp, peak - up * (tp - t), peak - down * (t - tp)), 0.0, None)
    when, between = _first_over(t, s, limit, peak, tp)
    assert when == pytest.approx(tp - (peak - limit) / up, abs=1e-9) and not between
    # a pulse so narrow that every sample stays below: missed by the samples
    s2 = np.clip(peak - 1e9 * np.abs(t - tp), 0.0, None)
    when, between = _first_over(t, s2, limit, peak, tp)
    assert between and 26.0 < when < tp
    # nothing recorded: the peak's own time
    assert _first_over(t, None, limit, peak, tp) == (tp, True)
