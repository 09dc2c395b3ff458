"""Every coupler key lands in its named place; keys of another model are refused.

The placement test walks the schema (every field of every coupler model's class), not
the lowering code: a key gets a different value from every other key, the scenario is
lowered, and the value must be found in the column the registry names for it (or, for
a derived column, the value that the documented formula gives). A new schema key
without a place, or two keys swapped, fails here.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from ltdsim.engine.couplers import MODEL_NAMES, N_CCOL, REGISTRY
from ltdsim.errors import ScenarioError
from ltdsim.engine.lowering import lower
from ltdsim.scenario import COUPLER_CLASSES, CouplerParams
from ltdsim.data import load_preset

from conftest import build, train_dict

#: one valid coupler of each model with every key given (optional ones too)
FULL = {
    "linear": {"model": "linear", "slack": 0.02, "stiffness": 5e6, "damping": 2e4,
               "travel": 0.08, "solid_stiffness": 2e9},
    "simplified": {"model": "simplified", "slack": 0.025, "preload": 1e4, "damping": 1e3,
                   "k1": 8e6, "k2": 1.8e6, "k3": 3.4e6, "v_c": 0.6, "travel": 0.09,
                   "solid_stiffness": 3e9, "fade": "rate", "gears": 2},
    "friction_wedge": {**load_preset("gears", "friction-wedge-high"), "tracking_time": 2e-3,
                       "solid_stiffness": 4e9, "plate_backlash": 0.004},
    "table": {**load_preset("gears", "mt-2"), "tracking_time": 3e-3, "solid_stiffness": 5e9},
    "polymer": {**load_preset("gears", "polymer-heavy-haul"), "tracking_time": 1e-3,
                "solid_stiffness": 6e9},
    "cushion": {**load_preset("gears", "eoc-15"), "solid_stiffness": 7e9},
}
S_TABLE = {"velocity": [0.0, 1.0, 4.0], "deflection": [0.0, 0.05],
           "values": [[1.0, 1.1], [0.9, 1.0], [0.8, 0.85]]}


def _wedge_geometry(alpha, beta, gamma):
    """tan a, tan b, tan g, G and c1..c3 of paper Eq. 3-4 (angles in deg)."""
    a, b, g = (math.radians(v) for v in (alpha, beta, gamma))
    cag = math.cos(a + g)
    return {"tan_alpha": math.tan(a), "tan_beta": math.tan(b), "tan_gamma": math.tan(g),
            "G": math.cos(a) * math.cos(g - b) / (cag * math.cos(b)),
            "c1": math.cos(a) / cag, "c2": math.sin(g) / cag,
            "c3": math.cos(a) * math.sin(g) / (cag * math.cos(b))}


def _store(tables, off, n):
    return tables[int(off):int(off) + n]


def expected_places(c, key):
    """``{column: value}`` a key of validated coupler ``c`` must produce, or a callable
    check on ``(row, tables)`` for keys stored in the table store; None for keys that
    are not lowered (merged at validation)."""
    value = getattr(c, key)
    if key == "preset":
        return None
    if key == "v_c":
        return {"inv_v_c": 1.0 / value}
    if key == "gears":
        return {"inv_gears": 1.0 / value}
    if key == "fade":
        return {"by_rate": 1.0 if value == "rate" else 0.0}
    if key in ("alpha_deg", "beta_deg", "gamma_deg"):
        return _wedge_geometry(c.alpha_deg, c.beta_deg, c.gamma_deg)
    if key == "tracking_time":
        return {"rate": 1.0 / value}
    if key in ("loading", "unloading"):
        def check(row, tables, entry=REGISTRY[c.model], pts=np.asarray(value)):
            n = int(row[entry.column(key + "_len")])
            assert n == len(pts)
            stored = _store(tables, row[entry.column(key)], 2 * n)
            np.testing.assert_array_equal(stored, np.concatenate([pts[:, 0], pts[:, 1]]))
        return check
    if key == "S_table":
        if value is None:
            return {"S_table": -1.0}

        def check(row, tables, entry=REGISTRY[c.model], t=value):
            nv = int(row[entry.column("S_n_velocity")])
            nx = int(row[entry.column("S_n_deflection")])
            assert (nv, nx) == (len(t.velocity), len(t.deflection))
            stored = _store(tables, row[entry.column("S_table")], nv + nx + nv * nx)
            np.testing.assert_array_equal(stored, [*t.velocity, *t.deflection,
                                                   *np.ravel(t.values)])
        return check
    if key == "travel" and value is None:
        return {"travel": math.inf}  # never closes solid
    if value is None:  # an optional key left out (S with an S_table; tracking_time)
        return {}
    return {key: value}


def check_every_key(c, low, j):
    entry = REGISTRY[c.model]
    row, tables = low.cpl[j], low.ctab
    assert low.cpl_model[j] == MODEL_NAMES.index(c.model)
    unplaced = []
    for key in type(c).model_fields:
        if key == "model":
            continue
        want = expected_places(c, key)
        if want is None:
            continue
        if callable(want):
            want(row, tables)
            continue
        if not want and getattr(c, key) is not None:
            unplaced.append(key)
        for column, value in want.items():
            got = row[entry.column(column)]
            assert got == pytest.approx(value, rel=1e-13), (key, column, got, value)
    assert not unplaced, f"keys without a place in the coupler table: {unplaced}"


def _scaled(params, factors):
    out = copy.deepcopy(params)
    for (key, value), f in zip(sorted((k, v) for k, v in params.items()
                                      if isinstance(v, float) and k != "slack"), factors):
        out[key] = value * f
    return out


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=st.sampled_from(MODEL_NAMES), s_table=st.booleans(),
       factors=st.lists(st.floats(0.93, 1.07), min_size=24, max_size=24, unique=True),
       slack=st.floats(0.0, 0.05), start=st.sampled_from(["neutral", "stretched", "bunched"]))
def test_every_coupler_key_lands_in_its_named_column(model, s_table, factors, slack, start):
    params = _scaled(FULL[model], factors)
    params["slack"] = slack
    if model == "friction_wedge" and s_table:
        params.pop("S")
        params["S_table"] = S_TABLE
    floats = [v for v in params.values() if isinstance(v, float)]
    assume(len(set(floats)) == len(floats))  # every key its own value
    d = train_dict([8e4, 9e4, 7e4], coupler=params)
    d["solver"]["stability_check"] = False
    d["initial"]["couplers"] = start
    try:
        sc = build(d)
    except ScenarioError:  # a perturbed wedge that locks: not a valid gear
        assume(False)
    low = lower(sc)
    assert low.cpl.shape == (2, N_CCOL)
    for j in range(2):
        c = sc.coupler(j)
        assert type(c) is COUPLER_CLASSES[model]
        check_every_key(c, low, j)
        # the initial state of the slack: at its end in the direction the train starts
        sign = {"neutral": 0.0, "stretched": 1.0, "bunched": -1.0}[start]
        assert low.d0[j] == sign * 0.5 * slack
    # a gear's internal force starts at its released force, f_l(0)
    if model == "table":
        assert low.y0[6] == params["loading"][0][1]


def test_the_coupler_table_is_as_wide_as_the_common_columns_and_the_widest_model():
    from ltdsim.engine.couplers import COMMON_COLUMNS

    widths = {m: len(REGISTRY[m].columns) for m in MODEL_NAMES}
    assert N_CCOL == len(COMMON_COLUMNS) + max(widths.values())
    for m in MODEL_NAMES:  # a model's own columns are distinct and inside the table
        cols = [REGISTRY[m].column(k) for k in REGISTRY[m].columns]
        assert len(set(cols)) == len(cols) and max(cols) < N_CCOL


@pytest.mark.parametrize("model, foreign, value, owner", [
    ("linear", "k1", 1e6, "simplified"),
    ("simplified", "stiffness", 1e6, "linear"),
    ("simplified", "k_locked", 1e8, "friction_wedge"),
    ("table", "damping", 1e3, "linear"),
    ("friction_wedge", "loading", [[0.0, 0.0], [0.1, 1e6]], "table"),
])
def test_a_key_of_another_model_is_refused_in_one_line(model, foreign, value, owner):
    params = {**FULL[model], foreign: value}
    with pytest.raises(ScenarioError) as err:
        build(train_dict([8e4, 9e4], coupler=params))
    msg = str(err.value)
    assert "\n" not in msg
    assert f"couplers.default.{foreign}" in msg and f"model '{model}'" in msg
    assert repr(owner) in msg


def test_an_unknown_model_is_refused_with_the_models_listed():
    with pytest.raises(ScenarioError) as err:
        build(train_dict([8e4, 9e4], coupler={"model": "hydraulic", "k1": 1.0}))
    msg = str(err.value)
    assert "couplers.default.model" in msg and "'table'" in msg and '"hydraulic"' in msg


def _with_override(override):
    d = train_dict([8e4, 9e4, 7e4, 6e4], coupler=FULL["simplified"])
    d["solver"]["stability_check"] = False
    d["couplers"]["override"] = [override]
    return build(d)


def test_an_override_that_keeps_the_model_merges_with_the_default():
    sc = _with_override({"index": 1, "k3": 7.9e6})
    c, base = sc.coupler(1), sc.coupler(0)
    assert c.k3 == 7.9e6
    assert (c.k1, c.k2, c.damping, c.slack, c.travel) == (base.k1, base.k2, base.damping,
                                                          base.slack, base.travel)


def test_an_override_that_changes_the_model_keeps_only_the_shared_keys():
    sc = _with_override({"index": 2, "model": "linear", "stiffness": 4e6})
    c = sc.coupler(2)
    assert c.model == "linear" and c.stiffness == 4e6
    default = FULL["simplified"]
    assert (c.slack, c.travel, c.solid_stiffness) == (default["slack"], default["travel"],
                                                      default["solid_stiffness"])
    # the default's simplified damping does not carry over to the linear coupler
    assert c.damping == 0.0 != default["damping"]
    assert sc.coupler(1).model == sc.coupler(3).model == "simplified"
    low = lower(sc)
    assert list(low.cpl_model) == [MODEL_NAMES.index(m) for m in
                                   ("simplified", "simplified", "linear")]
    check_every_key(c, low, 2)


def test_an_override_naming_a_preset_takes_the_presets_gear():
    sc = _with_override({"index": 0, "preset": "mt-2"})
    c = sc.coupler(0)
    assert c.model == "table" and c.k_locked == load_preset("gears", "mt-2")["k_locked"]
    assert c.slack == FULL["simplified"]["slack"]  # the default's slack, not the preset's


def test_an_override_that_changes_the_model_still_needs_that_models_keys():
    with pytest.raises(ScenarioError) as err:
        _with_override({"index": 1, "model": "linear"})
    assert "coupler 2 (index 1" in str(err.value) and "needs stiffness" in str(err.value)


def test_couplerparams_builds_the_model_class_and_merges_presets():
    c = CouplerParams(preset="friction-wedge-high", slack=0.0)
    assert type(c) is COUPLER_CLASSES["friction_wedge"] and c.slack == 0.0
    assert type(CouplerParams(k1=1.0, k3=1.0, v_c=1.0)) is COUPLER_CLASSES["simplified"]


def test_a_result_saved_before_the_model_classes_reads_back():
    # results used to save every coupler key of every model (others null or at their
    # defaults); a saved dump drops them, a file refuses them
    from ltdsim.scenario import Scenario

    sc = build(train_dict([8e4, 9e4], coupler=FULL["friction_wedge"]))
    old = sc.to_dict()
    old["couplers"]["default"].update({"stiffness": None, "k1": None, "v_c": None,
                                       "damping": 0.0, "preload": 0.0, "k2": 0.0,
                                       "loading": None})
    back = Scenario.from_saved(old)
    assert back.coupler(0) == sc.coupler(0)
    with pytest.raises(ScenarioError):
        Scenario.from_dict(old)
