"""The command line as an engineer meets it: version, outputs checked before the work,
help on every option, 1-based coupler numbers, units in CSV headers, and the numbers
of the run summary against closed forms."""

from __future__ import annotations

import re
import sys
from importlib import metadata

import numpy as np
import pandas as pd
import pytest
import typer
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from typer.testing import CliRunner

import ltdsim
from ltdsim.cli.app import app
from ltdsim.analysis.phases import WHOLE_RUN, phase_norms, phases_of
from ltdsim.scenario import STUDY_PHASES
from ltdsim.results.summary import stopping

from conftest import PAPER, ROOT, build, train_dict
from conftest import BRAKE, single_braked_wagon

runner = CliRunner()

# a locomotive pulling one wagon from rest through an undamped linear coupler without
# slack: the coupler force is F m2 / (m1 + m2) (1 - cos w t), never below 0 N
M1, M2, F = 8.0e4, 6.0e4, 1.4e5
PULL = f"""
name = "pull"

[solver]
method = "rk4"
dt = 1e-4
t_end = 3.0
output_interval = 1e-3

[[vehicles]]
name = "loco"
mass = {M1}
length = 20.0
powered = true

[[vehicles]]
name = "wagon"
mass = {M2}
length = 15.0

[couplers.default]
model = "linear"
stiffness = 5e6
damping = 0.0
slack = 0.0

[traction]
max_force = 1e8
max_power = 1e9
adhesion_mass = 1e8

[driver]
mode = "force"
force_profile = [[0.0, {F}]]

[cases.emergency]
"solver.t_end" = 2.0
"""


