"""The analysis commands (phases, modal, spectrum, sysid) refuse in one line what they
cannot analyse, before the work (issue 37): a train of one vehicle, windows outside the
record or with too few samples, forces that are not finite, output names taken; what
they write is valid (JSON without NaN) and numbers couplers, vehicles and modes from 1."""

import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

import ltdsim
from ltdsim.cli.app import app

from conftest import ROOT, build, cli_refused, train_dict

RUNNER = CliRunner()
SHORT = ROOT / "scenarios" / "short-train.toml"
ANALYSES = ("phases", "modal", "spectrum", "sysid")


def cli_ok(*args) -> str:
    res = RUNNER.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.stdout + res.stderr
    return res.stdout


def refuse_work(*a, **k):
    raise AssertionError("the work started although the input was refused")


def train_toml(path, vehicles=3, t_end=2.0, output_interval=0.01, phases=()):
    """A force-driven train of ``vehicles`` 90 t vehicles, linear couplers, as a file."""
    text = [f'name = "test"\n[solver]\nmethod = "ode3"\ndt = 1e-3\nt_end = {t_end}\n'
            f"output_interval = {output_interval}\n"]
    for i in range(vehicles):
        text.append(f'[[vehicles]]\nname = "v{i + 1}"\nmass = 9e4\nlength = 15.0\n'
                    + ("powered = true\n" if i == 0 else ""))
    text.append('[couplers.default]\nmodel = "linear"\nstiffness = 5e7\ndamping = 2e5\n'
                "[traction]\nmax_force = 3e5\nmax_power = 6.4e6\nadhesion_mass = 9e4\n"
                '[driver]\nmode = "force"\nforce_profile = [[0.0, 1e5]]\n')
    for name, start, end in phases:
        text.append(f'[[phases]]\nname = "{name}"\nstart = {start}\nend = {end}\n')
    path.write_text("".join(text))
    return path


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """A 2 s result of three vehicles, recorded every 0.01 s."""
    ds = ltdsim.simulate(build(train_dict([9e4, 9e4, 9e4], t_end=2.0, dt=1e-3,
                                          output_interval=0.01)))
    return ltdsim.save_result(ds, tmp_path_factory.mktemp("res") / "three.nc")


@pytest.fixture
def no_simulation(monkeypatch):
    import ltdsim.cli.analyse

    # (raising=False: on a version that simulates otherwise the test fails, not errs)
    monkeypatch.setattr(ltdsim.cli.analyse, "simulate_shown", refuse_work, raising=False)


def edited(result, tmp_path, var, index):
    """A copy of ``result`` with ``var[index]`` set to NaN."""
    import xarray as xr

    with xr.open_dataset(result) as ds:
        ds = ds.load()
    x = ds[var].values.copy()
    x[index] = np.nan
    ds[var] = (ds[var].dims, x, ds[var].attrs)
    path = tmp_path / "edited.nc"
    ds.to_netcdf(path)
    return path, float(ds.time[index[0]])


# -- 1: a train of one vehicle
@pytest.mark.parametrize("command", ANALYSES)
def test_one_vehicle_is_refused_before_the_run(tmp_path, no_simulation, command):
    one = train_toml(tmp_path / "one.toml", vehicles=1)
    msg = cli_refused(command, one, "-o", tmp_path / "out")
    assert f"error (invalid input): {one}: vehicles: ltdsim {command} needs at least 2 " \
           "vehicles (one coupler)" in msg, msg
    assert msg.endswith("the train has 1"), msg
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["phases", "spectrum", "sysid"])
def test_one_vehicle_result_is_refused(tmp_path, command):
    ds = ltdsim.simulate(build(train_dict([9e4], t_end=1.0, dt=1e-3, output_interval=0.01)))
    nc = ltdsim.save_result(ds, tmp_path / "one.nc")
    msg = cli_refused(command, nc, "-o", tmp_path / "out")
    assert f"{nc}: vehicles: ltdsim {command} needs at least 2 vehicles" in msg, msg
    assert not (tmp_path / "out").exists()


