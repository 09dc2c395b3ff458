"""Fatigue damage (ltdsim.results.fatigue) against independent references: the worked
rainflow example of ASTM E1049-85 (Fig. 6 of section 5.4.4, with its table of ranges and
counts), the closed form of Miner's rule for a constant amplitude, the published ratios
of EN 1993-1-9's two-slope curve, the shipped curve's numbers against their published
figures, and, for a real run, a count of the same force history by the hand-written
four-point rainflow method below (no code shared with the module under test).

The four-point method (the rainflow counting of ASTM E1049-85 written as a stack): of
four consecutive turning points s1, s2, s3, s4, the inner pair is a full cycle of range
|s2 - s3| when that range is no larger than either outer one; it is taken out and the
test repeated; what stays on the stack at the end is the residue, each of its ranges a
half cycle. Cycles taken out never depend on the order in which they are found, so a
history cut in two is counted as its two parts' full cycles plus the count of their
joined residues: the seam's only effect.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ltdsim
from ltdsim.results.fatigue import (
    ATTR,
    NOISE,
    cutoff_range,
    cycles_to_failure,
    distance_run,
    fatigue_damage,
    history_damage,
    knee_range,
    rainflow_cycles,
    stored_damage,
    turning_points,
)
from ltdsim.scenario import Scenario
from ltdsim.scenario.couplers import FatigueCurve, fatigue_curve

from conftest import ROOT

KIP = 4448.2216152605  # N per kip (1000 lbf, exact)

#: the same examples on every machine and run, no time limit
PROPERTY = dict(deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow])


# ----------------------------------------------------- an independent reference count
def ref_turning(x) -> list[float]:
    """Peaks and valleys of ``x`` with its first and last point (plain Python)."""
    pts = [float(x[0])]
    for v in map(float, x[1:]):
        if v == pts[-1]:
            continue
        if len(pts) >= 2 and (pts[-1] - pts[-2]) * (v - pts[-1]) > 0.0:
            pts[-1] = v  # still going the same way: the extreme moves on
        else:
            pts.append(v)
    return pts


def ref_rainflow(x) -> tuple[list[float], list[float]]:
    """Four-point rainflow count of ``x``: the full cycles' ranges and the residue."""
    full: list[float] = []
    stack: list[float] = []
    for v in ref_turning(x):
        stack.append(v)
        while len(stack) >= 4:
            s1, s2, s3, s4 = stack[-4:]
            inner = abs(s2 - s3)
            if inner <= abs(s1 - s2) and inner <= abs(s3 - s4):
                full.append(inner)
                del stack[-3:-1]
            else:
                break
    return full, stack


def ref_cycles(x) -> tuple[np.ndarray, np.ndarray]:
    """(ranges, counts) of the four-point count: full cycles 1, residue ranges 0.5."""
    full, res = ref_rainflow(x)
    half = [abs(b - a) for a, b in zip(res, res[1:])]
    return (np.array(full + half, dtype=float),
            np.array([1.0] * len(full) + [0.5] * len(half)))


def ref_life(curve: dict, dF: float) -> float:
    """Cycles to failure at range ``dF`` (N) of a curve given as its numbers, written
    out from the two-slope law (not the module's code)."""
    ref, n_ref, m = curve["reference_range"], curve["reference_cycles"], curve["slope"]
    if dF <= 0.0:
        return math.inf
    n = n_ref * (ref / dF) ** m
    knee = curve.get("knee_cycles")
    if knee is None or n <= knee:
        return n
    m2 = curve.get("slope_beyond_knee")
    if m2 is None:
        return math.inf
    f_knee = ref * (n_ref / knee) ** (1.0 / m)
    n2 = knee * (f_knee / dF) ** m2
    cut = curve.get("cutoff_cycles")
    return math.inf if cut is not None and n2 > cut * (1 + 1e-12) else n2


def ref_damage(curve: dict, x) -> float:
    ranges, counts = ref_cycles(x)
    return float(sum(c / ref_life(curve, r) for r, c in zip(ranges, counts)))


def _curve(**keys) -> FatigueCurve:
    return FatigueCurve(**keys)


#: a two-slope curve of EN 1993-1-9's shape at a low reference, so that small forces do
#: damage: 100 kN at 2e6 cycles, m = 3 to 5e6, m = 5 to the cut-off at 1e8
LOW = {"load": "both", "reference_range": 1.0e5, "reference_cycles": 2.0e6, "slope": 3.0,
       "knee_cycles": 5.0e6, "slope_beyond_knee": 5.0, "cutoff_cycles": 1.0e8}


