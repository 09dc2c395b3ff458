"""Couplings held at their slack edge (``solver.hold_speed``) against the rigid-body
closed form, a fixed-step run where the gear carries, and the energy balance.

A preloaded friction gear with a rigid end exerts nothing in its slack and its released
force f0 the instant the slack closes. Two vehicles pulled apart by less than f0 then
move as one body in the exact solution: the coupling stays at its edge and carries the
force that keeps them together. Held, the coupling must carry exactly that force; let go
where it reaches f0, the gear must take over as a fixed-step run finds it.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ltdsim
from conftest import build, train_dict

SLACK = 0.02  # m
HOLD = 3e-3  # m/s


def _pair(m1, m2, force_profile, t_end, method="bs23", hold=HOLD, energy=False, dt=1e-4):
    """A locomotive of ``m1`` (kg) pulling a wagon of ``m2`` (kg) by the force profile
    ``[[t s, F N], ...]``, on the study's high friction gear with a rigid end and
    ``SLACK`` of free play, stretched at the start; no resistance."""
    d = train_dict([m1, m2], t_end=t_end, dt=dt, output_interval=0.05, method=method,
                   coupler={"preset": "friction-wedge-high", "slack": SLACK})
    d["driver"]["force_profile"] = force_profile
    d["initial"]["couplers"] = "stretched"
    if method == "bs23":
        d["solver"].update(rtol=1e-4, atol=1e-5)
        if hold is not None:
            d["solver"]["hold_speed"] = hold
    d["solver"]["energy"] = energy
    return ltdsim.simulate(build(d))


def _preload(ds) -> float:
    """The gear's released force f0, N: the force it meets the closing slack with."""
    from ltdsim.engine.couplers import P_F0
    from ltdsim.engine.lowering import lower
    return float(lower(ltdsim.Scenario.from_dict(json.loads(ds.attrs["scenario_json"]),
                                                 "test")).cpl[0, P_F0])


@settings(max_examples=6, deadline=None)
@given(m1=st.floats(60e3, 200e3), m2=st.floats(20e3, 130e3), share=st.floats(0.1, 0.9))
def test_a_held_coupling_carries_the_rigid_body_force(m1, m2, share):
    # a constant pull P whose share m2 / (m1 + m2) on the wagon is below the preload:
    # the pair accelerates as one body at P / (m1 + m2) and the coupling carries
    # P m2 / (m1 + m2), at every record and as its peak over every step
    f0 = 99.0e3  # (about the preset's; checked against the lowered value below)
    pull = share * f0 * (m1 + m2) / m2
    ds = _pair(m1, m2, [[0.0, pull]], 5.0)
    assert _preload(ds) == pytest.approx(f0, rel=0.01)
    # (the traction force the run applied, which may lag the profile)
    pulled = ds.traction_force.values[1:]
    f = ds.coupler_force.values[1:, 0]
    np.testing.assert_allclose(f, pulled * m2 / (m1 + m2), rtol=1e-9)
    assert ds.max_coupler_force.values[0] == pytest.approx(pull * m2 / (m1 + m2), rel=1e-9)
    a = ds.acceleration.values[1:]
    np.testing.assert_allclose(a, np.broadcast_to(pulled[:, None] / (m1 + m2), a.shape),
                               rtol=1e-9)
    # the coupling stays at its edge
    np.testing.assert_allclose(ds.coupler_deflection.values[:, 0], SLACK / 2, atol=1e-9)


def test_a_held_coupling_is_let_go_into_its_gear_at_the_preload():
    # a pull rising at 100 kN/s on two 90 t vehicles: the coupling carries half of it
    # and is held until that reaches the preload (at about 2 s), then the gear deflects
    # on its loading curve; from there the held run follows a fixed-step run at 2e-5 s
    # (which chatters at the edge before and agrees once the gear carries)
    prof = [[0.0, 0.0], [6.0, 6.0e5]]
    held = _pair(90e3, 90e3, prof, 6.0)
    fixed = _pair(90e3, 90e3, prof, 6.0, method="ode3", hold=None, dt=2e-5)
    f0 = _preload(held)
    t = held.time.values
    f = held.coupler_force.values[:, 0]
    pull = 1e5 * t
    before = pull / 2 < 0.98 * f0
    np.testing.assert_allclose(f[before], pull[before] / 2, rtol=1e-9, atol=1e-6)
    after = pull / 2 > 1.2 * f0
    assert after.sum() > 30
    ff = fixed.coupler_force.values[:, 0]
    np.testing.assert_allclose(f[after], ff[after], rtol=0.02)
    assert held.max_coupler_force.values[0] == pytest.approx(
        fixed.max_coupler_force.values[0], rel=0.01)


def test_a_slow_touch_is_plastic_and_its_energy_is_the_coupling_s_work():
    # the pull ends and a brake force of 20 kN slows the 120 t locomotive: the coupling,
    # held in draft, is let go into its slack, which the locomotive closes against the
    # 60 t wagon at sqrt(2 a s) (a = 20 kN / 120 t, s the slack) = 82 mm/s; held below
    # 0.1 m/s, that touch is plastic: the coupling takes mu v^2 / 2 (mu the reduced
    # mass), 133 J, and holds the pair in buff. The energy balance closes to a
    # hundredth of that.
    m1, m2, brake = 120e3, 60e3, 2.0e4
    prof = [[0.0, 5.0e4], [2.0, 5.0e4], [2.001, -brake], [6.0, -brake]]
    ds = _pair(m1, m2, prof, 6.0, hold=0.1, energy=True)
    v = np.sqrt(2.0 * brake / m1 * SLACK)
    touch = 0.5 * m1 * m2 / (m1 + m2) * v ** 2
    assert ds.attrs["edge_holds"] >= 3  # held in draft, let go, held in buff
    work = float(ds.coupler_energy.values[-1, 0])
    assert work == pytest.approx(touch, rel=0.02), (work, touch)
    np.testing.assert_allclose(ds.coupler_deflection.values[-20:, 0], -SLACK / 2, atol=1e-9)
    err = float(np.abs(ds.energy_balance_error.values).max())
    assert err < 0.01 * touch, (err, touch)


def test_which_couplings_may_be_held_and_a_key_that_could_hold_none_is_refused():
    # held up to its released force: a preloaded gear with a rigid end; never: the same
    # gear with a structure at the end of its slack (its force rises from none), a
    # linear coupler (no step at the edge)
    from ltdsim.engine.lowering import lower
    from ltdsim.errors import ScenarioError
    d = train_dict([90e3, 90e3, 90e3], t_end=1.0, method="bs23",
                   coupler={"preset": "friction-wedge-high", "slack": SLACK})
    d["couplers"]["override"] = [{"index": 1, "preset": "friction-wedge-high",
                                  "slack": SLACK, "edge_stiffness": 1e8}]
    d["solver"]["hold_speed"] = HOLD
    low = lower(build(d))
    assert low.hold_f[0] == pytest.approx(99.0e3, rel=0.01) and low.hold_f[1] == 0.0
    d["couplers"] = {"default": {"model": "linear", "stiffness": 5e6, "slack": SLACK}}
    with pytest.raises(ScenarioError, match=r"solver\.hold_speed: no coupling of this "
                                            r"train can be held"):
        ltdsim.simulate(build(d))
