"""Every vehicle, traction, driver and brake key lands in its named column.

The check walks the schema classes' fields: each key gets a value of its own, the
scenario is lowered, and the value is looked up in the column :mod:`ltdsim.engine.layout`
names for it (or the documented formula of a derived column). A key the test does not
place, and that is not listed as used elsewhere, fails the test, so a new key cannot
be forgotten in the lowering silently.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from ltdsim.engine import layout as L
from ltdsim.engine.lowering import lower
from ltdsim.physics.air.brakes import FRICTION_CONSTANT, FRICTION_KARWATZKI, FRICTION_TABLE
from ltdsim.physics.control import METHODS
from ltdsim.scenario import PID, Brake, Davis, Traction, Vehicle, VehicleBrake

from conftest import build

#: keys that are not columns of these tables, and where they go instead
ELSEWHERE = {
    Vehicle: {"name": "labels only", "count": "expanded at validation",
              "geometry": "the curving indicators after the run (tests/results/test_curving.py)",
              "brake": "its own keys, below", "davis": "its own keys, below"},
    Traction: {"drive": "test_induction_drive_keys_land_in_their_rows",
               "motor": "test_induction_drive_keys_land_in_their_rows",
               "creep": "test_induction_drive_keys_land_in_their_rows"},
    PID: {"acceleration_of": "the demand mass, checked below"},
    Brake: {"mode": "the signal delay, checked below",
            "model": "the fluid-brake test below", "fluid": "the fluid-brake test below",
            "air": "the fluid-brake test below",
            "minimum_level": "the fluid-brake test below (a schedule's level)"},
    VehicleBrake: {"friction_table": "the table store, checked below",
                   "piston_area": "the fluid-brake test below",
                   "return_spring": "the fluid-brake test below",
                   "efficiency": "the fluid-brake test below"},
    Davis: {},
}

VEHICLES = [
    {"name": "loco", "mass": 1.31e5, "static_mass": 1.27e5, "length": 22.1, "powered": True,
     "davis": {"a": 1101.0, "b": 31.1, "c": 6.1, "v0": 0.011},
     "brake": {"cylinder_force": 40011.0, "rigging_ratio": 7.3, "shoes": 12,
               "friction": 0.31}},
    {"name": "wagon", "mass": 9.07e4, "length": 15.3,
     "davis": {"a": 902.0, "b": 12.2, "c": 3.3, "v0": 0.0},
     "brake": {"cylinder_force": 30013.0, "rigging_ratio": 6.1, "shoes": 8,
               "friction_table": [[0.0, 0.41], [20.0, 0.23]]}},
    {"name": "wagon2", "mass": 7.05e4, "static_mass": 6.9e4, "length": 13.7,
     "davis": {"a": 703.0, "b": 9.4, "c": 2.7, "v0": 0.021},
     "brake": {"cylinder_force": 20017.0, "rigging_ratio": 5.2, "shoes": 4}},
]
TRACTION = {"max_force": 4.01e5, "max_power": 6.02e6, "adhesion_mass": 3.03e5,
            "max_accel": 0.71, "max_decel": 0.83, "feedforward": True, "time_constant": 1.9,
            "jerk_limit": 0.37, "dynamic_brake_fade": 2.2}
PIDKEYS = {"kp": 1.3, "ki": 0.07, "kd": 0.011, "n": 93.0, "ts": 2e-3,
           "integrator": "backward_euler", "filter": "forward_euler", "anti_windup": True,
           "acceleration_of": "locomotive"}
BRAKE = {"mode": "pneumatic", "propagation_speed": 231.0, "apply_time_constant": 2.7,
         "release_time_constant": 11.3, "standstill_speed": 0.023, "level_step": 0.15}


def scenario_dict() -> dict:
    return copy.deepcopy({
        "solver": {"dt": 1e-3, "t_end": 1.0, "output_interval": 1e-3,
                   "stability_check": False},
        "vehicles": VEHICLES,
        "couplers": {"default": {"model": "linear", "stiffness": 5e6}},
        "traction": TRACTION,
        "brake": BRAKE,
        "driver": {"mode": "speed", "speed_profile": [[0.0, 0.0], [10.0, 5.0]],
                   "pid": PIDKEYS, "brake_controller": True},
    })


def scenario():
    return build(scenario_dict())


def col(names, key):
    return names.index(key)


def test_every_vehicle_traction_driver_and_brake_key_lands_in_its_named_column():
    sc = scenario()
    low = lower(sc)
    veh, cons, trac, drv, tables = low.veh, low.cons, low.trac, low.drv, low.ctab
    V, K, T, D = L.VEHICLE_COLUMNS, L.CONSIST_COLUMNS, L.TRACTION_SLOTS, L.DRIVER_SLOTS
    placed = {cls: set(skip) for cls, skip in ELSEWHERE.items()}
    m = np.array([v["mass"] for v in VEHICLES])

    # vehicles
    for i, v in enumerate(VEHICLES):
        row = veh[i]
        assert row[col(V, "mass")] == v["mass"]
        assert row[col(V, "weight_mass")] == v.get("static_mass", v["mass"])
        for k in ("a", "b", "c"):
            assert row[col(V, "davis_" + k)] == v["davis"][k]
        v0 = v["davis"]["v0"]
        assert row[col(V, "inv_v0")] == (1.0 / v0 if v0 > 0 else 1e12)
        assert row[col(V, "share")] == (1.0 if v.get("powered") else 0.0)
        b = v["brake"]
        full = b["cylinder_force"] * b["rigging_ratio"]
        assert row[col(V, "brake_full")] == pytest.approx(full, rel=1e-15)
        assert row[col(V, "brake_shoe")] == pytest.approx(full / b["shoes"], rel=1e-15)
        if "friction_table" in b:
            tab = np.asarray(b["friction_table"])
            assert row[col(V, "brake_friction")] == FRICTION_TABLE
            n = int(row[col(V, "brake_table_len")])
            off = int(row[col(V, "brake_table")])
            np.testing.assert_array_equal(tables[off:off + 2 * n], [*tab[:, 0], *tab[:, 1]])
        elif "friction" in b:
            assert row[col(V, "brake_friction")] == FRICTION_CONSTANT
            assert row[col(V, "brake_mu")] == b["friction"]
        else:
            assert row[col(V, "brake_friction")] == FRICTION_KARWATZKI
    # length: centres at half-length spacings behind the lead
    lengths = np.array([v["length"] for v in VEHICLES])
    np.testing.assert_allclose(-np.diff(veh[:, col(V, "p0")]),
                               0.5 * (lengths[:-1] + lengths[1:]), rtol=1e-15)
    # brake-pipe signal: from the lead at propagation_speed (pneumatic mode)
    np.testing.assert_allclose(veh[:, col(V, "brake_delay")],
                               -veh[:, col(V, "p0")] / BRAKE["propagation_speed"], rtol=1e-15)
    placed[Vehicle] |= {"mass", "static_mass", "length", "powered"}
    placed[Davis] |= {"a", "b", "c", "v0"}
    placed[VehicleBrake] |= {"cylinder_force", "rigging_ratio", "shoes", "friction"}
    placed[Brake] |= {"propagation_speed"}

    # traction: the one consist and the traction slots
    for key in ("max_force", "max_power", "adhesion_mass", "time_constant",
                "dynamic_brake_fade"):
        assert cons[0, col(K, key)] == TRACTION[key]
    for key in ("max_force", "max_power", "adhesion_mass"):
        assert trac[col(T, key)] == TRACTION[key]
    assert cons[0, col(K, "rate_limit")] == pytest.approx(TRACTION["jerk_limit"] * m.sum(),
                                                          rel=1e-15)
    # the PID demands the locomotive's acceleration: its output multiplies the lead's
    # mass, and the acceleration limits scale with the train's mass over it
    ratio = m.sum() / m[0]
    assert trac[col(T, "demand_mass")] == m[0]
    assert trac[col(T, "max_accel")] == pytest.approx(TRACTION["max_accel"] * ratio, rel=1e-15)
    assert trac[col(T, "max_decel")] == pytest.approx(TRACTION["max_decel"] * ratio, rel=1e-15)
    assert trac[col(T, "feedforward")] == 1.0
    placed[Traction] |= set(TRACTION)
    # without a fade speed, the standstill band is the dynamic brake's fade speed
    plain = {k: v for k, v in TRACTION.items() if k != "dynamic_brake_fade"}
    d0 = scenario_dict()
    d0["traction"] = dict(plain, standstill_speed=0.037)
    assert lower(build(d0)).cons[0, col(K, "dynamic_brake_fade")] == 0.037
    placed[Traction] |= {"standstill_speed"}
    placed[PID] |= {"acceleration_of"}

    # driver: the speed profile, PID and brake control (speed_profile, pid and
    # brake_controller of Driver: placed in the other test's list)
    np.testing.assert_array_equal(low.prof_t, [0.0, 10.0])
    np.testing.assert_array_equal(low.prof_y, [0.0, 5.0])
    assert drv[col(D, "mode")] == L.DRIVER_MODES.index("speed")
    for key in ("kp", "ki", "kd", "n", "ts"):
        assert drv[col(D, key)] == PIDKEYS[key]
    for key in ("integrator", "filter"):
        assert drv[col(D, key)] == METHODS[PIDKEYS[key]]
    assert drv[col(D, "anti_windup")] == 1.0
    assert drv[col(D, "brake_controller")] == 1.0
    for key, slot in (("level_step", "brake_step"), ("apply_time_constant", "apply_tau"),
                      ("release_time_constant", "release_tau"),
                      ("standstill_speed", "standstill_speed")):
        assert drv[col(D, slot)] == BRAKE[key]
    shoes = [v["brake"]["cylinder_force"] * v["brake"]["rigging_ratio"] / v["brake"]["shoes"]
             for v in VEHICLES]
    assert drv[col(D, "shoe_force_ref")] == pytest.approx(np.mean(shoes), rel=1e-15)
    assert drv[col(D, "full_shoe_sum")] == pytest.approx(
        sum(v["brake"]["cylinder_force"] * v["brake"]["rigging_ratio"] for v in VEHICLES),
        rel=1e-15)
    placed[PID] |= {"kp", "ki", "kd", "n", "ts", "integrator", "filter", "anti_windup"}
    placed[Brake] |= {"level_step", "apply_time_constant", "release_time_constant",
                      "standstill_speed"}
    # a calibration takes the lumped keys from the valve preset's [lumped] table (the
    # keys given beside it win); an emergency command asks for emergency_level
    from ltdsim.data import load_preset
    from ltdsim.engine.lowering import brake_schedule

    table = load_preset("brakes", "aar")["lumped"]
    d1 = scenario_dict()
    d1["brake"] = {"calibration": "aar", "release_time_constant": 7.5}
    d1["driver"] = dict(d1["driver"], brake_commands=[{"time": 1.0, "handle": "emergency"}])
    sc1 = build(d1)
    low1 = lower(sc1)
    assert low1.drv[col(D, "apply_tau")] == table["apply_time_constant"]
    assert low1.drv[col(D, "release_tau")] == 7.5
    np.testing.assert_allclose(low1.veh[:, col(V, "brake_delay")],
                               -low1.veh[:, col(V, "p0")] / table["propagation_speed"],
                               rtol=1e-15)
    assert [r[1] for r in brake_schedule(sc1, "time", None)] == [table["emergency_level"]]
    placed[Brake] |= {"calibration", "emergency_level"}

    missing = {cls.__name__: sorted(set(cls.model_fields) - keys)
               for cls, keys in placed.items() if set(cls.model_fields) - keys}
    assert not missing, f"schema keys this test does not place: {missing}"


def test_table_widths_follow_their_column_names():
    for names, width in ((L.VEHICLE_COLUMNS, L.N_VCOL), (L.CONSIST_COLUMNS, L.N_KCOL),
                         (L.TRACTION_SLOTS, L.N_TRAC), (L.DRIVER_SLOTS, L.N_DRV)):
        assert width == len(names) == len(set(names))
    low = lower(scenario())
    assert low.veh.shape[1] == L.N_VCOL and low.cons.shape[1] == L.N_KCOL
    assert low.trac.shape == (L.N_TRAC,) and low.drv.shape == (L.N_DRV,)


def test_locomotive_track_solver_driver_and_initial_keys_land_in_their_places():
    from ltdsim.scenario import Driver, Initial, Locomotive, Solver, Track

    masses = [1.2e5, 1.1e5, 8e4, 1.15e5, 7e4]
    vehicles = [{"name": f"v{i}", "mass": m, "length": 20.0 + i, "powered": i in (0, 3),
                 "brake": {"cylinder_force": 3e4, "rigging_ratio": 6.0}}
                for i, m in enumerate(masses)]
    locos = [{"name": "lead", "vehicles": [0], "max_force": 3.1e5, "time_constant": 1.3,
              "jerk_limit": 0.21},
             {"name": "mid", "vehicles": [3], "max_power": 4.4e6, "adhesion_mass": 1.7e5,
              "time_constant": 0.0, "jerk_limit": 0.0,
              "notch_profile": [[0.0, 2.0], [5.0, -3.0]],
              "brake_control": True}]
    track = {"gradient": [[0.0, 0.0], [130.0, 0.004]], "curve": [[0.0, 0.0], [70.0, 450.0]],
             "curve_h": 610.0, "gravity": 9.79}
    solver = {"method": "bs23", "dt": 2e-4, "t_end": 3.0, "output_interval": 2e-3,
              "rtol": 3e-6, "atol": 2e-7, "max_step": 0.03, "air_max_step": 0.7}
    initial = {"velocities": [1.1, 1.2, 1.3, 1.4, 1.5], "couplers": "bunched"}
    driver = {"mode": "notch", "notch_profile": [[0.0, 3.0], [2.0, 5.0]],
              "brake_profile": [[1.0, 0.5]], "brake_positions": [[40.0, 0.7]],
              "brake_commands": [{"time": 2.5, "handle": "full"},
                                 {"position": 60.0, "handle": "release"}]}
    sc = build({"solver": solver, "vehicles": vehicles, "locomotives": locos,
                "couplers": {"default": {"model": "linear", "stiffness": 5e6, "slack": 0.02}},
                "traction": {"max_force": 4e5, "max_power": 5e6, "adhesion_mass": 2e5,
                             "time_constant": 0.9, "jerk_limit": 0.5},
                "track": track, "driver": driver, "initial": initial})
    low = lower(sc)
    K, V, T, D = L.CONSIST_COLUMNS, L.VEHICLE_COLUMNS, L.TRACTION_SLOTS, L.DRIVER_SLOTS
    cons, tables = low.cons, low.ctab
    # locomotives: own keys, the rest from [traction]
    assert cons[0, col(K, "max_force")] == 3.1e5 and cons[1, col(K, "max_force")] == 4e5
    assert cons[0, col(K, "max_power")] == 5e6 and cons[1, col(K, "max_power")] == 4.4e6
    assert cons[0, col(K, "adhesion_mass")] == 2e5
    assert cons[1, col(K, "adhesion_mass")] == 1.7e5
    assert cons[0, col(K, "time_constant")] == 1.3 and cons[1, col(K, "time_constant")] == 0.0
    assert cons[0, col(K, "lag_state")] >= 0 and cons[1, col(K, "lag_state")] == -1
    share = 3.1e5 / (3.1e5 + 4e5)  # of the force sum: the jerk limit's share
    assert cons[0, col(K, "rate_limit")] == pytest.approx(0.21 * sum(masses) * share,
                                                          rel=1e-14)
    assert [cons[k, col(K, "speed_vehicle")] for k in (0, 1)] == [0, 3]
    assert low.veh[3, col(V, "consist")] == 1 and low.veh[3, col(V, "share")] == 1.0
    n, off = int(cons[1, col(K, "notch_len")]), int(cons[1, col(K, "notch_offset")])
    np.testing.assert_array_equal(tables[off:off + 2 * n], [0.0, 5.0, 2.0, -3.0])
    assert cons[0, col(K, "notch_len")] == 0  # the lead follows the driver
    # brake_control: the mid locomotive is a control point; the signal reaches vehicle 4
    # from it, not from the lead
    p0 = low.p0
    assert low.veh[4, col(V, "brake_delay")] == pytest.approx((p0[3] - p0[4]) / 250.0,
                                                              rel=1e-14)
    # track: grade and curvature on merged breakpoints; curve constant; gravity
    np.testing.assert_array_equal(low.track_pos, [0.0, 70.0, 130.0])
    np.testing.assert_array_equal(low.track_grade, [0.0, 0.0, 0.004])
    np.testing.assert_array_equal(low.track_curv, [0.0, 1 / 450.0, 1 / 450.0])
    assert low.curve_h == 610.0 and low.trac[col(T, "gravity")] == 9.79
    # solver
    assert low.adaptive and low.dt == 2e-4 and low.max_step == 0.03 and low.air_max_step == 0.7
    assert low.record_every == 10 and low.n_steps == 15000  # 3 s / 2e-4 s
    nv = len(masses)
    assert (low.rtol[:nv] == 0.0).all() and (low.rtol[nv:] == 3e-6).all()
    assert (low.atol[:nv] == 2e-7).all()  # positions: atol
    assert low.atol[nv:2 * nv] == pytest.approx(2e-6)  # vehicle speeds: 10 x atol
    assert low.atol[low.cons[0, col(K, "lag_state")].astype(int)] == pytest.approx(2e-7 * 1e6)
    # speed_atol: the speeds held to it alone, the other states' tolerances unchanged
    held = lower(sc.with_overrides({"solver.speed_atol": 3e-5}))
    assert (held.atol[nv:2 * nv] == 3e-5).all() and (held.rtol[nv:2 * nv] == 0.0).all()
    rest = np.r_[0:nv, 2 * nv:len(low.atol)]
    np.testing.assert_array_equal(held.atol[rest], low.atol[rest])
    np.testing.assert_array_equal(held.rtol[rest], low.rtol[rest])
    # hold_speed: the speed the kernel holds couplings below (0: none); which couplings,
    # and up to what force, tests/engine/test_held_edges.py
    assert lower(sc.with_overrides({"solver.hold_speed": 2e-3})).hold_speed == 2e-3
    assert low.hold_speed == 0.0
    # driver: notch mode and its profile; brake schedule and position triggers
    assert low.drv[col(D, "mode")] == L.DRIVER_MODES.index("notch")
    np.testing.assert_array_equal(low.prof_t, [0.0, 2.0])
    np.testing.assert_array_equal(low.prof_y, [3.0, 5.0])
    # (each a column after the other: time or position, level, kind, value; the lumped
    # brake takes a handle as a level)
    for key, pts in (("brake_schedule", [1.0, 2.5, 0.5, 1.0]),
                     ("brake_positions", [40.0, 60.0, 0.7, 0.0])):
        off, n = int(low.drv[col(D, key)]), int(low.drv[col(D, key + "_len")])
        assert n == 2
        np.testing.assert_array_equal(tables[off:off + 4], pts)
        np.testing.assert_array_equal(tables[off + 4:off + 8], [L.CMD_LEVEL] * 2 + [0.0] * 2)
    # initial: speeds per vehicle, couplers at the buff end of their slack
    np.testing.assert_array_equal(low.y0[nv:2 * nv], initial["velocities"])
    np.testing.assert_array_equal(low.d0, -0.01)
    # initial speed of the whole train; a force profile
    other = sc.with_overrides({"initial.velocities": None, "initial.speed": 2.5,
                               "driver.mode": "force",
                               "driver.force_profile": [[0.0, 1e5], [1.0, -2e4]],
                               "driver.brake_profile": None, "driver.brake_positions": None,
                               "driver.brake_commands": None})
    low2 = lower(other)
    np.testing.assert_array_equal(low2.y0[nv:2 * nv], 2.5)
    assert low2.drv[col(D, "mode")] == L.DRIVER_MODES.index("force")
    np.testing.assert_array_equal(low2.prof_t, [0.0, 1.0])
    np.testing.assert_array_equal(low2.prof_y, [1e5, -2e4])
    # solver.record: the widths of the kernel's record arrays (0: not recorded)
    import importlib
    sim = importlib.import_module("ltdsim.engine.run")
    sel = sc.with_overrides({"solver.record": ["coupler_force", "velocity"]})
    rec = sim._buffers(lower(sel), 3, sim.recorded(sel))[0]
    assert rec["f"].shape == (3, nv - 1) and rec["v"].shape == (3, nv)
    assert rec["x"].shape[1] == rec["a"].shape[1] == rec["d"].shape[1] == 0
    assert sim._buffers(lower(sc), 3, sim.recorded(sc))[0]["x"].shape == (3, nv)
    # solver.energy: under bs23 (this scenario) states among the mechanical ones, out of
    # the error norm; with a fixed step no states (the work is summed step by step in the
    # work arrays); recorded with the kinetic energy either way; off, none of it
    ne = L.N_ENERGY + nv - 1
    assert low.trac[col(T, "energy_state")] == -1 and not low.energy
    on = sc.with_overrides({"solver.energy": True})
    counted = lower(on)
    ez = int(counted.trac[col(T, "energy_state")])
    assert counted.energy and counted.y0.size == low.y0.size + ne
    assert (counted.y0[ez:ez + ne] == 0.0).all() and np.isinf(counted.atol[ez:ez + ne]).all()
    assert (counted.rtol[ez:ez + ne] == 0.0).all()
    fixed = on.with_overrides({"solver.method": "ode3"})
    lf = lower(fixed)
    assert lf.trac[col(T, "energy_state")] == -1 and lf.y0.size == lower(
        sc.with_overrides({"solver.method": "ode3"})).y0.size
    rec, *_, common = sim._buffers(lf, 3, sim.recorded(fixed))
    assert rec["e"].shape == (3, ne + 1) and common[3].energy.shape == (ne,)
    assert sim._buffers(low, 3, sim.recorded(sc))[5][3].energy.shape == (0,)
    placed = {
        Driver: {"mode", "notch_profile", "brake_profile", "brake_positions",
                 "force_profile", "speed_profile", "pid", "brake_controller",
                 "brake_commands"},
        Locomotive: {"name", "vehicles", "max_force", "max_power", "adhesion_mass",
                     "time_constant", "jerk_limit", "notch_profile", "brake_control",
                     "drive"},  # (drive: test_induction_drive_keys_land_in_their_rows)
        # the plane alignment: tests/results/test_curving.py (the curve resistance reads
        # transitions and profile through Track.resistance_curve, checked there)
        Track: set(track) | {"transitions", "cant", "profile", "profile_file",
                             "rail_spacing"},
        Solver: set(solver) | {"stability_check", "record", "energy", "energy_interval",
                               "speed_atol", "hold_speed"},
        #       (a check at validation; energy just above; energy_interval below)
        Initial: {"speed", "velocities", "couplers"},
    }
    for cls, keys in placed.items():
        assert set(cls.model_fields) <= keys, (cls.__name__, set(cls.model_fields) - keys)
    # energy_interval: 4 ms under a fixed 0.2 ms step with records every 2 ms -> every 10
    fixed = sc.with_overrides({"solver.method": "ode3", "solver.energy": True,
                               "solver.energy_interval": 4e-3})
    assert lower(fixed).energy_every == 10 and lower(fixed).record_every == 10


def test_every_fluid_brake_key_lands_in_its_column_or_row():
    """brake.model = "fluid": the vehicle's cylinder keys, [brake.fluid] and [brake.air]
    in the vehicle table, the gas row, the pipe grid and the valve rows; the lumped
    brake's minimum_level in its schedule."""
    from ltdsim.physics.air.brakevalves import CV_PARAMS, DV_PARAMS
    from ltdsim.scenario import Air, FluidBrake

    d = scenario_dict()
    d["vehicles"][1]["brake"].update(piston_area=0.071, return_spring=1503.0,
                                     efficiency=0.83)
    air = {"gamma": 1.39, "gas_constant": 287.5, "temperature": 280.0,
           "atmosphere": 99000.0, "linear_ratio": 0.99, "viscosity": 1.7e-5,
           "thermal": "adiabatic", "conductivity": 0.031}
    fluid = {"valve": {"preset": "uic-g", "control_valve": {"auxiliary_volume": 0.0917,
                                                            "branch_volume": 1.7e-3}},
             "pipe_diameter": 0.0333, "cells_per_vehicle": 3, "roughness": 5.1e-5,
             "leakage": 3.3e-7, "regulated_pressure": 4.9e5, "hose_volume": 3.1e-4}
    d["brake"] = {"model": "fluid", "fluid": fluid, "air": air, "level_step": 0.1}
    low = lower(build(d))
    V = L.VEHICLE_COLUMNS
    veh = low.veh
    b1 = d["vehicles"][1]["brake"]
    row = veh[1]
    assert row[col(V, "piston_area")] == b1["piston_area"]
    assert row[col(V, "return_spring")] == b1["return_spring"]
    assert row[col(V, "brake_gain")] == pytest.approx(0.83 * b1["rigging_ratio"], rel=1e-15)
    assert row[col(V, "inv_shoes")] == 1.0 / b1["shoes"]
    p_fs = row[col(V, "full_service_pressure")]
    assert p_fs == 3.8e5  # the uic-g preset's max_cylinder
    # piston_area left out: derived so that the full service gives cylinder_force
    b0 = d["vehicles"][0]["brake"]
    assert veh[0, col(V, "piston_area")] * p_fs == pytest.approx(b0["cylinder_force"],
                                                                  rel=1e-15)
    assert low.drv[col(L.DRIVER_SLOTS, "brake_model")] == L.BRAKE_FLUID
    gas = low.air_gas
    for key, slot in (("gamma", "gamma"), ("gas_constant", "r_gas"),
                      ("temperature", "temperature"), ("atmosphere", "atmosphere"),
                      ("linear_ratio", "r_lin"), ("viscosity", "viscosity"),
                      ("conductivity", "conductivity")):
        assert gas[col(L.AIR_SLOTS, slot)] == air[key]
    from ltdsim.physics.air.brakepipe import THERMAL_MODES
    assert THERMAL_MODES[int(gas[col(L.AIR_SLOTS, "thermal")])] == air["thermal"]
    assert gas[col(L.AIR_SLOTS, "diameter")] == fluid["pipe_diameter"]
    assert gas[col(L.AIR_SLOTS, "roughness")] == fluid["roughness"]
    lengths = [v["length"] for v in VEHICLES]
    np.testing.assert_allclose(low.pipe_dx_cell, np.repeat(np.array(lengths) / 3, 3),
                               rtol=1e-15)
    np.testing.assert_allclose(low.pipe_leak, fluid["leakage"] / 3, rtol=1e-15)
    # every (braked) vehicle's hoses and branch, a third in each of its cells
    area = np.pi * fluid["pipe_diameter"] ** 2 / 4
    np.testing.assert_allclose(low.pipe_volume, area * low.pipe_dx_cell + (3.1e-4 + 1.7e-3) / 3,
                               rtol=1e-14)
    zp, nc = low.air_index[0], low.air_index[1]
    assert nc == 3 * len(VEHICLES)
    np.testing.assert_array_equal(low.y0[zp:zp + nc], air["atmosphere"] + 4.9e5)
    # the pipe's densities after its face flows: the charged air at the temperature
    np.testing.assert_allclose(low.y0[zp + 2 * nc - 1:zp + 3 * nc - 1],
                               (air["atmosphere"] + 4.9e5) / (287.5 * 280.0), rtol=1e-15)
    assert low.cv_rows[0, CV_PARAMS.index("auxiliary_volume")] == 0.0917
    assert low.dv_rows[0, DV_PARAMS.index("regulated")] == 4.9e5
    placed = {FluidBrake: set(fluid), Air: set(air)}
    missing = {cls.__name__: sorted(set(cls.model_fields) - keys)
               for cls, keys in placed.items() if set(cls.model_fields) - keys}
    assert not missing, f"schema keys this test does not place: {missing}"


