"""Keys that would have no effect, and keys whose values contradict one another, are
refused in one line naming the key and the relation (issue 37); a file the scenario
reader cannot take for what it is says what it is."""

import tomllib
from pathlib import Path

import pytest

import ltdsim
from ltdsim import ScenarioError

from conftest import PAPER, ROOT, cli_refused

SCENARIOS = ROOT / "scenarios"
SHORT = (SCENARIOS / "short-train.toml").read_text()


def write(tmp_path: Path, text: str | bytes, name: str = "bad.toml") -> Path:
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


def refused(tmp_path, text, match, case=None) -> str:
    """Load ``text`` as bad.toml: assert it is refused with ``match``, in one line naming
    the file; return the message."""
    with pytest.raises(ScenarioError, match=match) as info:
        ltdsim.load_scenario(write(tmp_path, text), case=case)
    msg = str(info.value)
    assert "bad.toml" in msg and len(msg.splitlines()) == 1, msg
    return msg


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new)


# --------------------------------------------------------------- the file itself
def test_a_utf8_byte_order_mark_at_the_start_is_accepted(tmp_path):
    sc = ltdsim.load_scenario(write(tmp_path, b"\xef\xbb\xbf" + SHORT.encode()))
    assert sc.name == "short-train" and sc.n_vehicles == 5


def test_a_byte_order_mark_in_a_profile_csv_does_not_hide_its_first_row(tmp_path):
    (tmp_path / "line.csv").write_bytes(b"\xef\xbb\xbf0.0,0.0,0.0\n500.0,0.002,0.05\n")
    text = edit(SHORT, 'curve = [[0.0, 0.0], [150.0, 300.0], [450.0, 0.0]]',
                'profile_file = "line.csv"')
    sc = ltdsim.load_scenario(write(tmp_path, text))
    assert sc.track.profile == [(0.0, 0.0, 0.0), (500.0, 0.002, 0.05)]


def test_a_sweep_file_given_as_a_scenario_says_to_run_ltdsim_sweep():
    sweep = SCENARIOS / "heavy-haul-brakes-sweep.toml"
    with pytest.raises(ScenarioError, match=r"a sweep file \(its scenario key and "
                                            r"\[overrides\] and \[list\] tables\), not a "
                                            r"scenario: run its cases with `ltdsim sweep "):
        ltdsim.load_scenario(sweep)
    text = cli_refused("run", sweep)
    assert f"ltdsim sweep {sweep}" in text and "required key" not in text
    assert "unknown key" not in text


# ------------------------------------------------------------------ vehicles
def test_a_dynamic_mass_below_the_static_mass_is_refused(tmp_path):
    # a 1 kg wagon carrying 1000 t on the rails
    msg = refused(tmp_path, edit(SHORT, "mass = 90000.0", "mass = 1.0\nstatic_mass = 1.0e6"),
                  r"vehicles\.1: mass \(1 kg\) must be at least static_mass \(1e\+06 kg\)")
    assert "dynamic mass" in msg and "rotating parts" in msg
    sc = ltdsim.load_scenario(write(tmp_path, edit(SHORT, "mass = 90000.0",
                                                   "mass = 9.0e4\nstatic_mass = 9.0e4")))
    assert sc.vehicles[1].weight_mass == 9.0e4  # equal masses: nothing rotating counted


@pytest.mark.parametrize("axles", [3, 5])
def test_an_odd_axle_count_cannot_be_split_between_two_bogies(tmp_path, axles):
    text = edit(SHORT, 'c = 11.9322 }\n\n[couplers',
                f'c = 11.9322 }}\ngeometry = {{ axles = {axles} }}\n\n[couplers')
    refused(tmp_path, text, rf"vehicles\.1\.geometry\.axles: {axles} axles cannot be split "
                            r"between the vehicle's two bogies .*even number from 2 to 16")
    text = edit(SHORT, 'c = 11.9322 }\n\n[couplers', 'c = 11.9322 }\ngeometry = { axles = 6 }'
                                                     '\n\n[couplers')
    assert ltdsim.load_scenario(write(tmp_path, text)).vehicles[1].geometry.axles == 6


# ------------------------------------------------------------------ couplers
TABLE_GEAR = """[couplers.default]
model = "table"
slack = 0.025
k_locked = 5e7
loading = LOADING
unloading = [[0.0, 2e4], [0.05, 0.6e6], [0.08, 1.6e6]]
"""