def write(tmp_path, text, name="pull.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def no_coupler_zero(text):
    assert re.search(r"\bcoupler 0\b", text) is None, text


# --------------------------------------------------------------------------- basics
def test_version_is_the_installed_package_version():
    res = invoke("--version")
    assert res.exit_code == 0
    assert res.stdout.strip() == f"ltdsim {metadata.version('ltdsim')}"


def _commands(group, prefix=""):
    for name, cmd in group.commands.items():
        if hasattr(cmd, "commands"):
            yield from _commands(cmd, f"{prefix}{name} ")
        else:
            yield f"{prefix}{name}", cmd


def test_every_option_and_argument_of_every_command_has_help():
    root = typer.main.get_command(app)
    missing = [f"{root.name or 'ltdsim'} {p.name}" for p in root.params
               if not (getattr(p, "help", None) or "").strip()]
    commands = list(_commands(root))
    assert {"run", "sweep", "phases", "modal", "spectrum", "sysid", "study",
            "gear loop", "gear impact"} <= {c for c, _ in commands}
    markup = []  # "[cases.NAME]" in a help text: rich's help renderer would swallow it
    for name, cmd in commands:
        assert (cmd.help or "").strip(), name
        missing += [f"{name} {p.name}" for p in cmd.params
                    if not (getattr(p, "help", None) or "").strip()]
        markup += [name for text in [cmd.help] + [getattr(p, "help", "") for p in cmd.params]
                   if re.search(r"\[[a-zA-Z/#@\[]", text or "")]
    assert missing == [] and markup == []


# ------------------------------------------------------------ outputs before the work
LONG = PULL.replace("t_end = 3.0", "t_end = 1.0e6")  # hours of simulation if it ran


@pytest.fixture
def no_simulation(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("simulated although the output was refused")
    monkeypatch.setattr(sys.modules["ltdsim.results.simulate"], "simulate", refuse)


@pytest.mark.parametrize("option, name", [("-o", "out.csv"), ("-o", "out"), ("-o", "out.NC4"),
                                          ("--plot", "fig.docx"), ("--plot", "fig")])
def test_an_output_suffix_that_would_not_be_honoured_is_refused_before_simulating(
        tmp_path, no_simulation, option, name):
    scenario = write(tmp_path, LONG)
    res = invoke("run", scenario, option, tmp_path / name, "-q")
    assert res.exit_code == 2
    assert not (tmp_path / name).exists()
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in res.output
    assert ("--output" if option == "-o" else "--plot") in err and "accepted" in err
    assert (".nc" in err) if option == "-o" else (".png" in err and ".svg" in err)


def test_output_over_the_input_is_refused_and_the_input_untouched(tmp_path, no_simulation):
    scenario = write(tmp_path, LONG)
    before = scenario.read_bytes()
    for args in (("run", scenario, "-o", scenario), ("run", scenario, "--plot", scenario),
                 ("gear", "impact", "--scenario", scenario, "--csv", scenario),
                 ("reduce", "--scenario", scenario, "--toml", scenario),
                 ("phases", scenario, "-o", scenario), ("spectrum", scenario, "-o", scenario)):
        res = invoke(*args)
        assert res.exit_code == 2, (args, res.output)
        assert "input" in res.stderr or "is a file" in res.stderr, res.stderr
    assert scenario.read_bytes() == before


def test_set_on_a_saved_result_is_refused_in_one_line(tmp_path):
    ds = ltdsim.simulate(build(train_dict([1e5, 1e5], t_end=1.0, dt=1e-3)))
    nc = ltdsim.save_result(ds, tmp_path / "r.nc")
    for cmd in ("phases", "spectrum", "sysid", "modal"):
        res = invoke(cmd, nc, "--set", "solver.t_end=2", "-o", tmp_path / cmd)
        assert res.exit_code == 2, (cmd, res.output)
        assert len(res.stderr.strip().splitlines()) == 1 and "--set" in res.stderr
        assert "saved result" in res.stderr


# --------------------------------------------------------------------------- phases
def test_a_scenario_without_phases_is_one_phase_over_the_whole_run():
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "two-wagons-linear.toml")
    assert sc.phases == []
    ds = ltdsim.simulate(sc.with_overrides({"solver.t_end": 2.0}))
    assert phases_of(ds, sc) == [(WHOLE_RUN, 0.0, float(ds.time[-1]))]
    norms = phase_norms(ds, sc)
    assert list(norms.phase.values) == [WHOLE_RUN]
    assert_allclose(norms.coupler_force_infnorm.sel(phase=WHOLE_RUN),
                    np.abs(ds.coupler_force.values).max(axis=0))


def test_the_paper_scenario_declares_the_studys_four_windows():
    # the study's section 5.1: acceleration 0-10 s, curving 75-85 s, slope climbing
    # 185-195 s, deceleration 120-130 s
    sc = ltdsim.load_scenario(PAPER)
    assert [p.model_dump() for p in sc.phases] == STUDY_PHASES
    assert [p.model_dump() for p in sc.with_case("LHHL").phases] == STUDY_PHASES


def test_phases_cli_with_set_reads_the_whole_run_and_numbers_couplers_from_1(tmp_path):
    scenario = ROOT / "scenarios" / "two-wagons-linear.toml"
    out = tmp_path / "phases"
    res = invoke("phases", scenario, "--set", "solver.t_end=4", "-o", out, "-q")
    assert res.exit_code == 0, res.output
    norms = pd.read_csv(out / "phase_norms_couplers.csv")
    assert set(norms.phase) == {WHOLE_RUN}
    assert list(norms["coupler (1 = behind the lead)"]) == [1, 2]
    assert {"coupler_force_2norm_N", "coupler_force_infnorm_N", "coupler_force_rms_N"} <= set(
        norms.columns)
    veh = pd.read_csv(out / "phase_norms_vehicles.csv")
    assert list(veh["vehicle (1 = lead)"]) == [1, 2, 3]
    crit = pd.read_csv(out / "critical_couplers.csv")
    assert set(crit.criterion) == {"peak", "RMS"}
    assert set(crit["coupler (1 = behind the lead)"]) == {1, 2}
    # the ranking agrees with the recorded forces of the 4 s run (--set reached it)
    ds = ltdsim.simulate(ltdsim.load_scenario(scenario).with_overrides({"solver.t_end": 4.0}))
    peak = np.abs(ds.coupler_force.values).max(axis=0)
    top = crit.query("criterion == 'peak' and rank == 1")
    assert int(top["coupler (1 = behind the lead)"].iloc[0]) == int(np.argmax(peak)) + 1
    assert_allclose(top.force_N.iloc[0], peak.max(), rtol=1e-5)  # 6 significant figures
    assert "by peak" in res.stdout and "by RMS" in res.stdout
    row = next(line for line in res.stdout.splitlines()
               if WHOLE_RUN in line and line.lstrip().startswith("│"))
    cells = [c.strip() for c in re.split(r"[│|]", row) if c.strip()]
    by_rms = crit.query("criterion == 'RMS' and rank == 1")["coupler (1 = behind the lead)"]
    assert cells[1] == str(int(np.argmax(peak)) + 1) and cells[3] == str(int(by_rms.iloc[0]))
    no_coupler_zero(res.output)


# ---------------------------------------------------------------- stopping distance
@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(v0=st.floats(5.0, 25.0), decel=st.floats(0.3, 1.2))
def test_stopping_distance_and_time_of_a_braked_wagon_are_v0_squared_over_2a_and_v0_over_a(
        v0, decel):
    mu = decel * 9e4 / (BRAKE["cylinder_force"] * BRAKE["rigging_ratio"])
    ds = ltdsim.simulate(build(single_braked_wagon(v0, {"friction": mu}, 1.2 * v0 / decel)))
    s = stopping(ds)
    assert s is not None
    assert s["brake_time_s"] <= 0.01  # the command at 0 s, recorded every 0.01 s
    assert_allclose(s["stopping_distance_m"], v0**2 / (2 * decel), rtol=0.01)
    assert_allclose(s["stopping_time_s"], v0 / decel, rtol=0.01)


BRAKED = """
name = "braked-wagon"

[solver]
method = "ode3"
dt = 1e-3
t_end = 25.0
output_interval = 0.01

[[vehicles]]
name = "wagon"
mass = 9.0e4
length = 15.0
powered = true
brake = { cylinder_force = 3.0e4, rigging_ratio = 6.0, friction = 0.25 }

[traction]
max_force = 1e8
max_power = 1e9
adhesion_mass = 1e8

[brake]
mode = "ecp"
apply_time_constant = 1e-3

[driver]
mode = "force"
force_profile = [[0.0, 9.0e4], [5.0, 9.0e4], [5.001, 0.0]]
brake_profile = [[8.0, 1.0]]
"""


def test_stopping_is_measured_from_the_brake_application_after_traction(tmp_path):
    # pulled at 1 m/s^2 for 5 s, coasting (no resistance) to 8 s, then braked at
    # mu x 180 kN / 90 t = 0.5 m/s^2: from v = 5 m/s it stops in 25 m and 10 s
    scenario = write(tmp_path, BRAKED, "braked.toml")
    ds = ltdsim.simulate(ltdsim.load_scenario(scenario))
    s = stopping(ds)
    v = 5.0005  # 1 m/s^2 for 5 s and half the 1 ms ramp
    assert_allclose(s["brake_time_s"], 8.0, atol=0.011)
    assert_allclose(s["speed_m_s"], v, rtol=1e-4)
    assert_allclose(s["stopping_distance_m"], v**2 / (2 * 0.5), rtol=0.005)
    assert_allclose(s["stopping_time_s"], v / 0.5, rtol=0.005)
    res = invoke("run", scenario, "-q")
    assert res.exit_code == 0, res.output
    assert f"stopped in {s['stopping_distance_m']:.1f} m and {s['stopping_time_s']:.1f} s" \
        in res.stdout
    assert "5.0 m/s (18.0 km/h)" in res.stdout  # km/h beside m/s
    # a run that never stops reports no stopping distance
    assert stopping(ltdsim.simulate(build(train_dict([1e5, 1e5], t_end=1.0)))) is None


# -------------------------------------------------------------------- run summary
def test_a_coupler_never_in_compression_shows_dashes_and_its_closed_form_tension(tmp_path):
    res = invoke("run", write(tmp_path, PULL), "-q")
    assert res.exit_code == 0, res.output
    row = next(line for line in res.stdout.splitlines() if re.match(r"^\W*1\W", line))
    cells = [c.strip() for c in re.split(r"[│|]", row) if c.strip()]
    assert cells[0] == "1"
    assert_allclose(float(cells[1]), 2 * F * M2 / (M1 + M2) / 1e3, atol=0.06)  # kN
    assert cells[3:] == ["-", "-"]  # never in compression: no "0.0 kN at 0.00 s"
    no_coupler_zero(res.output)


def test_a_run_recording_only_the_coupler_forces_prints_the_same_closed_form_tension(tmp_path):
    # solver.record: the table comes from the peaks over every step, as in a full run;
    # what needs an unrecorded variable is left out, and --plot is refused before the run
    scenario = write(tmp_path, PULL)
    res = invoke("run", scenario, "-q", "--set", 'solver.record=["coupler_force"]')
    assert res.exit_code == 0, res.output
    row = next(line for line in res.stdout.splitlines() if re.match(r"^\W*1\W", line))
    cells = [c.strip() for c in re.split(r"[│|]", row) if c.strip()]
    assert_allclose(float(cells[1]), 2 * F * M2 / (M1 + M2) / 1e3, atol=0.06)  # kN
    assert "top speed" not in res.output and "RMS speed error" not in res.output
    assert "nan" not in res.output and "peak traction" in res.output
    bad = invoke("run", scenario, "--set", 'solver.record=["coupler_force"]', "--plot",
                 str(tmp_path / "f.png"))
    assert bad.exit_code == 2 and "solver.record" in bad.stderr and "--plot" in bad.stderr
    assert not (tmp_path / "f.png").exists()


def test_a_case_name_shows_in_brackets_without_a_backslash(tmp_path):
    res = invoke("run", write(tmp_path, PULL), "--case", "emergency")
    assert res.exit_code == 0, res.output
    assert "pull [emergency]" in res.stdout
    assert "\\[" not in res.output
    bad = invoke("run", write(tmp_path, PULL + '\n[cases.x]\n"solver.t_end" = -1.0\n'))
    assert bad.exit_code == 2 and "[cases.x]" in bad.stderr and "\\[" not in bad.stderr


def test_a_missing_brake_table_is_named_in_the_error_line(tmp_path):
    # "[brake]" in an error message is plain text, not markup that rich would swallow
    text = PULL.replace('mode = "force"\n', 'mode = "force"\nbrake_profile = [[1.0, 0.5]]\n')
    res = invoke("run", write(tmp_path, text))
    assert res.exit_code == 2
    assert "no vehicle has a [brake] table" in res.stderr, res.stderr


# ---------------------------------------------------------------- coupler numbers
def test_coupler_options_take_numbers_from_1_and_name_the_range(tmp_path):
    scenario = ROOT / "scenarios" / "short-train.toml"  # 5 vehicles: couplers 1-4
    for args in (("gear", "loop", "--scenario", scenario, "--coupler", "0"),
                 ("gear", "loop", "--scenario", scenario, "--coupler", "5"),
                 ("spectrum", scenario, "--couplers", "0,4", "-o", tmp_path / "s")):
        res = invoke(*args)
        assert res.exit_code == 2, res.output
        assert "1-4" in res.stderr and "Traceback" not in res.output
    # coupler 4 is the file's override index 3 (a stiffer gear): its loop is stiffer
    peaks = {}
    for number in (3, 4):
        res = invoke("gear", "loop", "--scenario", scenario, "--coupler", number,
                     "--cycles", "1", "--plot", tmp_path / f"loop{number}.png")
        assert res.exit_code == 0, res.output
        peaks[number] = float(re.search(r"peak force ([\d.]+) kN", res.stdout).group(1))
    sc = ltdsim.load_scenario(scenario)
    assert sc.coupler(3).k3 > sc.coupler(2).k3 and peaks[4] > peaks[3]


def test_spectrum_numbers_couplers_from_1_with_units_in_the_csv(tmp_path):
    out = tmp_path / "spectra"
    res = invoke("spectrum", ROOT / "scenarios" / "short-train.toml", "--couplers", "1,4",
                 "--set", "solver.t_end=20", "-o", out, "-q")
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out / "phase_spectra.csv")
    assert set(table["coupler (1 = behind the lead)"]) == {1, 4}
    assert {"max_N", "f_at_max_hz", "band_rms_N"} <= set(table.columns)
    assert set(table.phase) == {"pulling_away"}  # the only phase within 20 s
    no_coupler_zero(res.output)


