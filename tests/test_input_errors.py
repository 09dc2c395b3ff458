"""Bad input fails at load time with one clear message naming file, key and range."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import ltdsim
from ltdsim import ScenarioError, SimulationError

from conftest import ROOT, build, train_dict

EXAMPLE = (ROOT / "scenarios" / "short-train.toml").read_text()


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "bad.toml"
    p.write_text(text)
    return p


def load_error(tmp_path, text, case=None) -> str:
    with pytest.raises(ScenarioError) as info:
        ltdsim.load_scenario(write(tmp_path, text), case=case)
    msg = str(info.value)
    assert "bad.toml" in msg
    return msg


def test_unknown_key_is_named_with_the_allowed_keys(tmp_path):
    msg = load_error(tmp_path, EXAMPLE.replace("t_end = 60.0", "t_end = 60.0\nmetod = 1"))
    assert "solver.metod" in msg and "unknown key" in msg and "output_interval" in msg


@pytest.mark.parametrize("mass", ["-90000.0", "0.0"])
def test_negative_or_zero_mass_names_the_vehicle_and_the_range(tmp_path, mass):
    msg = load_error(tmp_path, EXAMPLE.replace("mass = 90000.0", f"mass = {mass}"))
    assert "vehicles.1.mass" in msg and "greater than 0" in msg


def test_nan_is_refused(tmp_path):
    msg = load_error(tmp_path, EXAMPLE.replace("k1 = 8.265776e6", "k1 = nan"))
    assert "couplers.default.k1" in msg and "finite" in msg


def test_empty_train_is_refused():
    d = train_dict([1e4, 1e4])
    d["vehicles"] = []
    with pytest.raises(ScenarioError) as info:
        ltdsim.Scenario.from_dict(d, "empty.toml")
    assert "empty.toml: vehicles" in str(info.value) and "at least 1" in str(info.value)


def test_output_interval_must_be_a_whole_number_of_steps(tmp_path):
    msg = load_error(tmp_path, EXAMPLE.replace("output_interval = 1e-3", "output_interval = 2.5e-4"))
    assert "solver" in msg and "whole multiple of dt" in msg


def test_coupler_override_index_out_of_range(tmp_path):
    msg = load_error(tmp_path, EXAMPLE.replace("index = 3", "index = 4"))
    assert "couplers.override.0.index = 4" in msg and "coupler indices 0 to 3" in msg


def test_unknown_case_lists_the_available_ones(tmp_path, paper_path):
    with pytest.raises(ScenarioError) as info:
        ltdsim.load_scenario(paper_path, case="LHHX")
    msg = str(info.value)
    assert "paper.toml" in msg and "LHHX" in msg and "LHHL" in msg


def test_a_case_with_a_bad_key_fails_when_the_file_is_loaded(tmp_path):
    msg = load_error(tmp_path, EXAMPLE + '\n[cases.broken]\n"couplers.default.k9" = 1.0\n')
    assert "cases.broken" in msg and "k9" in msg


def test_override_of_a_vehicle_that_does_not_exist(tmp_path):
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "short-train.toml")
    with pytest.raises(ScenarioError) as info:
        sc.with_overrides({"vehicles.30.mass": 1.0})
    assert "vehicles.30.mass" in str(info.value) and "0-4" in str(info.value)
    with pytest.raises(ScenarioError) as info:
        sc.with_overrides({"solver.dt": -1.0})
    assert "solver.dt" in str(info.value) and "greater than 0" in str(info.value)


def test_cli_reports_bad_input_in_one_line_without_a_traceback(tmp_path):
    bad = write(tmp_path, EXAMPLE.replace("mass = 90000.0", "mass = -1.0"))
    proc = subprocess.run([sys.executable, "-m", "ltdsim.cli", "run", str(bad), "-q"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr + proc.stdout
    assert "vehicles.1.mass" in proc.stderr and "bad.toml" in proc.stderr


def test_a_diverging_simulation_stops_and_names_time_vehicle_and_values():
    # explicit Euler far beyond its stability limit: k/m = 1e5 1/s^2 at dt = 0.01 s
    d = train_dict([1e4, 1e4, 1e4], t_end=100.0, dt=1e-2, method="euler",
                   coupler={"model": "linear", "stiffness": 1e9, "damping": 0.0, "slack": 0.0})
    with pytest.raises(SimulationError) as info:
        ltdsim.simulate(build(d))
    err = info.value
    assert 0.0 < err.time < 100.0
    assert err.vehicle is not None and 0 <= err.vehicle < 3
    msg = str(err)
    assert f"t = {err.time:.6g} s" in msg and "vehicle" in msg and "velocity" in msg
    assert np.isfinite(err.time)


HH = (ROOT / "scenarios" / "heavy-haul.toml").read_text()


@pytest.mark.parametrize("old,new,key,words", [
    ("vehicles = [107, 108]", "vehicles = [107, 300]", "locomotives", "out of range 0-213"),
    ("vehicles = [107, 108]", "vehicles = [107, 110]", "locomotives", "is not powered"),
    ("vehicles = [107, 108]", "vehicles = [1, 108]", "locomotives", "already in 'lead'"),
    ("propagation_speed = 250.0", "propagation_speed = 2500.0", "brake.propagation_speed",
     "less than or equal to 400"),
    ("time_constant = 1.5 ", "time_constant = 0.0 ", "traction", "jerk_limit"),
    ("shoes = 8, friction_table", "shoes = 0, friction_table", "vehicles.1.brake.shoes",
     "greater than or equal to 1"),
    ("brake_controller = true", "brake_controller = true\nnotch_profile = [[0.0, 2.5]]",
     "driver.notch_profile", "whole notches in [-8, 8]"),
    ("method = \"bs23\"", "method = \"bs45\"", "solver.method", "bs23"),
    ("name = \"lead\"\nvehicles = [0, 1]", "name = \"lead\"\nvehicles = [0, 1]\n"
     "notch_profile = [[0.0, 4.0]]", "locomotives.0.notch_profile", "follows [driver]"),
])
def test_bad_brake_traction_and_solver_keys_are_named(tmp_path, old, new, key, words):
    assert old in HH
    msg = load_error(tmp_path, HH.replace(old, new, 1))
    assert key in msg and words in msg, msg


def test_brake_commands_without_brakes_are_refused():
    d = train_dict([1e5, 1e5])
    d["driver"]["brake_profile"] = [[1.0, 0.5]]
    with pytest.raises(ScenarioError, match="no vehicle has a \\[brake\\] table"):
        build(d)


@pytest.mark.parametrize("args, key", [
    (["--capacity", "5e5"], "--capacity"),        # more than force x travel
    (["--absorptivity", "1.2"], "--absorptivity"),
])
def test_impossible_gear_ratings_are_named(args, key):
    base = {"--travel": "0.083", "--force": "2.27e6", "--capacity": "5e4",
            "--absorptivity": "0.8"}
    base.update(dict(zip(args[::2], args[1::2])))
    cmd = [sys.executable, "-m", "ltdsim.cli", "gear", "ratings"]
    for k, v in base.items():
        cmd += [k, v]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr + proc.stdout
    assert key in proc.stderr
