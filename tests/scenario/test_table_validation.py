"""The valve, motor and creep tables validated by the schema (issue 37): strict types, each
key's physical range with its unit, the relations a designer checks between the keys; a
drive faster than the step named as such; no propagation speed for one vehicle.

Every refusal is checked against numbers worked out here from the presets' own values
(Boyle's law, the inverter's apparent power, the T equivalent circuit), not read back
from the code under test.
"""

from __future__ import annotations

import cmath
import copy
import glob
import math
import re
from pathlib import Path

import pytest

import ltdsim
from ltdsim.data import load_preset, preset_names
from ltdsim.errors import ScenarioError, SimulationError

from conftest import build, fluid_train

ROOT = Path(__file__).resolve().parents[2]
V = "brake.fluid.valve"


def _fluid(valve, **fluid):
    d = fluid_train(2, [{"time": 1.0, "handle": "full"}])
    d["brake"]["fluid"] = {"valve": copy.deepcopy(valve), **fluid}
    return d


def _refused(d) -> str:
    with pytest.raises(ScenarioError) as e:
        build(d)
    text = str(e.value)
    assert "\n" not in text.strip(), text
    return text


# ------------------------------------------------------------- every shipped table
def test_every_shipped_scenario_sweep_and_preset_loads():
    from ltdsim.scenario import FluidBrake, valve_tables
    from ltdsim.scenario.creep import RailCondition
    from ltdsim.scenario.motor import load_motor
    from ltdsim.sweep.core import load_sweep

    files = sorted(glob.glob(str(ROOT / "scenarios" / "*.toml")))
    assert len(files) >= 10
    for f in files:
        text = Path(f).read_text(encoding="utf-8")
        if re.search(r"^\[sweep\]|^scenario\s*=", text, re.M):
            assert load_sweep(f).cases
        else:
            ltdsim.load_scenario(f)
    for name in preset_names("brakes"):
        valve_tables(FluidBrake(valve=name))
    for name in preset_names("motors"):
        load_motor(name)
    for name in preset_names("creep"):
        RailCondition(preset=name)


# ------------------------------------------------------- valve tables: types, ranges
@pytest.mark.parametrize("table, key, value", [
    ("control_valve", "threshold", True),          # was read as 1 Pa
    ("control_valve", "auxiliary_volume", True),   # was read as 1 m^3
    ("control_valve", "apply_diameter", True),     # was read as a 1 m orifice
    ("control_valve", "band", "3000"),             # was read as 0
    ("driver_valve", "regulated", "5e5"),
    ("driver_valve", "main_volume", False),
])
def test_valve_keys_refuse_booleans_and_strings(table, key, value):
    text = _refused(_fluid({"preset": "aar", table: {key: value}}))
    assert f"{V}.{table}.{key}: must be a number" in text
    assert "not true/false" in text


@pytest.mark.parametrize("table, key, value, allowed", [
    # the review's 10,000 bar pipe (printed as "propagation 2926 m/s")
    ("driver_valve", "regulated", 1e9, "300000 Pa (3 bar) gauge to 1e+06 Pa (10 bar) gauge"),
    ("driver_valve", "regulated", 2e5, "300000 Pa (3 bar) gauge to 1e+06 Pa (10 bar) gauge"),
    ("driver_valve", "main_initial", 2e6, "to 1.2e+06 Pa (12 bar) gauge"),
    # the review's 20 bar cylinder
    ("control_valve", "max_cylinder", 20e5, "to 1e+06 Pa (10 bar) gauge (or 0: none)"),
    ("control_valve", "auxiliary_volume", 10.0, "0.001 m^3 to 0.5 m^3"),
    ("control_valve", "apply_diameter", 0.2, "0.0001 m to 0.05 m (or 0: none)"),
    ("control_valve", "piston_time", 1e-6, "0.001 s to 10 s"),
    ("control_valve", "discharge_coefficient", 1.2, "0.5 to 1, got 1.2"),
    ("driver_valve", "compressor_flow", 5.0, "0 kg/s to 1 kg/s"),
])
def test_valve_keys_out_of_range_name_the_range_with_units(table, key, value, allowed):
    text = _refused(_fluid({"preset": "uic-g", table: {key: value}}))
    assert f"{V}.{table}.{key}: must be within" in text and allowed in text, text
    assert "got " in text


