"""Bad input to the CLI refused before the work in one line naming the file, key or option
and its range (exit code 2, no traceback); what is refused is left as it was, and what is
allowed still runs."""

import sys

import pytest
from typer.testing import CliRunner

from ltdsim.cli.app import app

from conftest import ROOT, cli_refused

RUNNER = CliRunner()
SHORT = ROOT / "scenarios" / "short-train.toml"
RATINGS = ["gear", "ratings", "--travel", "0.083", "--force", "2.27e6", "--capacity", "5e4",
           "--absorptivity", "0.8"]




def cli_ok(*args) -> str:
    res = RUNNER.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.stdout + res.stderr
    return res.stdout


class Started(Exception):
    """Raised by a stand-in for the work: the command passed its checks."""


def refuse_work(*a, **k):
    raise AssertionError("the work started although the input was refused")


# -- 1: gear ratings --toml never writes over an existing file (nor does reduce --toml)
def test_gear_ratings_refuses_an_existing_toml_and_leaves_it_as_it_was(tmp_path):
    scenario = tmp_path / "mine.toml"
    scenario.write_text(SHORT.read_text())
    msg = cli_refused(*RATINGS, "--toml", scenario)
    assert f"error (invalid input): --toml: {scenario} exists" in msg, msg
    assert "does not write over an existing file" in msg
    assert scenario.read_text() == SHORT.read_text()
    cli_ok(*RATINGS, "--toml", tmp_path / "new.toml")  # a new file is still written
    assert 'model = "table"' in (tmp_path / "new.toml").read_text()


def test_reduce_refuses_an_existing_toml_before_the_fit(tmp_path, monkeypatch):
    import ltdsim.analysis.reduction

    monkeypatch.setattr(ltdsim.analysis.reduction, "reduce_gear", refuse_work)
    scenario = tmp_path / "mine.toml"
    scenario.write_text(SHORT.read_text())
    msg = cli_refused("reduce", "--preset", "mt-2", "--toml", scenario,
                      "--plot", tmp_path / "fig.png")
    assert f"--toml: {scenario} exists" in msg, msg
    assert scenario.read_text() == SHORT.read_text()
    assert not (tmp_path / "fig.png").exists()


def test_reduce_refuses_a_search_that_could_outlast_max_time(tmp_path):
    msg = cli_refused("reduce", "--preset", "mt-2", "--max-time", "0.01",
                      "--plot", tmp_path / "fig.png")
    assert "--max-time: the search takes up to about" in msg, msg
    assert "beyond the limit of 0.01 s" in msg and "lower --maxiter" in msg
    assert not (tmp_path / "fig.png").exists()


# -- 2: run --report writes only into a folder of its own
CURVED = """name = "pushed"
[solver]
method = "rk4"
dt = 1e-3
t_end = 2.0
output_interval = 0.5
[[vehicles]]
name = "wagon"
count = 3
mass = 8e4
length = 15.0
[[vehicles]]
name = "loco"
mass = 1.2e5
length = 20.0
powered = true
[couplers.default]
model = "linear"
stiffness = 5e7
damping = 1e6
[track]
curve = [[-200.0, 0.0], [-150.0, -250.0]]
transitions = [[-150.0, 30.0]]
[traction]
max_force = 1e8
max_power = 1e9
adhesion_mass = 1e8
[driver]
mode = "force"
force_profile = [[0.0, 0.0], [1.0, 6e5]]
[initial]
speed = 5.0
"""


def test_run_report_refuses_a_folder_holding_a_page_it_did_not_write(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules["ltdsim.results.simulate"], "simulate", refuse_work)
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "index.html").write_text("<html>my notes</html>")
    msg = cli_refused("run", SHORT, "-q", "--report", rep)
    assert f"error (invalid input): --report: {rep} holds what ltdsim run --report did " \
           "not write (index.html)" in msg, msg
    assert (rep / "index.html").read_text() == "<html>my notes</html>"
    assert sorted(p.name for p in rep.iterdir()) == ["index.html"]


def test_run_report_replaces_its_own_report_and_leaves_no_earlier_figure(tmp_path):
    curved, straight = tmp_path / "curved.toml", tmp_path / "straight.toml"
    curved.write_text(CURVED + "[curving]\n")
    straight.write_text(CURVED)
    rep = tmp_path / "rep"
    cli_ok("run", curved, "-q", "--report", rep)
    assert (rep / "curving.png").is_file() and (rep / "curving_worst.csv").is_file()
    cli_ok("run", straight, "-q", "--report", rep)  # the same folder again: its own
    names = sorted(p.name for p in rep.iterdir())
    assert names == ["couplers.csv", "index.html", "run-report.json"], names
    assert "curving" not in (rep / "index.html").read_text()
    # a file of the report changed by someone since is theirs: refused, kept
    (rep / "couplers.csv").write_text("edited by hand\n")
    msg = cli_refused("run", straight, "-q", "--report", rep)
    assert "--report:" in msg and "(couplers.csv)" in msg, msg
    assert (rep / "couplers.csv").read_text() == "edited by hand\n"


