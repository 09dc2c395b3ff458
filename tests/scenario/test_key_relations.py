"""Keys that would have no effect, and keys whose values contradict one another, are
refused in one line naming the key and the relation (issue 37); a file the scenario
reader cannot take for what it is says what it is."""

from pathlib import Path

import pytest

import ltdsim
from ltdsim import ScenarioError

from conftest import ROOT, cli_refused

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


def test_a_valve_family_given_as_a_number_says_string(tmp_path):
    text = edit(UIC, 'valve = "uic-g"', 'valve = { preset = "uic-g", control_valve = '
                                        '{ family = 1 } }')
    refused(tmp_path, text, r"brake\.fluid\.valve\.control_valve\.family: must be a string "
                            r"\(in quotes\) \(got 1\)")


def test_a_motor_key_given_as_text_says_number_and_what_was_given(tmp_path):
    text = edit((SCENARIOS / "paper-induction.toml").read_text(), "[traction.motor]",
                '[traction.motor]\nrated_power = "8.5e5"')
    refused(tmp_path, text, rf"traction\.motor: rated_power: {NUMBER} \(got \"8\.5e5\"\)")