def test_a_valve_table_refuses_an_unknown_key_naming_the_allowed_ones():
    text = _refused(_fluid({"preset": "aar", "control_valve": {"charge_cda": 1e-6}}))
    assert f"{V}.control_valve.charge_cda: unknown key; allowed:" in text
    assert "charge_diameter" in text


def test_regulated_pressure_key_has_the_pipe_range():
    text = _refused(_fluid("uic-g", regulated_pressure=1.2e6))
    assert "brake.fluid.regulated_pressure" in text and "1000000" in text


# ------------------------------------------------------------ valve tables: relations
def _equalisation(preset, regulated=None):
    """Boyle's law at constant temperature, gauge pressures: the auxiliary reservoir at the
    pipe's regulated pressure shares its air with the empty cylinder."""
    cv, dv = preset["control_valve"], preset["driver_valve"]
    p = dv["regulated"] if regulated is None else regulated
    va, vc = cv["auxiliary_volume"], cv["cylinder_volume"]
    # (p_eq - 0) (V_aux + V_cyl) = p V_aux + 0 V_cyl  (atmosphere cancels in gauge terms)
    return p * va / (va + vc)


def test_max_cylinder_above_the_equalisation_is_refused():
    preset = load_preset("brakes", "uic-g")
    p_eq = _equalisation(preset)                       # 5 bar x 100 / 120 l = 4.17 bar
    assert p_eq == pytest.approx(4.1667e5, rel=1e-4)
    build(_fluid({"preset": "uic-g", "control_valve": {"max_cylinder": 0.99 * p_eq}}))
    text = _refused(_fluid({"preset": "uic-g", "control_valve": {"max_cylinder": 1.01 * p_eq}}))
    assert "control_valve.max_cylinder (4.21 bar) must not exceed" in text
    # the key once, as the validator names it (not "brake: brake.fluid.valve: ...")
    assert ": brake.fluid.valve: control_valve.max_cylinder" in text, text
    assert "brake: brake." not in text, text
    assert ("p_eq = driver_valve.regulated x auxiliary_volume / (auxiliary_volume + "
            "cylinder_volume) = 5 bar x 0.1 / (0.1 + 0.02) m^3 = 4.17 bar") in text
    # a smaller reservoir (50 l: 3.57 bar), or a lower pipe (4.5 bar: 3.75 bar), under 3.8
    small = copy.deepcopy(preset)
    small["control_valve"]["auxiliary_volume"] = 0.05
    text = _refused(_fluid({"preset": "uic-g", "control_valve": {"auxiliary_volume": 0.05}}))
    assert f"0.05 / (0.05 + 0.02) m^3 = {_equalisation(small) / 1e5:.3g} bar" in text
    text = _refused(_fluid("uic-g", regulated_pressure=4.5e5))
    assert f"{_equalisation(preset, 4.5e5) / 1e5:.3g} bar" in text and "max_cylinder" in text