# -- 3: sweep checks the tables it writes at the end before running any case
@pytest.mark.parametrize("name", ["summary.csv", "phase_norms.csv"])
def test_sweep_refuses_a_folder_where_it_writes_a_table_before_any_case(tmp_path, monkeypatch,
                                                                       name):
    from ltdsim.sweep import core as sw

    monkeypatch.setattr(sw, "run_sweep", refuse_work)
    spec = tmp_path / "sw.toml"
    spec.write_text(f'scenario = "{SHORT}"\n[overrides]\n"solver.t_end" = 1.0\n'
                    '[list]\n"vehicles.1.mass" = [8e4, 9e4]\n')
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    msg = cli_refused("sweep", spec, "-o", out, "--workers", "1")
    assert f"error (invalid input): --output: {out / name} is a folder where this command " \
           "writes a file" in msg, msg
    assert not (out / "cases").exists()


TWO_WAGONS = ROOT / "scenarios" / "two-wagons-linear.toml"


def two_case_sweep(tmp_path):
    spec = tmp_path / "sw.toml"
    spec.write_text(f'scenario = "{TWO_WAGONS}"\n[overrides]\n"solver.t_end" = 2.0\n'
                    '[list]\n"couplers.default.stiffness" = [2e6, 8e6]\n')
    return spec


@pytest.mark.parametrize("name", ["summary.csv", "phase_norms.csv",
                                  "figures/l0001_fig6_forces.png"])
def test_sweep_refuses_someone_elses_file_where_it_writes_before_any_case(tmp_path,
                                                                         monkeypatch, name):
    from ltdsim.sweep import core as sw

    monkeypatch.setattr(sw, "run_sweep", refuse_work)
    out = tmp_path / "out"
    theirs = out / name
    theirs.parent.mkdir(parents=True)
    theirs.write_text("someone's notes")
    msg = cli_refused("sweep", two_case_sweep(tmp_path), "-o", out, "--workers", "1")
    assert f"error (invalid input): --output: {theirs} exists and is not a file an earlier " \
           "ltdsim sweep wrote there (or it changed since); ltdsim sweep does not write " \
           "over it" in msg, msg
    assert theirs.read_text() == "someone's notes"
    assert not (out / "cases").exists()


def test_sweep_leaves_other_files_in_its_figures_folder_alone(tmp_path, monkeypatch):
    from ltdsim.sweep import core as sw

    monkeypatch.setattr(sw, "run_sweep", lambda *a, **k: (_ for _ in ()).throw(Started()))
    figures = tmp_path / "out" / "figures"
    figures.mkdir(parents=True)
    for name in ("notes.txt", "l9999_fig6_forces.png", "fig6_forces.png"):  # not a case's
        (figures / name).write_text("someone's")
    res = RUNNER.invoke(app, ["sweep", str(two_case_sweep(tmp_path)), "-o",
                              str(tmp_path / "out"), "--workers", "1"])
    assert isinstance(res.exception, Started), res.stdout + res.stderr


def test_sweep_runs_again_and_resumes_into_its_folder_but_not_over_an_edited_table(tmp_path):
    spec, out = two_case_sweep(tmp_path), tmp_path / "out"
    args = ("sweep", spec, "-o", out, "--workers", "1", "--best-by", "max_tension")
    cli_ok(*args)
    best = [p.name for p in (out / "figures").iterdir() if p.suffix == ".png"]
    assert len(best) == 3, best
    first = (out / "summary.csv").read_text()
    done = (out / "cases" / "l0000.json").stat().st_mtime_ns
    cli_ok(*args)  # everything finished: its own tables and figures are written again
    assert (out / "summary.csv").read_text() == first
    assert (out / "cases" / "l0000.json").stat().st_mtime_ns == done  # not run again
    # an interrupted sweep (a case not finished, no tables yet) resumes with the rest
    (out / "cases" / "l0001.json").unlink()
    (out / "summary.csv").unlink()
    cli_ok(*args)
    assert (out / "summary.csv").read_text() == first
    assert (out / "cases" / "l0000.json").stat().st_mtime_ns == done
    # a table edited since is someone's: refused before any case, and kept
    (out / "summary.csv").write_text("edited by hand\n")
    msg = cli_refused(*args)
    assert f"--output: {out / 'summary.csv'} exists and is not a file an earlier ltdsim " \
           "sweep wrote there" in msg, msg
    assert (out / "summary.csv").read_text() == "edited by hand\n"


