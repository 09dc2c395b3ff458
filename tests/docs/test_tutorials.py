"""The tutorials (docs/tutorials/*.py, jupytext percent scripts) run as they are, each
in a fresh process with an empty working folder, and what each prints is checked here
against its physics, recomputed from the numbers the script prints or from the
scenario's own data, not taken from the script's asserts alone."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.py"))
NUMBER = r"(-?\d+(?:\.\d+)?)"


def run(script: Path, cwd: Path) -> str:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    code = f"import runpy; runpy.run_path({str(script)!r}, run_name='__main__')"
    proc = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc.stdout


def test_there_are_four_tutorials_at_least():
    assert len(TUTORIALS) >= 4
    for script in TUTORIALS:
        assert script.read_text(encoding="utf-8").count("# %%") >= 2, script.name


def tutorial(name: str) -> Path:
    (path,) = [p for p in TUTORIALS if p.stem.endswith(name)]
    return path


def test_first_run_position_is_the_integral_of_velocity(tmp_path):
    out = run(tutorial("first_run"), tmp_path)
    travel, integral = map(float, re.search(
        rf"travel {NUMBER} m, integral of its velocity {NUMBER} m", out).groups())
    assert travel > 10.0                       # m: the train moved
    assert abs(travel - integral) <= 1e-3 * travel
    peaks = [float(x) for x in re.findall(rf"largest tension +{NUMBER} kN", out)]
    assert len(peaks) == 9                     # the study's train: 9 couplers
    # pulling away, the front coupler drags the most mass: tension falls towards the rear
    assert peaks[0] == max(peaks) and peaks[-1] == min(peaks)
    assert (tmp_path / "results" / "first-run.nc").stat().st_size > 0


def test_custom_train_coupler_force_is_trailing_mass_times_acceleration(tmp_path):
    out = run(tutorial("custom_train"), tmp_path)
    # the tutorial's train, recomputed here: 150 kN on 80 + 50 + 60 + 70 t
    force, masses = 150e3, [80e3, 50e3, 60e3, 70e3]
    expected = [force * sum(masses[j + 1:]) / sum(masses) / 1e3 for j in range(3)]
    linear = [float(x) for x in re.findall(rf"coupler \d: simulated +{NUMBER} kN", out)]
    other = [float(x) for x in re.findall(rf"simplified gear, coupler \d: +{NUMBER} kN", out)]
    assert linear == pytest.approx(expected, rel=5e-3)
    assert other == pytest.approx(expected, rel=5e-3)
    a = float(re.search(rf"acceleration {NUMBER} m/s\^2", out).group(1))
    assert a == pytest.approx(force / sum(masses), rel=5e-3)


def test_fluid_brake_pipe_pressure_falls_front_to_rear(tmp_path):
    out = run(tutorial("fluid_brake"), tmp_path)
    pipe = [(float(a), float(b)) for a, b in re.findall(
        rf"brake pipe {NUMBER} bar at 0 s, {NUMBER} bar at", out)]
    assert len(pipe) == 2
    for start, end in pipe:
        assert start > 4.0 and end < 0.5 * start       # bar gauge: charged, then vented
    drops = [float(t) for t in re.findall(rf"0\.5 bar drop at {NUMBER} s", out)]
    assert len(drops) == 6 and drops == sorted(drops) and drops[-1] > drops[0]
    v0, v1 = map(float, re.search(rf"speed: {NUMBER} km/h at 0 s, {NUMBER} km/h", out).groups())
    assert v1 < v0


def test_dask_sweep_one_result_per_case(tmp_path):
    out = run(tutorial("dask_sweep"), tmp_path)
    assert "ONE_RESULT_PER_CASE" in out
    peaks = [float(x) for x in re.findall(rf"coupler 1 peak {NUMBER} kN", out)]
    assert len(peaks) == 3
    # two-wagons-linear: 200 kN on 80 + 2 x 60 t; coupler 1 moves the two wagons
    assert all(p > 200.0 * 120.0 / 200.0 for p in peaks)
    cases = sorted((tmp_path / "results" / "stiffness-sweep" / "cases").glob("*.json"))
    assert len(cases) == 3
