"""No brake pushes a standing train: a train braked to a stop on level track, by the
dynamic brake (traction curve or induction drive), the lumped air brake or the fluid air
brake, stays at rest for 60 s (speed 0 within round-off), and a train rolling backwards
is braked against its motion, not driven on.

The physics: every brake force opposes the motion and vanishes at standstill (shoe
friction on a standing wheel, and a motor's braking with its speed, give no force that
could start the train), so once the train has stopped nothing on level track moves it
again. Before the dynamic brake faded at rest, a constant -200 kN demand from 3 m/s
stopped the train and then drove it backwards to -16.7 m/s.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import ROOT, build, fluid_train, train_dict

from ltdsim.results.simulate import simulate
from ltdsim.scenario import Scenario, load_scenario

#: each vehicle's running resistance (Davis a N, b N s/m, c N s^2/m^2: about 1.1 per
#: mille of a 90 t wagon's weight at rest): what brings wagons bouncing in their slack
#: after the stop to rest, as on a real train
DAVIS = {"a": 1000.0, "b": 20.0, "c": 3.0}
#: m/s: "at rest" (round-off of a stopped integration, far below any creep a shoe or a
#: motor could cause)
AT_REST = 1e-6


def _settles_where_it_stopped(ds, room):
    """The vehicles' mean position, once at its furthest (m), goes back by less than
    ``room`` (m): the wagons may spring back within the couplers' slack and travel, the
    train is not driven backwards."""
    com = ds.position.values.mean(axis=1)
    k = int(np.argmax(com))
    assert com[k] - com[k:].min() < room, (com[k], com[k:].min())


def _stopped_then_at_rest(ds, hold=60.0, settle=10.0):
    """The time (s) the train first comes to a practical stop (every vehicle below
    1 mm/s), and the largest |speed| (m/s) of any vehicle over the ``hold`` seconds that
    follow a ``settle`` of the wagons in their slack."""
    t = ds.time.values
    v = np.abs(ds.velocity.values).max(axis=1)
    stop = np.flatnonzero(v < 1e-3)
    assert stop.size, f"never stopped (final speeds {ds.velocity.values[-1]})"
    t_stop = t[stop[0]]
    assert t[-1] >= t_stop + settle + hold, "the run ends before the hold"
    after = (t >= t_stop + settle) & (t <= t_stop + settle + hold)
    return t_stop, float(v[after].max())


@pytest.mark.parametrize("fade", [0.0, 2.0])
@pytest.mark.parametrize("method", ["ode3", "bs23"])
def test_dynamic_brake_stops_the_train_and_holds_it(fade, method):
    # a constant -200 kN (the case), force mode, 3 m/s, 5 vehicles
    d = train_dict([8e4, 6e4, 6e4, 6e4, 6e4], force=-2e5, t_end=90.0, dt=1e-3,
                   output_interval=0.05, method=method, speed=3.0, davis=DAVIS,
                   coupler={"model": "linear", "stiffness": 2e7, "damping": 1e5,
                            "slack": 0.02})
    d["traction"]["dynamic_brake_fade"] = fade
    sc = build(d)
    ds = simulate(sc)
    t_stop, moved = _stopped_then_at_rest(ds)
    assert t_stop < 20.0
    # at rest: within round-off on the fixed grid; within its speed tolerance (atol x 10
    # m/s) under bs23, whose error control keeps the stiff fade band about rest (the
    # brake as a damper of 2e5 N over 0.01 m/s) that far from exact, and the train
    # creeps by less than a millimetre over the minute
    assert moved < (AT_REST if method == "ode3" else 3 * 10 * sc.solver.atol)
    t = ds.time.values
    com = ds.position.values.mean(axis=1)
    hold = t >= t_stop + 10.0
    assert np.ptp(com[hold]) < 1e-3
    # (4 slacks of 20 mm and 4 springs of 2e7 N/m under the 200 kN)
    _settles_where_it_stopped(ds, room=4 * 0.02 + 4 * 2e5 / 2e7)


def test_dynamic_brake_in_notch_mode_holds_the_train():
    d = train_dict([8e4, 6e4, 6e4], t_end=110.0, dt=1e-3, output_interval=0.05, speed=3.0,
                   davis=DAVIS)
    d["traction"].update({"max_force": 3e5, "max_power": 3e6})  # notch -8: full braking
    d["driver"] = {"mode": "notch", "notch_profile": [[0.0, -8]]}
    ds = simulate(build(d))
    _, moved = _stopped_then_at_rest(ds)
    assert moved < AT_REST
    _settles_where_it_stopped(ds, room=0.2)


def test_dynamic_brake_opposes_a_train_running_backwards():
    # rolling back at 2 m/s with a braking demand: the force turns with the motion
    d = train_dict([8e4, 6e4, 6e4], force=-2e5, t_end=100.0, dt=1e-3, output_interval=0.05,
                   davis=DAVIS)
    d["initial"] = {"velocities": [-2.0, -2.0, -2.0]}
    ds = simulate(build(d))
    f = ds.traction_force.values
    v = ds.velocity.isel(vehicle=0).values
    moving = v < -0.1
    assert (f[moving] > 0.0).all()  # pushes forward, against the motion
    _, moved = _stopped_then_at_rest(ds)
    assert moved < AT_REST
    com = ds.position.values.mean(axis=1)  # never driven forwards past the slack's room
    assert com[np.argmin(com):].max() - com.min() < 0.2


def test_induction_drive_braking_holds_the_train():
    # the study's train on the induction drive, force mode with a braking demand from a
    # crawl; its wheelsets and motors stop with the train and stay
    sc = load_scenario(ROOT / "scenarios" / "paper-induction.toml")
    d = copy.deepcopy(sc.to_dict())
    d.pop("cases", None)
    d["solver"].update({"t_end": 80.0, "output_interval": 0.05})
    d["driver"] = {"mode": "force", "force_profile": [[0.0, -2e5]]}
    d["initial"] = {"speed": 1.0}
    d.pop("phases", None)
    ds = simulate(Scenario.from_dict(d, "test"))
    _, moved = _stopped_then_at_rest(ds, hold=60.0)
    assert moved < AT_REST
    _settles_where_it_stopped(ds, room=0.5)


def test_lumped_air_brake_holds_the_train():
    d = train_dict([8e4, 9e4, 9e4], force=0.0, t_end=120.0, dt=1e-3, output_interval=0.05,
                   speed=5.0, davis=DAVIS)
    for v in d["vehicles"][1:]:
        v["brake"] = {"cylinder_force": 3e4, "rigging_ratio": 6.0}
    d["driver"]["brake_profile"] = [[0.0, 1.0]]
    ds = simulate(build(d))
    _, moved = _stopped_then_at_rest(ds)
    assert moved < AT_REST


def test_fluid_air_brake_holds_the_train():
    d = fluid_train(3, [{"time": 0.5, "handle": "emergency"}], t_end=110.0, out=0.05,
                    speed=5.0)
    ds = simulate(build(d))
    _, moved = _stopped_then_at_rest(ds)
    assert moved < AT_REST


def test_a_standstill_band_beside_a_fade_speed_is_refused():
    from ltdsim.errors import ScenarioError

    d = train_dict([8e4, 6e4], force=-2e5)
    d["traction"].update({"dynamic_brake_fade": 2.0, "standstill_speed": 0.05})
    with pytest.raises(ScenarioError, match="standstill_speed has no effect with "
                                            "dynamic_brake_fade > 0"):
        build(d)


def test_a_step_too_long_for_the_fade_band_is_warned_not_refused():
    # 1e8 N of dynamic brake on an 80 t locomotive within 0.01 m/s of rest: a damper of
    # 1e10 N s/m, a lag of 8e-6 s; ode3 at 1 ms cannot settle a stop in it (the stopped
    # train would chatter within the band), a run that never stops is unaffected: warn
    from ltdsim.engine.preflight import check, warning

    d = train_dict([8e4, 6e4], force=-1e8, dt=1e-3)
    lim = check(build(d))  # not refused
    assert lim.standstill[1] == pytest.approx(8e4 * 0.01 / 1e8)
    text = warning(lim)
    assert "the dynamic brake near rest" in text and "traction.standstill_speed" in text
    # no braking demand: no band to warn of
    assert check(build(train_dict([8e4, 6e4], force=1e5, dt=1e-3))).standstill is None