# -- 4: gear --help names its three commands
def test_gear_help_names_loop_impact_and_ratings():
    text = " ".join(cli_ok("gear", "--help").split("Options")[0].split())
    for command in ("loop (", "impact (", "ratings ("):
        assert command in text, text


# -- 5: gear loop refuses a recording too long for the memory, before allocating it
def test_gear_loop_refuses_a_period_times_cycles_too_long_to_record(tmp_path, monkeypatch):
    import ltdsim.analysis.gears as gears

    monkeypatch.setattr(gears, "drive_deflection", refuse_work)
    msg = cli_refused("gear", "loop", "--preset", "mt-2", "--period", "3600", "--cycles", "100",
                      "--plot", tmp_path / "loop.png")
    assert "error (invalid input): --period x --cycles: 3600 s x 100 = 360000 s would record " \
           "3,600,000,001 samples" in msg, msg
    assert "at most 3600 s (36,000,001 samples)" in msg
    assert not (tmp_path / "loop.png").exists()


def test_gear_loop_allows_the_longest_period_for_one_cycle(tmp_path, monkeypatch):
    import ltdsim.analysis.gears as gears

    def started(params, t, d, **k):
        assert len(t) == 3_600_001  # (the 1 ms table; the rig then records 36,000,001)
        raise Started
    monkeypatch.setattr(gears, "drive_deflection", started)
    res = RUNNER.invoke(app, ["gear", "loop", "--preset", "mt-2", "--period", "3600",
                              "--cycles", "1", "--plot", str(tmp_path / "loop.png")])
    assert isinstance(res.exception, Started), res.stdout + res.stderr


# -- 6: gear impact refuses a wagon too light for the impact's step
def test_gear_impact_refuses_a_mass_too_light_for_the_step_with_the_allowed_range(tmp_path):
    from ltdsim.analysis.gears import lightest_impact_mass
    from ltdsim.scenario import CouplerParams

    lightest = lightest_impact_mass(CouplerParams(preset="mt-2"))
    assert 1.0 < lightest < 100.0  # kg: far below any wagon
    msg = cli_refused("gear", "impact", "--preset", "mt-2", "--mass", "1e-6", "--speeds", "1",
                      "--csv", tmp_path / "i.csv")
    assert f"error (invalid input): --mass: must be a number in [{lightest:g}, 1e+06] kg " \
           "(got 1e-06)" in msg, msg
    assert not (tmp_path / "i.csv").exists()
    cli_ok("gear", "impact", "--preset", "mt-2", "--mass", f"{lightest:g}", "--speeds", "1",
           "--csv", tmp_path / "i.csv")  # the lightest allowed runs
    assert (tmp_path / "i.csv").is_file()


# -- 7: gear ratings --series within the coupler key gears' range
@pytest.mark.parametrize("series", ["1000000", "3", "0"])
def test_gear_ratings_refuses_a_series_outside_the_gears_key(tmp_path, series):
    msg = cli_refused(*RATINGS, "--series", series, "--toml", tmp_path / "g.toml")
    assert f"error (invalid input): --series: must be a whole number from 1 to 2 " \
           f"(got {series})" in msg, msg
    assert not (tmp_path / "g.toml").exists()


def test_gear_ratings_with_two_gears_in_series_writes_gears_2(tmp_path):
    cli_ok(*RATINGS, "--series", "2", "--toml", tmp_path / "g.toml")
    assert "gears = 2 " in (tmp_path / "g.toml").read_text()


# -- 8: modal checks the files it writes before the work, and runs again into its folder
@pytest.mark.parametrize("name", ["modes_draft.csv", "mode_shapes_draft.png"])
def test_modal_refuses_a_folder_where_it_writes_a_file(tmp_path, monkeypatch, name):
    import ltdsim.analysis.modal

    monkeypatch.setattr(ltdsim.analysis.modal, "train_modes", refuse_work)
    out = tmp_path / "modal"
    (out / name).mkdir(parents=True)
    msg = cli_refused("modal", SHORT, "-o", out)
    assert f"error (invalid input): --output: {out / name} is a folder where this command " \
           "writes a file" in msg, msg
    assert sorted(p.name for p in out.iterdir()) == [name]


def test_modal_runs_twice_into_the_same_folder(tmp_path):
    out = tmp_path / "modal"
    first = cli_ok("modal", SHORT, "-o", out)
    table = (out / "modes_draft.csv").read_text()
    assert cli_ok("modal", SHORT, "-o", out) == first
    assert (out / "modes_draft.csv").read_text() == table
    assert sorted(p.name for p in out.iterdir()) == ["ltdsim-analysis-files.json",
                                                      "mode_shapes_draft.png", "modes_draft.csv"]