def _table(ranges, counts, floor: float = 0.0) -> dict[float, float]:
    """Cycles per range (ranges rounded to 1e-6 of their unit), ranges without any
    cycle and ranges up to ``floor`` left out."""
    out: dict[float, float] = {}
    for r, c in zip(np.asarray(ranges, dtype=float), counts):
        if r > floor:
            key = float(np.round(r, 6))
            out[key] = out.get(key, 0.0) + float(c)
    return {r: c for r, c in out.items() if c}


def _noise(x) -> float:
    """The rounding the module drops as no load: ranges up to 2 NOISE max |x| (with
    room for the reference count's own rounding)."""
    return 2.0 * NOISE * float(np.max(np.abs(x)))


# ------------------------------------------------------------------ ASTM E1049-85
ASTM_HISTORY = [-2, 1, -3, 5, -1, 3, -4, 4, -2]  # units, ASTM E1049-85 Fig. 6
#: its table (Fig. 6): range (units) -> cycles, half cycles counted as 0.5
ASTM_TABLE = {3: 0.5, 4: 1.5, 6: 0.5, 8: 1.0, 9: 0.5}


def test_astm_e1049_worked_example_counted_exactly():
    ranges, means, counts = rainflow_cycles(ASTM_HISTORY)
    table: dict[float, float] = {}
    for r, c in zip(ranges, counts):
        table[float(r)] = table.get(float(r), 0.0) + float(c)
    assert table == {float(k): v for k, v in ASTM_TABLE.items()}
    # the half and full cycles of the figure: one full cycle of 4 (-1 to 3), half cycles
    # of 3, 4, 6, 8, 8, 9
    assert sorted(ranges[counts == 1.0].tolist()) == [4.0]
    assert sorted(ranges[counts == 0.5].tolist()) == [3.0, 4.0, 6.0, 8.0, 8.0, 9.0]
    # and the reference count here agrees (the check of the check)
    full, res = ref_rainflow(ASTM_HISTORY)
    assert full == [4.0] and res == [-2, 1, -3, 5, -4, 4, -2]


def test_astm_example_through_a_gate_below_its_smallest_range():
    """The example's smallest range is 3 units: a gate of 2.9 leaves every cycle, one of
    3.1 drops the first half cycle (-2 to 1) and nothing else at or above 3.1."""
    r0, _, c0 = rainflow_cycles(ASTM_HISTORY, gate=2.9)
    r1, _, c1 = rainflow_cycles(ASTM_HISTORY)
    assert sorted(zip(r0.tolist(), c0.tolist())) == sorted(zip(r1.tolist(), c1.tolist()))
    r2, _, c2 = rainflow_cycles(ASTM_HISTORY, gate=3.1)
    assert 3.0 not in r2.tolist()
    big = sorted((r, c) for r, c in zip(r1.tolist(), c1.tolist()) if r >= 3.1)
    assert sorted((r, c) for r, c in zip(r2.tolist(), c2.tolist()) if r >= 3.1) == big


@given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=2, max_size=60))
@settings(max_examples=200, **PROPERTY)
def test_count_is_the_four_point_rainflow_count(x):
    """On any history, the module's count (the rainflow package's ASTM 5.4.4 stack) is
    the hand-written four-point count: the same cycles of each range (where ranges tie,
    ASTM's starting-point rule may count two half cycles for the four-point method's
    full one: the same 1 cycle, so the table of range and cycles is compared, as the
    standard gives it)."""
    floor = _noise(x)
    assert _table(*rainflow_cycles(x)[::2], floor) == _table(*ref_cycles(x), floor)


# ------------------------------------------------------ Miner's rule, closed form
def _constant_amplitude(mean: float, rng: float, n: int, per_cycle: int = 16) -> np.ndarray:
    """n cycles of a sine of range ``rng`` about ``mean``, sampled ``per_cycle`` times a
    cycle (its peaks and valleys on samples), starting and ending at a valley."""
    t = np.arange(n * per_cycle + 1) / per_cycle
    return mean - 0.5 * rng * np.cos(2.0 * np.pi * t)


@given(rng=st.floats(1.0e3, 3.0e6), n=st.integers(1, 300),
       curve=st.sampled_from(["low", "shipped"]))