# -- 2: modal into a folder it (or another analysis) wrote before
def test_modal_runs_again_into_a_folder_holding_csvs(tmp_path, result):
    out = tmp_path / "out"
    cli_ok("phases", result, "-o", out, "-q")
    # (the record of written files is shared: modal adds its own files to it)
    theirs = {p.name: p.read_bytes() for p in out.iterdir()
              if p.name != "ltdsim-analysis-files.json"}
    first = cli_ok("modal", SHORT, "-o", out)
    table = (out / "modes_draft.csv").read_text()
    assert cli_ok("modal", SHORT, "-o", out) == first
    assert (out / "modes_draft.csv").read_text() == table
    cli_ok("modal", SHORT, "-o", out, "--stiffness", "buff")
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.name in theirs} == theirs


# -- 3: spectrum (and sysid) on values that are not finite
def test_spectrum_refuses_nan_forces_naming_the_first(tmp_path, result):
    path, t = edited(result, tmp_path, "coupler_force", (57, 1))
    msg = cli_refused("spectrum", path, "--couplers", "1,2", "-o", tmp_path / "out")
    assert f"{path}: coupler_force: not finite (nan) at t = {t:g} s, coupler 2 (the first " \
           "such sample); ltdsim spectrum needs finite values" in msg, msg
    assert not (tmp_path / "out").exists()
    cli_ok("spectrum", path, "--couplers", "1", "-o", tmp_path / "out", "-q")  # not analysed


def test_sysid_refuses_a_nan_acceleration_of_vehicle_2(tmp_path, result):
    path, t = edited(result, tmp_path, "acceleration", (120, 1))
    msg = cli_refused("sysid", path, "-o", tmp_path / "out")
    assert f"{path}: acceleration: not finite (nan) at t = {t:g} s, vehicle 2" in msg, msg


# -- 4: phases outside the record, refused by spectrum as by phases
def test_spectrum_refuses_phases_outside_the_record_as_phases_does(tmp_path, no_simulation):
    late = train_toml(tmp_path / "late.toml", phases=[("later", 10.0, 20.0)])
    said = [cli_refused(command, late, "-o", tmp_path / command)
            for command in ("phases", "spectrum")]
    for msg in said:
        assert f"{late}: phases: no phase (later 10-20 s) overlaps the record (0-2 s)" in msg
    assert said[0] == said[1]


# -- 5: too few samples for the analysis; JSON without NaN or Infinity
def test_spectrum_refuses_a_window_too_short_for_a_line_within_10_hz(tmp_path, no_simulation):
    tiny = train_toml(tmp_path / "tiny.toml", t_end=0.05)
    msg = cli_refused("spectrum", tiny, "-o", tmp_path / "out")
    assert f"{tiny}: solver.t_end: the whole run (0-0.05 s) holds 5 samples (one every " \
           "0.01 s); a spectrum to 10 Hz needs at least 10 (0.1 s)" in msg, msg
    gap = train_toml(tmp_path / "gap.toml", output_interval=0.5,
                     phases=[("between", 0.6, 0.9)])
    msg = cli_refused("spectrum", gap, "-o", tmp_path / "out")
    assert "phases: phase between (0.6-0.9 s) holds 0 samples" in msg, msg
    assert "needs at least 3" in msg


def test_spectrum_of_the_shortest_window_allowed_runs(tmp_path):
    ten = train_toml(tmp_path / "ten.toml", t_end=0.1)
    cli_ok("spectrum", ten, "-o", tmp_path / "out", "-q")
    assert (tmp_path / "out" / "phase_spectra.csv").is_file()


def test_phases_refuses_a_phase_between_two_samples(tmp_path, no_simulation):
    gap = train_toml(tmp_path / "gap.toml", output_interval=0.5,
                     phases=[("between", 0.6, 0.9)])
    msg = cli_refused("phases", gap, "-o", tmp_path / "out")
    assert f"{gap}: phases: phase between (0.6-0.9 s) holds no recorded sample (one every " \
           "0.5 s); its norms need at least 1" in msg, msg


def test_sysid_refuses_fewer_samples_than_its_parameters_need(tmp_path, no_simulation,
                                                              result):
    tiny = train_toml(tmp_path / "tiny.toml", t_end=0.03)
    msg = cli_refused("sysid", tiny, "-o", tmp_path / "out")
    assert f"{tiny}: solver.t_end: the record holds 4 samples (one every 0.01 s); " \
           "identifying 8 parameters (4 poles, 3 zeros and the feed-through) needs at " \
           "least 24" in msg, msg
    msg = cli_refused("sysid", tiny, "--poles", "1", "--zeros", "0", "-o", tmp_path / "out")
    assert "needs at least 6" in msg, msg
    # resampled every 0.1 s, the 2 s record holds 21 samples
    msg = cli_refused("sysid", result, "--resample-dt", "0.1", "-o", tmp_path / "out")
    assert "the record holds 21 samples every 0.1 s (--resample-dt)" in msg, msg
    assert "a smaller --resample-dt" in msg