def table_gear(loading: str, extra: str = "") -> str:
    head, _, rest = SHORT.partition("[couplers.default]")
    tail = rest[rest.index("[[couplers.override]]"):].replace("k3 = 7.998176e6",
                                                               "k_locked = 6e7")
    return head + TABLE_GEAR.replace("LOADING", loading) + extra + "\n" + tail


def test_a_one_point_gear_table_is_refused(tmp_path):
    ltdsim.load_scenario(write(tmp_path, table_gear("[[0.0, 5e4], [0.08, 2.4e6]]")))
    refused(tmp_path, table_gear("[[0.0, 363e3]]"),
            r"couplers\.default: loading: 1 point \(363000 N at 0 m\) is not a "
            r"force-deflection curve: give at least 2 \[deflection m, force N\] points")


def test_a_gear_table_that_never_rises_is_refused(tmp_path):
    refused(tmp_path, table_gear("[[0.0, 1.6e6], [0.08, 1.6e6]]"),
            r"loading: the force must rise from its start \(1\.6e\+06 N at 0 m\) to its last "
            r"point \(1\.6e\+06 N at 0\.08 m\)")


def test_gear_table_points_beyond_the_travel_are_refused(tmp_path):
    loading = "[[0.0, 5e4], [0.05, 1.2e6], [0.08, 2.4e6]]"
    ltdsim.load_scenario(write(tmp_path, table_gear(loading, "travel = 0.08\n")))
    refused(tmp_path, table_gear(loading, "travel = 0.06\n"),
            r"travel \(0\.06 m\) is below the last deflection of loading \(0\.08 m\): the "
            r"points beyond travel would have no effect")


HEAVY = (SCENARIOS / "heavy-haul.toml").read_text()
S_TABLE = ("S_table = { velocity = [0.0, 1.0], deflection = [0.0, 0.08], "
           "values = [[0.03, 0.03], [0.02, 0.02]] }")


def test_edge_damping_without_an_edge_stiffness_is_refused(tmp_path):
    # a dashpot across a rigid end of the slack would have no effect
    good = edit(HEAVY, 'preset = "friction-wedge-high"\nslack = 0.02',
                'preset = "friction-wedge-high"\nslack = 0.02\nedge_stiffness = 1e8\n'
                'edge_damping = 2e6')
    assert ltdsim.load_scenario(write(tmp_path, good)).coupler(5).edge_damping == 2e6
    text = edit(HEAVY, 'preset = "friction-wedge-high"\nslack = 0.02',
                'preset = "friction-wedge-high"\nslack = 0.02\nedge_damping = 2e6')
    refused(tmp_path, text, r"couplers\.default: edge_damping acts only across the "
                            r"structure of edge_stiffness")


def test_s_and_s_table_together_are_refused(tmp_path):
    text = edit(HEAVY, 'preset = "friction-wedge-high"\nslack = 0.02',
                f'preset = "friction-wedge-high"\nslack = 0.02\nS = 0.03\n{S_TABLE}')
    refused(tmp_path, text, r"couplers\.default: S and S_table both given: the lubrication "
                            r"factor is either the constant S or the table S_table .*give "
                            r"one of them")


def test_an_s_table_over_a_preset_or_a_default_s_replaces_it(tmp_path):
    # the preset gives S: a table given with it stands instead
    text = edit(HEAVY, 'preset = "friction-wedge-high"\nslack = 0.02',
                f'preset = "friction-wedge-high"\nslack = 0.02\n{S_TABLE}')
    sc = ltdsim.load_scenario(write(tmp_path, text))
    c = sc.coupler(5)
    assert c.S is None and c.S_table.values == [[0.03, 0.03], [0.02, 0.02]]
    # an override's table replaces the default's S, and its S a default's table
    text = edit(HEAVY, "index = 107 ", f"index = 106\n{S_TABLE}\n\n[[couplers.override]]\n"
                                       "index = 107 ")
    sc = ltdsim.load_scenario(write(tmp_path, text))
    assert sc.coupler(106).S is None and sc.coupler(106).S_table is not None
    assert sc.coupler(105).S == 0.0315 and sc.coupler(105).S_table is None


# --------------------------------------------------------- a value of the wrong type
UIC = (SCENARIOS / "uic-freight.toml").read_text()
NUMBER = r"must be a number \(a TOML integer or float: not in quotes, not true/false\)"