@settings(max_examples=120, **PROPERTY)
def test_constant_amplitude_damage_is_cycles_over_allowed_cycles(rng, n, curve):
    """n cycles of one range dF do D = n / N(dF), N from the curve's law written out
    here; for the shipped knuckle curve (draft), a draft cycle from zero to dF."""
    if curve == "low":
        keys, mean = LOW, 0.0  # load both: the signed force about zero
    else:
        with (ROOT / "src/ltdsim/data/fatigue/aar-e-knuckle.toml").open("rb") as fh:
            keys = tomllib.load(fh)
        mean = 0.5 * rng  # from zero draft to dF and back
    c = fatigue_curve("aar-e-knuckle") if curve == "shipped" else _curve(**LOW)
    x = _constant_amplitude(mean, rng, n)
    expected = n / ref_life(keys, rng)
    got = history_damage(c, x)
    if rng < c.gate:  # (the shipped curve's 10 kN gate: below its cut-off, no damage)
        assert got["cycles"] == 0.0 and got["damage"] == 0.0
        return
    assert got["cycles"] == pytest.approx(n)
    assert got["largest_range_N"] == pytest.approx(rng, rel=1e-12)
    if expected == 0.0:
        assert got["damage"] == 0.0
    else:
        assert got["damage"] == pytest.approx(expected, rel=1e-9)


def test_two_slope_curve_has_en1993_1_9_ratios():
    """EN 1993-1-9: the constant-amplitude fatigue limit at 5e6 cycles is 0.737 of the
    reference range at 2e6 (= 0.4^(1/3)), the cut-off at 1e8 is 0.549 of it (=
    0.05^(1/5)); at the knee, N is 5e6 on either slope, at the cut-off 1e8."""
    c = _curve(**LOW)
    assert knee_range(c) / c.reference_range == pytest.approx(0.737, abs=5e-4)
    assert cutoff_range(c) / knee_range(c) == pytest.approx(0.549, abs=5e-4)
    n = cycles_to_failure(c, [knee_range(c), cutoff_range(c), 0.999 * cutoff_range(c)])
    assert n[0] == pytest.approx(5e6) and n[1] == pytest.approx(1e8) and n[2] == math.inf


def test_shipped_knuckle_curve_is_its_published_numbers():
    """aar-e-knuckle: the knee at 218 kip (Bostek's fatigue threshold of the knuckle),
    the EN 1993-1-9 slopes 3 and 5, knee at 5e6 and cut-off at 1e8 cycles, in draft."""
    c = fatigue_curve("aar-e-knuckle")
    assert c.load == "draft"
    assert knee_range(c) == pytest.approx(218.0 * KIP, rel=1e-6)
    assert (c.slope, c.slope_beyond_knee) == (3.0, 5.0)
    assert (c.knee_cycles, c.cutoff_cycles) == (5e6, 1e8)
    # its derived points, as its file and docs/fatigue.md state them
    assert cycles_to_failure(c, [1316e3])[0] == pytest.approx(2e6, rel=2e-3)
    assert cutoff_range(c) == pytest.approx(532.6e3, rel=1e-4)
    assert c.gate < cutoff_range(c)


# ---------------------------------------------------------- additivity at a seam
#: histories of whole newtons (their ranges tie often, and none is rounding-sized, so the
#: module's rounding floor, NOISE, drops nothing from any of them)
histories = st.lists(st.integers(-10**6, 10**6).map(float), min_size=2, max_size=40)


@given(a=histories, b=histories)
@settings(max_examples=200, **PROPERTY)
def test_damage_adds_over_a_concatenation_but_for_the_seam(a, b):
    """D(a then b) = D(a) + D(b) - (a's and b's residues as half cycles) + (the count of
    a's residue then b's): only the half cycles left open at the seam interact."""
    c = _curve(load="both", reference_range=1e5, reference_cycles=2e6, slope=3.0)
    whole = history_damage(c, a + b)["damage"]
    _, res_a = ref_rainflow(a)
    _, res_b = ref_rainflow(b)

    def halves(res):
        return sum(0.5 / cycles_to_failure(c, [abs(q - p)])[0] for p, q in zip(res, res[1:]))

    seam = history_damage(c, res_a + res_b)["damage"]
    expected = (history_damage(c, a)["damage"] + history_damage(c, b)["damage"]
                - halves(res_a) - halves(res_b) + seam)
    assert whole == pytest.approx(expected, rel=1e-9, abs=1e-300)


@given(a=histories, b=histories)
@settings(max_examples=100, **PROPERTY)
def test_damage_adds_exactly_for_histories_closed_at_the_same_extreme(a, b):
    """Two histories that each start and end at the same value, the largest of both,
    leave no open half cycle to meet at the seam: D(a then b) = D(a) + D(b)."""
    top = max(max(a), max(b)) + 1.0
    a, b = [top] + a + [top], [top] + b + [top]
    c = _curve(**LOW)
    assert history_damage(c, a + b)["damage"] == pytest.approx(
        history_damage(c, a)["damage"] + history_damage(c, b)["damage"], rel=1e-12,
        abs=1e-300)


# ------------------------------------------------------------------ a constant mean
@given(x=histories, shift=st.floats(-2e6, 2e6, allow_nan=False),
       gate=st.sampled_from([0.0, 1e3, 2e4]))