@pytest.mark.parametrize("valve, relation", [
    ({"preset": "uic-g", "control_valve": {"control_cutoff": 2.9e5, "max_cylinder": 2.5e5}},
     "control_valve.control_cutoff (2.9 bar) must be below control_valve.max_cylinder (2.5 bar)"),
    ({"preset": "uic-g", "control_valve": {"full_drop": 2e5}},
     "control_valve.full_drop (2 bar) must not exceed driver_valve.full_reduction (1.5 bar)"),
    ({"preset": "uic-p", "control_valve": {"quick_service_limit": 2.9e5, "max_cylinder": 2.5e5}},
     "control_valve.quick_service_limit (2.9 bar) must be below the full-service cylinder "
     "pressure (2.5 bar)"),
    ({"preset": "aar", "driver_valve": {"minimum_reduction": 0.05e5}},
     "driver_valve.minimum_reduction (0.05 bar) must exceed control_valve.threshold (0.103 bar)"),
    ({"preset": "aar", "control_valve": {"trip": 4.5e5, "trip_band": 0.6e5},
      "driver_valve": {"regulated": 4e5}},
     "control_valve.trip + trip_band (5.1 bar) must be below driver_valve.regulated (4 bar)"),
    ({"preset": "aar", "driver_valve": {"compressor_flow": 0.05, "cut_in": 5e5, "cut_out": 9e5,
                                        "governor_band": 1e4, "governor_time": 0.5}},
     "driver_valve.cut_in (5 bar) must exceed driver_valve.regulated (6.21 bar)"),
    ({"preset": "aar", "driver_valve": {"main_initial": 6e5}},
     "driver_valve.main_initial must exceed driver_valve.regulated"),
])
def test_valve_relations_name_the_keys(valve, relation):
    assert relation in _refused(_fluid(valve))


def test_aar_quick_service_limit_against_its_full_service_cylinder():
    """AAR: the full service moves the reduction's air, r V_aux / V_cyl, at most p_eq."""
    preset = load_preset("brakes", "aar")
    cv, dv = dict(preset["control_valve"]), preset["driver_valve"]
    cv["cylinder_volume"] = 0.1        # a big cylinder: 1.79 bar x 41 / 100 l = 0.73 bar
    full = min(dv["full_reduction"] * cv["auxiliary_volume"] / 0.1,
               _equalisation({"control_valve": cv, "driver_valve": dv}))
    assert full == pytest.approx(0.7345e5, rel=1e-3)
    ok = {"preset": "aar", "control_valve": {"cylinder_volume": 0.1,
                                             "quick_service_limit": 0.95 * full}}
    build(_fluid(ok))
    bad = {"preset": "aar", "control_valve": {"cylinder_volume": 0.1,
                                              "quick_service_limit": 1.05 * full}}
    assert (f"must be below the full-service cylinder pressure ({full / 1e5:.3g} bar)"
            in _refused(_fluid(bad)))


# ----------------------------------------------------------------------- the motor
def _induction(**motor):
    s = ltdsim.load_scenario(ROOT / "scenarios" / "paper-induction.toml")
    return s.with_overrides({f"traction.motor.{k}": v for k, v in motor.items()})


def _motor_refused(**motor) -> str:
    with pytest.raises(ScenarioError) as e:
        _induction(**motor)
    text = str(e.value)
    assert "\n" not in text and text.startswith("override: traction.motor: "), text
    return text


@pytest.mark.parametrize("key, value, message", [
    ("dc_link_voltage", 1.0, "dc_link_voltage: must be within 100 V to 10000 V, got 1 V"),
    ("magnetising_inductance", 1e-9,
     "magnetising_inductance: must be within 0.0001 H to 10 H, got 1e-09 H"),
    ("stator_leakage_inductance", 1e-9, "stator_leakage_inductance: must be within 1e-06 H"),
    ("rotor_inertia", 1e-9, "rotor_inertia: must be within 0.01 kg m^2 to 1000 kg m^2"),
    ("base_speed", 1.0, "base_speed: must be within 100 rpm to 20000 rpm, got 1 rpm"),
    ("current_bandwidth", 1e5, "current_bandwidth: must be within 1 Hz to 5000 Hz"),
    ("rated_power", True, "rated_power: must be a number"),
    ("rated_power", "1e6", "rated_power: must be a number"),
    ("pole_pairs", 2.0, "pole_pairs: must be a whole number"),
])
def test_motor_keys_in_range_with_units(key, value, message):
    assert message in _motor_refused(**{key: value})