@pytest.mark.parametrize("table, value, got", [
    ('control_valve = { auxiliary_volume = "0.1" }', "control_valve.auxiliary_volume",
     r'\(got "0\.1"\)'),
    ('driver_valve = { regulated = "5e5" }', "driver_valve.regulated", r'\(got "5e5"\)'),
    ("control_valve = { band = true }", "control_valve.band", r"\(got true\)")])
def test_a_valve_number_given_as_text_says_number_and_what_was_given(tmp_path, table, value,
                                                                     got):
    text = edit(UIC, 'valve = "uic-g"', f'valve = {{ preset = "uic-g", {table} }}')
    msg = refused(tmp_path, text, rf"brake\.fluid\.valve\.{value}: {NUMBER} {got}")
    assert "must be given" not in msg


def test_a_valve_family_given_as_a_number_names_the_families(tmp_path):
    text = edit(UIC, 'valve = "uic-g"', 'valve = { preset = "uic-g", control_valve = '
                                        '{ family = 1 } }')
    refused(tmp_path, text, r"brake\.fluid\.valve\.control_valve\.family: Input should be "
                            r"'uic' or 'aar' \(got 1\)")


def test_a_motor_key_given_as_text_says_number_and_what_was_given(tmp_path):
    text = edit((SCENARIOS / "paper-induction.toml").read_text(), "[traction.motor]",
                '[traction.motor]\nrated_power = "8.5e5"')
    refused(tmp_path, text, rf"traction\.motor: rated_power: {NUMBER} \(got \"8\.5e5\"\)")


# ------------------------------------------------- keys that would have no effect
TWO = (SCENARIOS / "two-wagons-linear.toml").read_text()  # force mode, lumped brake, rk4
FORCE_MODE = 'mode = "force"'


@pytest.mark.parametrize("text, key, why, reader", [
    (SHORT + '\n[brake]\nmodel = "lumped"\n[brake.fluid]\nvalve = "uic-g"\n', "brake.fluid",
     r"the lumped brake \(brake\.model = 'lumped'\) has no brake pipe or valves",
     r"\[brake\.fluid\] is read by the fluid brake: set brake\.model = 'fluid'"),
    (SHORT + "\n[brake.air]\ntemperature = 280.0\n", "brake.air",
     r"the lumped brake \(brake\.model = 'lumped'\) has no brake pipe or valves",
     r"\[brake\.air\] is read by the fluid brake"),
    (edit(UIC, "[brake.fluid]", "propagation_speed = 280.0\n[brake.fluid]"),
     "brake.propagation_speed", r"under the fluid brake \(brake\.model = 'fluid'\), where "
     r"the pipe's air flow carries the signal", r"read by the lumped brake"),
    (edit(SHORT, "adhesion_mass = 3.9e5", "adhesion_mass = 3.9e5\n[traction.motor]\n"
                                          "per_locomotive = 4"), "traction.motor",
     r"no consist uses the induction drive \(traction\.drive = 'curve' and no "
     r"\[\[locomotives\]\] drive = 'induction'\)",
     r"\[traction\.motor\] is read by the induction drive: set traction\.drive = "
     r"'induction'"),
    (edit(SHORT, "adhesion_mass = 3.9e5", 'adhesion_mass = 3.9e5\ncreep = { rail = "wet" }'),
     "traction.creep", r"no consist uses the induction drive", r"\[traction\.creep\] is "
                                                               r"read by the induction drive"),
    (edit(SHORT, 'mode = "speed"', 'mode = "speed"\nforce_profile = [[0.0, 1e5]]'),
     "driver.force_profile", r"in driver\.mode = 'speed'",
     r"force_profile is read in mode 'force': set driver\.mode = 'force'"),
    (edit(TWO, FORCE_MODE, FORCE_MODE + "\nnotch_profile = [[0.0, 4.0]]"),
     "driver.notch_profile", r"in driver\.mode = 'force'", r"read in mode 'notch'"),
    (edit(TWO, FORCE_MODE, FORCE_MODE + "\nspeed_profile = [[0.0, 0.0], [10.0, 5.0]]"),
     "driver.speed_profile", r"in driver\.mode = 'force'", r"read in mode 'speed'"),
    (edit(TWO, FORCE_MODE, FORCE_MODE + "\npid = { kp = 1.0 }"), "driver.pid",
     r"in driver\.mode = 'force'", r"pid is read in mode 'speed'"),
    (edit(TWO, "output_interval = 1e-3", "output_interval = 1e-3\nrtol = 1e-4"),
     "solver.rtol", r"with method = 'rk4' \(a fixed step\)",
     r"rtol is read by the adaptive method: set solver\.method = 'bs23'"),
    (edit(TWO, "output_interval = 1e-3", "output_interval = 1e-3\nspeed_atol = 1e-6"),
     "solver.speed_atol", r"with method = 'rk4' \(a fixed step\)",
     r"speed_atol is read by the adaptive method: set solver\.method = 'bs23'"),
    (edit(TWO, "output_interval = 1e-3", "output_interval = 1e-3\nhold_speed = 3e-3"),
     "solver.hold_speed", r"with method = 'rk4' \(a fixed step\)",
     r"hold_speed is read by the adaptive method: set solver\.method = 'bs23'"),
    (edit(SHORT, 'couplers = "stretched"', 'couplers = "stretched"\nspeed = 5.0\n'
                                           'velocities = [1.0, 1.0, 1.0, 1.0, 1.0]'),
     "initial.speed", r"initial\.velocities gives each vehicle's initial speed",
     r"give one of speed \(the whole train\) and velocities"),
])
def test_a_key_that_would_have_no_effect_is_refused(tmp_path, text, key, why, reader):
    refused(tmp_path, text, rf"bad\.toml: {key.replace('.', '[.]')}: has no effect.*{why}"
                            rf".*{reader}")