def test_sweep_set_reaches_every_case_and_its_csvs_number_couplers_from_1(tmp_path):
    sweep = tmp_path / "stiff.toml"
    sweep.write_text(f'scenario = "{ROOT / "scenarios" / "two-wagons-linear.toml"}"\n'
                     '[list]\n"couplers.default.stiffness" = [2e6, 8e6]\n')
    out = tmp_path / "sweep"
    res = invoke("sweep", sweep, "--set", "solver.t_end=2", "-o", out, "--workers", "1",
                 "--no-figures", "--best-by", "max_tension")
    assert res.exit_code == 0, res.output
    summary = pd.read_csv(out / "summary.csv")
    assert {"max_tension_coupler1_N", "max_tension_coupler2_N",
            "max_compression_coupler2_N"} <= set(summary.columns)
    assert not any(re.search(r"c0|coupler0", c) for c in summary.columns)
    norms = pd.read_csv(out / "phase_norms.csv")
    assert set(norms.phase) == {WHOLE_RUN}
    assert set(norms.dropna(subset=["coupler or vehicle (1 = lead end)"])
               ["coupler or vehicle (1 = lead end)"]) == {1, 2, 3}
    assert set(norms.unit) == {"N", "m/s^2", "m/s"}
    # every case ran 2 s: its peak tension is that of a 2 s run
    for stiffness, row in zip((2e6, 8e6), summary.itertuples()):
        sc = ltdsim.load_scenario(ROOT / "scenarios" / "two-wagons-linear.toml").with_overrides(
            {"couplers.default.stiffness": stiffness, "solver.t_end": 2.0})
        f = ltdsim.simulate(sc).coupler_force.values
        assert_allclose(row.max_tension_N, f.max(), rtol=1e-5)