def strict_json(text):
    def refuse(word):
        raise AssertionError(f"not valid JSON: {word}")
    return json.loads(text, parse_constant=refuse)


def test_sysid_json_is_valid_json_with_null_and_the_reason(tmp_path, result):
    out = tmp_path / "out"
    shown = cli_ok("sysid", result, "-o", out, "-q")
    data = strict_json((out / "sysid.json").read_text())
    # force -> acceleration has a DC gain far from 1: its ramp error does not settle
    assert data["ramp_steady_state_error"] is None
    assert data["null"]["ramp_steady_state_error"].startswith("inf: the ramp response does "
                                                              "not settle")
    assert "ramp_steady_state_error is inf: the ramp response" in shown
    assert all(np.isfinite(data[k]) for k in ("fpe", "mse", "fit_percent", "cost"))


# -- 7: the names the commands write, taken
WRITES = {"phases": "critical_couplers.csv", "spectrum": "spectrogram.png",
          "sysid": "sysid.json", "modal": "modes_draft.csv"}
#: (modal simulates nothing: it has no progress to quiet)
QUIET = {c: () if c == "modal" else ("-q",) for c in WRITES}


@pytest.mark.parametrize("command", WRITES)
def test_a_folder_where_an_analysis_writes_a_file_is_refused(tmp_path, no_simulation,
                                                             command):
    out = tmp_path / "out"
    (out / WRITES[command]).mkdir(parents=True)
    msg = cli_refused(command, train_toml(tmp_path / "t.toml"), "-o", out)
    assert f"--output: {out / WRITES[command]} is a folder where this command writes a " \
           "file" in msg, msg
    assert [p.name for p in out.iterdir()] == [WRITES[command]]


@pytest.mark.parametrize("command", WRITES)
def test_a_file_the_analysis_did_not_write_is_left_alone(tmp_path, no_simulation, command):
    out = tmp_path / "out"
    out.mkdir()
    theirs = out / WRITES[command]
    theirs.write_text("someone's notes")
    msg = cli_refused(command, train_toml(tmp_path / "t.toml"), "-o", out)
    assert f"--output: {theirs} exists and is not a file an earlier ltdsim {command} wrote " \
           f"there (or it changed since); ltdsim {command} does not write over it" in msg, msg
    assert theirs.read_text() == "someone's notes"
    assert [p.name for p in out.iterdir()] == [theirs.name]


@pytest.mark.parametrize("command", WRITES)
def test_an_analysis_runs_again_into_its_folder_but_not_over_a_changed_file(tmp_path, result,
                                                                           command):
    out = tmp_path / "out"
    cli_ok(command, result, "-o", out, *QUIET[command])
    written = sorted(p.name for p in out.iterdir())
    assert WRITES[command] in written and "ltdsim-analysis-files.json" in written
    cli_ok(command, result, "-o", out, *QUIET[command])
    assert sorted(p.name for p in out.iterdir()) == written
    (out / WRITES[command]).write_text("edited by hand")
    msg = cli_refused(command, result, "-o", out)
    assert f"{out / WRITES[command]} exists and is not a file" in msg, msg
    assert (out / WRITES[command]).read_text() == "edited by hand"


def test_analyses_share_a_folder_and_a_foreign_record_is_refused(tmp_path, result):
    out = tmp_path / "out"
    for command in WRITES:
        cli_ok(command, result, "-o", out, *QUIET[command])
    for command in WRITES:  # each still knows its files beside the others'
        cli_ok(command, result, "-o", out, *QUIET[command])
    record = out / "ltdsim-analysis-files.json"
    record.write_text("{}")
    msg = cli_refused("sysid", result, "-o", out)
    assert f"--output: {record} is not the record of files ltdsim writes there" in msg, msg
    assert record.read_text() == "{}"