def test_a_lumped_brake_refuses_the_fluid_brake_s_vehicle_keys_once_for_a_group(tmp_path):
    text = edit(SHORT, "count = 4\nmass = 90000.0", "count = 4\nmass = 90000.0\nbrake = "
                       "{ cylinder_force = 3e4, rigging_ratio = 6.0, piston_area = 0.1 }")
    refused(tmp_path, text, r"vehicles\.1\.brake\.piston_area: has no effect \(vehicle 2 "
                            r"from the lead\): the lumped brake .* takes cylinder_force; "
                            r"piston_area is read by the fluid brake")


@pytest.mark.parametrize("names, match", [
    ('"velocity", "brake_pipe_pressure"',
     r"names brake_pipe_pressure \(recorded by the fluid brake, brake\.model = 'fluid'\), "
     r"which this train does not produce: leave it out"),
    ('"velocity", "auxiliary_reservoir_pressure", "stator_current"',
     r"names auxiliary_reservoir_pressure \(recorded by the fluid brake, brake\.model = "
     r"'fluid'\), stator_current \(recorded by an induction drive, traction\.drive = "
     r"'induction'\), which this train does not produce: leave them out")])
def test_a_recorded_variable_the_train_does_not_produce_is_refused(tmp_path, names, match):
    text = edit(SHORT, "output_interval = 1e-3", f"output_interval = 1e-3\nrecord = [{names}]")
    refused(tmp_path, text, r"solver\.record: " + match)
    text = edit(UIC, "output_interval = 0.05", 'output_interval = 0.05\nrecord = '
                                               '["velocity", "brake_pipe_pressure"]')
    ltdsim.load_scenario(write(tmp_path, text, "fluid.toml"))  # the fluid brake records it


def test_a_consist_on_the_induction_drive_reads_the_motor_and_creep_tables():
    # traction.drive = "curve", the lead consist's drive = "induction"
    sc = ltdsim.load_scenario(SCENARIOS / "heavy-haul-wet-start.toml")
    assert sc.traction.drive == "curve" and sc.locomotives[0].drive == "induction"


def test_a_key_a_case_reads_is_not_refused_in_the_file(tmp_path):
    base = edit(TWO, FORCE_MODE, FORCE_MODE + "\npid = { kp = 1.0 }")
    text = base + ('\n[cases.speed]\n"driver.mode" = "speed"\n'
                   '"driver.speed_profile" = [[0.0, 0.0], [10.0, 5.0]]\n')
    sc = ltdsim.load_scenario(write(tmp_path, text, "cased.toml"), case="speed")
    assert sc.driver.mode == "speed" and sc.driver.pid.kp == 1.0
    # without the case that reads it, the key is refused
    refused(tmp_path, base + '\n[cases.slow]\n"solver.t_end" = 10.0\n', r"driver\.pid: has "
                                                                         r"no effect")