def _apparent_power_limit(motor, current):
    """0.95 x sqrt(3) x U_line x I_line: U_line the rms line voltage of the space-vector
    limit (phase peak V_dc / sqrt(3), so line peak V_dc), the winding current x sqrt(3)
    in delta."""
    u_line = motor["dc_link_voltage"] / math.sqrt(2.0)
    i_line = current * (math.sqrt(3.0) if motor["connection"] == "delta" else 1.0)
    return 0.95 * math.sqrt(3.0) * u_line * i_line


def test_rated_power_against_voltage_and_current():
    m = load_preset("motors", "study-850kw")
    limit = _apparent_power_limit(m, m["max_current"])  # 2180 V, 310 A delta: 1.362 MW
    assert limit == pytest.approx(1.362e6, rel=1e-3) and m["rated_power"] < limit
    _induction(rated_power=0.99 * limit)
    text = _motor_refused(rated_power=1.01 * limit)
    assert f"rated_power ({1.01 * limit:g} W) is more than the inverter can feed" in text
    assert f"= {limit:.4g} W" in text and "dc_link_voltage / sqrt(2) = 1541 V" in text
    assert "max_current 310 A rms winding x sqrt(3) = 536.9 A rms line (delta)" in text
    # the review's 10 MW at 1 A; the study's currents read as star (the preset explains)
    assert "rated_power (1e+07 W) is more" in _motor_refused(
        rated_power=1e7, rated_current=1.0, max_current=1.0)
    assert "310 A rms line (star)" in _motor_refused(connection="star")
    # the stiff scenario's raised limit, 1.2333 MW at 363 A, is within it
    ltdsim.load_scenario(ROOT / "scenarios" / "paper-induction-stiff.toml")


def _magnetising_current(m, lm):
    """The rotor flux over L_m at the rated point, A peak, from the T equivalent circuit
    written out here (star-equivalent phase, peak values)."""
    p = m["pole_pairs"]
    we = p * m["base_speed"] * math.pi / 30.0 / (1.0 - m["rated_slip"])
    v = m["voltage_margin"] * m["dc_link_voltage"] / math.sqrt(3.0)
    s = m["rated_slip"]
    z_rotor = m["rotor_resistance"] / s + 1j * we * m["rotor_leakage_inductance"]
    z_mag = 1j * we * lm
    i_s = v / (m["stator_resistance"] + 1j * we * m["stator_leakage_inductance"]
               + z_mag * z_rotor / (z_mag + z_rotor))
    i_m = i_s * z_rotor / (z_mag + z_rotor)           # the magnetising branch's current
    i_r = i_m - i_s
    psi_r = lm * i_m + m["rotor_leakage_inductance"] * i_r
    return abs(psi_r) / lm, cmath.phase(i_s)


def test_magnetising_inductance_against_the_rated_current():
    m = load_preset("motors", "study-850kw")
    i_rated = m["rated_current"] * math.sqrt(3.0) * math.sqrt(2.0)   # delta, peak: 661 A
    i_d0, _ = _magnetising_current(m, m["magnetising_inductance"])
    assert 0.4 < i_d0 / i_rated < 0.6                  # the preset magnetises with 52 %
    i_d0, _ = _magnetising_current(m, 1e-3)             # 1 mH: 2382 A, 3.6 x rated
    text = _motor_refused(magnetising_inductance=1e-3)
    assert f"= {i_d0:.4g} A peak at the rated point" in text
    assert f"not below the rated current {i_rated:.4g} A peak" in text
    assert "magnetising_inductance (0.001 H)" in text and "rated_current 270 A" in text