@settings(max_examples=150, **PROPERTY)
def test_damage_ignores_a_constant_mean_on_a_curve_without_mean_correction(x, shift, gate):
    """The curves carry no mean-force correction: on the signed force (load both) a
    constant added to the whole history changes no range, so no damage (the gate works
    on ranges too)."""
    c = _curve(**LOW, gate=gate) if gate else _curve(**LOW)
    base = history_damage(c, x)["damage"]
    assert history_damage(c, [v + shift for v in x])["damage"] == pytest.approx(
        base, rel=1e-6, abs=1e-12 * max(base, 1e-300))


def test_a_draft_curve_does_see_the_mean():
    """A draft (knuckle) curve counts compression as no force: the same oscillation
    centred in draft does damage, moved wholly into buff none, and across zero only its
    draft part counts (range 150 kN of 200 kN)."""
    keys = dict(LOW, load="draft")
    c = _curve(**keys)
    n, rng = 50, 2.0e5
    in_draft = history_damage(c, _constant_amplitude(3e5, rng, n))["damage"]
    in_buff = history_damage(c, _constant_amplitude(-3e5, rng, n))["damage"]
    across = history_damage(c, _constant_amplitude(0.5e5, rng, n))["damage"]
    assert in_draft == pytest.approx(n / ref_life(keys, rng), rel=1e-9)
    assert in_buff == 0.0
    assert across == pytest.approx(n / ref_life(keys, 1.5e5), rel=1e-9)


# ---------------------------------------------------------------------- the gate
@given(x=st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=2, max_size=80),
       gate=st.floats(1.0, 5e5))
@settings(max_examples=200, **PROPERTY)
def test_gate_drops_only_cycles_smaller_than_itself(x, gate):
    """The hysteresis gate removes the cycles and half cycles of range below it and no
    other: the counted cycles at or above the gate are those of the ungated count, so a
    curve whose cut-off is at or above the gate takes the same damage."""
    r0, _, c0 = rainflow_cycles(x)
    r1, _, c1 = rainflow_cycles(x, gate=gate)
    keep = r0 >= gate
    assert _table(r1, c1) == _table(r0[keep], c0[keep])
    assert np.all(r1 >= gate)
    idx = turning_points(x, gate)
    assert np.all(np.diff(idx) > 0)


# -------------------------------------------------------------------- a real run
@pytest.fixture(scope="module")
def run():
    """two-wagons-linear.toml (a locomotive pulls two wagons through linear couplers
    with slack, then brakes: run-in and run-out), coupler 1 on the low two-slope curve
    on the signed force, coupler 2 on the same curve in draft, with a 5 kN gate."""
    with (ROOT / "scenarios/two-wagons-linear.toml").open("rb") as fh:
        d = tomllib.load(fh)
    d["couplers"]["default"]["fatigue"] = dict(LOW, gate=5e3)
    d["couplers"]["override"] = [{"index": 1, "fatigue": dict(LOW, load="draft", gate=5e3)}]
    sc = Scenario.from_dict(d, "two-wagons-linear with fatigue curves")
    return sc, ltdsim.simulate(sc)


def test_run_damage_per_coupler_is_the_reference_count(run):
    sc, ds = run
    table = stored_damage(ds)
    assert table is not None and len(table) == 2
    assert ATTR in ds.attrs
    f = ds.coupler_force.values
    for j, load in ((0, "both"), (1, "draft")):
        x = f[:, j] if load == "both" else np.maximum(f[:, j], 0.0)
        expected = ref_damage(LOW, x)  # no gate: the gate is below the cut-off range
        assert expected > 0.0  # the run does load the couplers past the cut-off
        row = table[table.coupler == j + 1].iloc[0]
        assert row.load == load and row.curve == "inline"
        assert row.damage == pytest.approx(expected, rel=1e-9)
    # the table the run stored is the one computed from the result afresh
    again = fatigue_damage(ds, sc)
    assert again.damage.tolist() == pytest.approx(table.damage.tolist(), rel=1e-12)


def test_run_damage_per_km_uses_the_distance_the_train_ran(run):
    """Per km over the lead vehicle's path, which is the time integral of its speed."""
    _, ds = run
    table = stored_damage(ds)
    v = ds.velocity.values[:, 0]
    t = ds.time.values
    path = float(np.sum(0.5 * (np.abs(v[1:]) + np.abs(v[:-1])) * np.diff(t)))
    assert distance_run(ds) == pytest.approx(path, rel=1e-4)
    for r in table.itertuples():
        assert r.damage_per_km == pytest.approx(r.damage / (path / 1e3), rel=1e-4)