def test_schema_defaults_and_a_case_switching_modes_do_not_count_as_given():
    # heavy-haul's emergency case drives in force mode, its file's pid is the speed mode's;
    # every shipped scenario and case loads (the schema fills brake.fluid, traction.motor,
    # every profile without them being given)
    for path in sorted(SCENARIOS.glob("*.toml")):
        if "sweep" in path.name:
            continue
        sc = ltdsim.load_scenario(path)
        for name in sc.cases:
            ltdsim.load_scenario(path, case=name)
    sc = ltdsim.load_scenario(SCENARIOS / "heavy-haul.toml", case="emergency")
    assert sc.driver.mode == "force" and sc.driver.pid is not None


def test_the_shipped_sweep_and_its_overrides_load():
    from ltdsim.sweep.core import load_sweep

    sweep = load_sweep(SCENARIOS / "heavy-haul-brakes-sweep.toml")
    assert [sweep.scenario(c).brake.mode for c in sweep.cases] == ["pneumatic"] * 3 + ["ecp"]


@pytest.mark.parametrize("key, value, match", [
    ("brake.fluid.leakage", "1e-6", r"brake\.fluid: has no effect: the lumped brake"),
    ("driver.force_profile", "[[0.0, 1e5]]", r"driver\.force_profile: has no effect in "
                                             r"driver\.mode = 'speed'"),
    ("traction.motor.per_locomotive", "4", r"traction\.motor: has no effect: no consist "
                                           r"uses the induction drive")])
def test_an_override_that_would_have_no_effect_is_refused(key, value, match):
    sc = ltdsim.load_scenario(SCENARIOS / "short-train.toml")
    with pytest.raises(ScenarioError, match=r"^--set: " + match):
        sc.with_overrides({key: tomllib.loads(f"v = {value}")["v"]},
                          source="--set")
    text = cli_refused("run", SCENARIOS / "short-train.toml", "--set", f"{key}={value}")
    assert "--set" in text and "has no effect" in text


# ---------------------------------------------------------------- the case key
def test_a_case_key_naming_a_case_the_file_lacks_is_refused_listing_its_cases(tmp_path):
    text = edit(SHORT, 'name = "short-train"', 'name = "short-train"\ncase = "X"')
    text += '\n[cases.slow]\n"solver.t_end" = 10.0\n[cases.fast]\n"solver.t_end" = 5.0\n'
    refused(tmp_path, text, r"bad\.toml: case: 'X' is not a case of this scenario \(its "
                            r"cases: fast, slow\); case names the case applied by --case")


def test_a_case_key_naming_one_of_the_file_s_cases_is_refused_too(tmp_path):
    text = edit(SHORT, 'name = "short-train"', 'name = "short-train"\ncase = "slow"')
    text += '\n[cases.slow]\n"solver.t_end" = 10.0\n'
    refused(tmp_path, text, r"bad\.toml: case: names the case applied, set by --case NAME, "
                            r"which applies the case's overrides; given as a key it would "
                            r"only relabel the run \(the cases: slow\)")


@pytest.mark.parametrize("name", ["X", "LHHL"])
def test_set_case_is_refused_listing_the_cases(name):
    paper = SCENARIOS / "paper.toml"
    with pytest.raises(ScenarioError, match=r"--set: case: names the case applied"):
        ltdsim.load_scenario(paper).with_overrides({"case": name}, source="--set")
    text = cli_refused("run", paper, "--set", f"case={name}")
    assert "would only relabel the run" in text and "LHHL" in text


def test_an_energy_interval_without_the_energy_accounting_is_refused():
    sc = ltdsim.load_scenario(PAPER, case="LHHL")
    with pytest.raises(ScenarioError, match=r"solver.energy_interval: has no effect with "
                                            r"solver.energy = false"):
        sc.with_overrides({"solver.energy_interval": 1e-3})
    with pytest.raises(ScenarioError, match=r"solver.energy_interval: has no effect with "
                                            r"method = 'bs23'"):
        sc.with_overrides({"solver.energy": True, "solver.method": "bs23",
                           "solver.energy_interval": 1e-3})
    assert sc.with_overrides({"solver.energy": True,
                              "solver.energy_interval": 1e-3}).solver.energy_every == 10