def test_minimum_handle_is_the_lumped_brake_s_minimum_level():
    d = scenario_dict()
    d["brake"] = dict(BRAKE, minimum_level=0.31)
    d["driver"]["brake_commands"] = [{"time": 2.0, "handle": "minimum"}]
    low = lower(build(d))
    o, m = int(low.drv[col(L.DRIVER_SLOTS, "brake_schedule")]), int(
        low.drv[col(L.DRIVER_SLOTS, "brake_schedule_len")])
    assert m == 1 and low.ctab[o] == 2.0 and low.ctab[o + m] == 0.31


def test_induction_drive_keys_land_in_their_rows():
    """traction.drive = "induction": each [traction.motor] and [traction.creep] key in
    its parameter row, the drive's states before the brakes' with the magnetised,
    rolling initial state."""
    import math

    from ltdsim.scenario.creep import Wheelset
    from ltdsim.physics.drive import creep as cr
    from ltdsim.physics.drive import foc
    from ltdsim.physics.drive.induction import MP_LM, MP_RS

    d = scenario_dict()
    d["traction"] = {**TRACTION, "drive": "induction",
                     "motor": {"preset": "study-850kw", "per_locomotive": 4,
                               "stator_resistance": 0.0211, "max_current": 333.0},
                     "creep": {"rail": {"preset": "wet", "mu0": 0.27},
                               "wheelset": {"axles": 5, "wheel_radius": 0.55,
                                            "gear_ratio": 4.4, "gear_efficiency": 0.96,
                                            "inertia": 210.0, "v_reg": 0.8},
                               "slip_control": {"enabled": False, "w_set": 0.21,
                                                "w_slope": 0.03, "bandwidth": 15.0,
                                                "recovery_time": 3.0}}}
    d["initial"] = {"speed": 2.5}
    low = lower(build(d))
    assert low.drive_of.tolist() == [0]
    z = int(low.drive_z[0])
    assert 0 <= z and z + 9 <= min(int(b) for b in low.veh[:, L.V_BZ] if b >= 0)
    assert low.drive_motor[0, MP_RS] == 0.0211
    assert low.drive_ctrl[0, foc.C_IMAX] == pytest.approx(333.0 * math.sqrt(6), rel=1e-15)
    assert low.drive_rail[0, cr.CR_MU0] == 0.27 and low.drive_rail[0, cr.CR_KA] == 0.30
    ws = low.drive_ws[0]
    assert ws[cr.WS_Q] == pytest.approx(1.27e5 * 9.81 / 10, rel=1e-15)  # static mass, 5 axles
    assert ws[cr.WS_R] == 0.55 and ws[cr.WS_I] == 4.4 and ws[cr.WS_VREG] == 0.8
    assert ws[cr.WS_J] == pytest.approx(210.0 + 4.4 ** 2 * 50.0, rel=1e-15)
    misc = low.drive_misc[0]
    assert misc[L.DM_MOTORS] == 4 and misc[L.DM_PER_LOCO] == 4  # one powered vehicle
    assert misc[L.DM_GEAR_EFF] == 0.96 and misc[L.DM_SLIP_ON] == 0.0
    assert misc[L.DM_VDC] == 2180.0 and misc[L.DM_FADE] == TRACTION["dynamic_brake_fade"]
    sp = low.drive_slip[0]
    assert sp[cr.SL_WSET] == 0.21 and sp[cr.SL_WSLOPE] == 0.03
    assert sp[cr.SL_TRACK] == 15.0
    assert sp[cr.SL_GAIN] == pytest.approx(ws[cr.WS_J] * 15.0 / 0.55, rel=1e-15)
    y0 = low.y0[z:z + 9]
    assert y0[foc.FOC_FLUX] == pytest.approx(y0[2], rel=1e-15)  # rotor flux on d, at rated
    assert y0[2] / low.drive_motor[0, MP_LM] > 0.0
    assert y0[7] == pytest.approx(2.5 / 0.55, rel=1e-15)  # the wheel rolls with the train
    assert y0[8] == pytest.approx(sp[cr.SL_RECOV] * 3.0, rel=1e-12)  # the largest torque
    assert Wheelset().axles == 6  # (the default the docs quote)
    # a consist's own drive wins over [traction]'s
    d["locomotives"] = [{"name": "lead", "vehicles": [0], "drive": "curve"}]
    low = lower(build(d))
    assert low.drive_of.tolist() == [-1] and low.drive_z.size == 0
    d["traction"]["drive"] = "curve"
    d["locomotives"][0]["drive"] = "induction"
    assert lower(build(d)).drive_of.tolist() == [0]