def test_leakage_against_the_rated_torque():
    m = load_preset("motors", "study-850kw")
    t_rated = m["rated_power"] / (m["base_speed"] * math.pi / 30.0)     # 6327 N m
    text = _motor_refused(stator_leakage_inductance=1e-2, rotor_leakage_inductance=1e-2)
    assert "stator_leakage_inductance and rotor_leakage_inductance (0.01 and 0.01 H)" in text
    assert f"below the rated torque rated_power / base_speed = {t_rated:.4g} N m" in text
    # the breakdown torque falls about as 1 / leakage: the preset's margin of about 2
    # over the rated torque keeps a 1.5 times larger leakage, not a 2 times larger one
    _induction(stator_leakage_inductance=1.5 * m["stator_leakage_inductance"],
               rotor_leakage_inductance=1.5 * m["rotor_leakage_inductance"])
    assert "the motor cannot deliver its rated power" in _motor_refused(
        stator_leakage_inductance=2 * m["stator_leakage_inductance"],
        rotor_leakage_inductance=2 * m["rotor_leakage_inductance"])


def test_creep_tables_are_strict_and_in_range():
    s = ltdsim.load_scenario(ROOT / "scenarios" / "paper-induction.toml")
    for value, words in ((True, "must be a number"), ("0.3", "must be a number"),
                         (1.5, "less than or equal to 1")):
        with pytest.raises(ScenarioError, match=f"traction.creep.rail.mu0: .*{words}"):
            s.with_overrides({"traction.creep.rail.mu0": value})
    with pytest.raises(ScenarioError, match=r"kS = 0\.5 must not exceed kA = 0\.3"):
        s.with_overrides({"traction.creep.rail": {"preset": "wet", "kS": 0.5}})


# ------------------------------------------- a drive faster than the step, by its name
def test_a_drive_faster_than_the_step_is_named_not_the_couplers():
    """5 kHz current loops (31.8 us) under ode3 at 0.1 ms: ode3 holds a lag down to
    dt / 2.513 = 39.8 us, so the drive, not a coupler, goes unstable."""
    s = _induction(current_bandwidth=5000.0).with_overrides(
        {"solver.t_end": 0.5, "solver.stability_check": False})  # (else refused before)
    with pytest.raises(SimulationError) as e:
        ltdsim.simulate(s)
    text = str(e.value)
    tau = 1.0 / (2.0 * math.pi * 5000.0)
    assert "the induction drive of consist 1 ('lead', vehicle 1 'loco'" in text
    assert f"1 / (2 pi traction.motor.current_bandwidth) = {tau:.3g} s" in text
    assert "against solver.dt = 0.0001 s" in text
    assert f"at most {2.5127 * tau:.3g} s" in text
    assert "coupler" not in text and "stiffness and damping" not in text


# ----------------------------------------------------- one vehicle: no propagation
def test_one_vehicle_fluid_brake_prints_no_propagation_speed(tmp_path):
    from typer.testing import CliRunner

    from ltdsim.cli.app import app

    path = tmp_path / "one.toml"
    path.write_text("""
[solver]
method = "bs23"
dt = 1e-4
t_end = 1.0
output_interval = 0.01
max_step = 0.05
[[vehicles]]
name = "wagon"
mass = 9e4
length = 14.4
powered = true
brake = { cylinder_force = 40500.0, rigging_ratio = 2.6, shoes = 8, friction = 0.3 }
[traction]
max_force = 3e5
max_power = 6.4e6
adhesion_mass = 9e4
[brake]
model = "fluid"
fluid = { valve = "uic-g" }
[driver]
mode = "force"
force_profile = [[0.0, 0.0]]
brake_commands = [{ time = 0.2, handle = "emergency" }]
[initial]
speed = 20.0
""", encoding="utf-8")
    res = CliRunner().invoke(app, ["run", str(path), "-q"])
    out = " ".join(res.stdout.split())
    assert res.exit_code == 0, out
    line = out[out.index("fluid brake: "):]
    assert line.startswith("fluid brake: application at 0.20 s from vehicle 1")
    assert "propagation n/a (one vehicle)" in line
    assert "m/s" not in line and "vent front" not in line