# -- 6: couplers, vehicles and modes counted from 1
def test_what_the_analyses_print_and_write_counts_from_1(tmp_path, result):
    out = tmp_path / "out"
    text = [cli_ok(c, result, "-o", out, "-q") for c in ("phases", "spectrum", "sysid")]
    text.append(cli_ok("modal", result, "-o", out))
    text += [p.read_text() for p in out.iterdir() if p.suffix in (".csv", ".json")]
    for t in text:
        assert re.search(r"\b(coupler|vehicle)s? 0\b", t) is None, t
        assert "vehicle_0" not in t and "coupler_0" not in t
    import pandas as pd

    for name, col, n in (("phase_norms_couplers.csv", "coupler (1 = behind the lead)", 2),
                         ("phase_norms_vehicles.csv", "vehicle (1 = lead)", 3)):
        assert sorted(set(pd.read_csv(out / name)[col])) == list(range(1, n + 1))
    assert list(pd.read_csv(out / "modes_draft.csv")["mode (1 = lowest)"]) == [1, 2, 3]


def test_the_mode_shape_figure_numbers_modes_as_the_table(tmp_path, monkeypatch):
    import ltdsim.viz.plotting
    from ltdsim.analysis.modal import train_modes
    from ltdsim.viz.analysis import save_mode_shapes

    figures = []
    monkeypatch.setattr(ltdsim.viz.plotting, "_save", lambda fig, path: figures.append(fig))
    table = train_modes(ltdsim.load_scenario(SHORT), "draft")  # mode 1: 0 Hz, not drawn
    save_mode_shapes(table, tmp_path / "a.png", table_numbers=True)
    save_mode_shapes(table, tmp_path / "b.png")
    titles = [[ax.get_title(loc="left") for ax in f.axes if ax.get_visible()] for f in figures]
    assert [t.split(":")[0] for t in titles[0]] == ["mode 2", "mode 3", "mode 4", "mode 5"]
    assert titles[0][0] == f"mode 2: {table.frequency_hz[1]:.2f} Hz"
    assert "mode 1 at 0 Hz" in figures[0]._suptitle.get_text()
    assert [t.split(":")[0] for t in titles[1]] == ["mode 1", "mode 2", "mode 3", "mode 4"]


# -- 8: scipy's words are not options
RATINGS = ["gear", "ratings", "--travel", "0.083", "--force", "2.27e6"]


@pytest.mark.parametrize("capacity", ["1000", "1.8e5"])
def test_gear_ratings_names_the_capacity_range_not_the_root_finder(capacity):
    msg = cli_refused(*RATINGS, "--capacity", capacity, "--absorptivity", "0.8")
    assert "f(a)" not in msg and "--f" not in msg, msg
    assert "ratings: --capacity: must lie between 2385.32 and 167345 J for this travel, " \
           "force and preload" in msg, msg


def test_gear_ratings_names_the_absorptivity_range():
    msg = cli_refused(*RATINGS, "--capacity", "1.67e5", "--absorptivity", "1e-9")
    assert "ratings: --absorptivity: must lie between" in msg and "got 1e-09" in msg, msg
    msg = cli_refused(*RATINGS, "--capacity", "5e4", "--absorptivity", "0.999")
    assert "ratings: --absorptivity: must be at most 0.998969 for this force and capacity" \
           in msg, msg
    assert "ValidationError" not in msg
    cli_ok(*RATINGS, "--capacity", "5e4", "--absorptivity", "0.998")


def test_modal_reports_a_failed_eigensolver_in_plain_words(tmp_path, monkeypatch):
    import ltdsim.analysis.modal

    def fails(*a, **k):
        raise np.linalg.LinAlgError("The leading minor of order 3 of B is not positive")
    monkeypatch.setattr(ltdsim.analysis.modal, "train_modes", fails)
    msg = cli_refused("modal", SHORT, "-o", tmp_path / "out")
    assert f"error (invalid input): {SHORT}: the modes could not be computed: scipy's " \
           "eigensolver failed" in msg, msg
    assert "--The" not in msg and "--stiffness:" not in msg


# -- a run that would not record what the analysis reads
@pytest.mark.parametrize("command, missing", [
    ("sysid", "acceleration"), ("spectrum", "coupler_deflection"),
    ("phases", "acceleration, speed_error, velocity, relative_position, relative_velocity")])
def test_an_analysis_refuses_a_run_whose_record_leaves_out_what_it_reads(tmp_path, command,
                                                                         missing):
    out = tmp_path / "out"
    msg = cli_refused(command, SHORT, "--set", 'solver.record=["coupler_force"]', "-o", out)
    assert f"solver.record: ltdsim {command} reads {missing}, which the run would not " \
           "record (solver.record: coupler_force)" in msg, msg
    assert not out.exists()
