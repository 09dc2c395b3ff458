"""Bad input fails at load time with one clear message naming file, key and range."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import ltdsim
from ltdsim import ScenarioError, SimulationError

from conftest import ROOT, build, cli_refused, traced_peak, train_dict

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
    proc = subprocess.run([sys.executable, "-m", "ltdsim.cli.app", "run", str(bad), "-q"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr + proc.stdout
    assert "vehicles.1.mass" in proc.stderr and "bad.toml" in proc.stderr


def test_a_diverging_simulation_stops_and_names_time_vehicle_and_values():
    # explicit Euler far beyond its stability limit: k/m = 1e5 1/s^2 at dt = 0.01 s
    d = train_dict([1e4, 1e4, 1e4], t_end=100.0, dt=1e-2, method="euler",
                   coupler={"model": "linear", "stiffness": 1e9, "damping": 0.0, "slack": 0.0})
    d["solver"]["stability_check"] = False  # (else refused before the run: see below)
    with pytest.raises(SimulationError) as info:
        ltdsim.simulate(build(d))
    err = info.value
    assert 0.0 < err.time < 100.0
    assert err.vehicle is not None and 0 <= err.vehicle < 3
    msg = str(err)
    # stopped where the state first went beyond a physical bound (or stopped being
    # finite), with the coupler's deflection or the vehicle's speed
    assert f"t = {err.time:.6g} s" in msg
    assert ("blew up" in msg and ("deflected" in msg or "m/s" in msg)) or (
        "vehicle" in msg and "velocity" in msg)
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
    ("method = \"bs23\"", "method = \"bs23\"\nrecord = [\"forces\"]", "solver.record",
     "'coupler_force'"),
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
    cmd = [sys.executable, "-m", "ltdsim.cli.app", "gear", "ratings"]
    for k, v in base.items():
        cmd += [k, v]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr + proc.stdout
    assert key in proc.stderr


# -- issue 13: reading and types
# Bad files and values of the wrong TOML type are refused in one line naming the file and
# the key, exit code 2, no traceback.
from typer.testing import CliRunner

from ltdsim.cli.app import app

RUNNER = CliRunner()
SHORT = ROOT / "scenarios" / "short-train.toml"




@pytest.mark.parametrize("name, content, words", [
    ("string.toml", b'name = "caf\xe9"\n', "byte 0xe9 at line 1, column 12"),
    ("comment.toml", b"# \xff comment\n" + EXAMPLE.encode(), "byte 0xff at line 1, column 3"),
    ("binary.toml", bytes(range(256)) * 4, "binary file"),
])
def test_a_file_that_is_not_utf8_text_is_named_with_the_place(tmp_path, name, content, words):
    p = tmp_path / name
    p.write_bytes(content)
    msg = cli_refused("run", p, "-q")
    assert name in msg and words in msg and "UTF-8" in msg


def test_a_folder_a_missing_file_and_an_unreadable_file_are_named(tmp_path, monkeypatch):
    (tmp_path / "x.toml").mkdir()
    msg = cli_refused("run", tmp_path / "x.toml", "-q")
    assert "x.toml" in msg and "is a folder" in msg
    msg = cli_refused("sweep", tmp_path / "x.toml", "-o", tmp_path / "out")
    assert "x.toml" in msg and "is a folder" in msg
    msg = cli_refused("run", tmp_path / "gone.toml", "-q")
    assert "gone.toml" in msg and "file not found" in msg
    # permission denied (the tests may run as root, who reads any file: simulate it)
    p = tmp_path / "locked.toml"
    p.write_text(EXAMPLE)

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", denied)
    msg = cli_refused("run", p, "-q")
    assert "locked.toml" in msg and "permission denied" in msg


@pytest.mark.parametrize("old, new, key, kind", [
    ("mass = 90000.0", "mass = true", "vehicles.1.mass", "must be a number"),
    ("powered = true", 'powered = "yes"', "vehicles.0.powered", "must be true or false"),
    ("powered = true", "powered = 1", "vehicles.0.powered", "must be true or false"),
    ("dt = 1e-4", 'dt = "1e-4"', "solver.dt", "must be a number"),
    ("count = 4", "count = true", "vehicles.1.count", "must be a whole number"),
    ("count = 4", "count = 4.0", "vehicles.1.count", "must be a whole number"),
    ('name = "wagon"', "name = 7", "vehicles.1.name", "must be a string"),
    ("k1 = 8.265776e6", 'k1 = "8.265776e6"', "couplers.default.k1", "must be a number"),
    ("index = 3", "index = true", "couplers.override.0.index", "must be a whole number"),
    ("[300.0, 0.005]", "[300.0, true]", "track.gradient", "row 2, number 2: must be a number"),
    ("ts = 1e-4", "ts = false", "driver.pid.ts", "must be a number"),
])
def test_a_value_of_the_wrong_toml_type_is_refused_naming_its_key(tmp_path, old, new, key, kind):
    assert old in EXAMPLE
    msg = cli_refused("run", write(tmp_path, EXAMPLE.replace(old, new, 1)), "-q")
    assert f"bad.toml: {key}: {kind}" in msg, msg
    assert msg.count("bad.toml") == 1  # the key itself, not a knock-on error elsewhere


@pytest.mark.parametrize("rows, says", [
    ("[[0.0, 0.0, 1.0]]", "row 1 has 3 numbers, at most 2 allowed (got [0.0, 0.0, 1.0])"),
    ("[[0.0, 0.0], [300.0]]", "row 2 has 1 number, needs 2"),
])
def test_a_row_of_a_track_table_with_the_wrong_count_of_numbers_is_named_from_1(tmp_path, rows,
                                                                                says):
    line = "gradient = [[0.0, 0.0], [300.0, 0.005]]"
    assert line in EXAMPLE
    msg = cli_refused("run", write(tmp_path, EXAMPLE.replace(line, f"gradient = {rows}", 1)), "-q")
    assert f"bad.toml: track.gradient: {says}" in msg, msg


def test_an_integer_is_a_number_and_the_scenario_runs_the_same(tmp_path):
    # a TOML integer where a float is expected is a number too (mass = 90000)
    a = ltdsim.load_scenario(write(tmp_path, EXAMPLE.replace("mass = 90000.0", "mass = 90000")))
    assert a.vehicles[1].mass == 90000.0 and isinstance(a.vehicles[1].mass, float)


@pytest.mark.parametrize("item, key, kind", [
    ("vehicles.0.powered=yes", "vehicles.0.powered", "must be true or false"),
    ('solver.dt="1e-4"', "solver.dt", "must be a number"),
    ("vehicles.1.mass=true", "vehicles.1.mass", "must be a number"),
])
def test_set_overrides_follow_the_same_types(item, key, kind):
    msg = cli_refused("run", SHORT, "-q", "--set", item)
    assert f"--set: {key}: {kind}" in msg, msg


def test_case_and_sweep_tables_follow_the_same_types(tmp_path):
    msg = load_error(tmp_path, EXAMPLE + '\n[cases.flag]\n"vehicles.0.powered" = "no"\n')
    assert "[cases.flag]" in msg and "vehicles.0.powered" in msg and "true or false" in msg
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'scenario = "{SHORT}"\n[grid]\n"solver.dt" = [1e-4, "2e-4"]\n')
    msg = cli_refused("sweep", sweep, "-o", tmp_path / "out")
    assert "s.toml" in msg and "solver.dt" in msg and "must be a number" in msg


def test_a_case_problem_keeps_its_brackets_on_the_command_line(tmp_path):
    bad = write(tmp_path, EXAMPLE + '\n[cases.flag]\n"vehicles.0.powered" = "no"\n')
    msg = cli_refused("run", bad, "-q")
    assert "bad.toml [cases.flag]: vehicles.0.powered: must be true or false" in msg, msg


def test_odd_keys_are_shown_escaped_in_one_line(tmp_path):
    # found by the property test below: a control character in a key split the message,
    # a key holding "[" crashed the unknown-key message
    msg = load_error(tmp_path, EXAMPLE.replace('name = "short-train"',
                                               'name = "short-train"\n"odd\\u001e" = 1'))
    assert "unknown key 'odd\\x1e'" in msg and len(msg.splitlines()) == 1
    msg = load_error(tmp_path, EXAMPLE + '\n[cases.x]\n"[" = 1\n')
    assert "[cases.x]: [: unknown key '['" in msg


TABLE_GEAR = """
[couplers.default]
model = "table"
slack = 0.025
k_locked = 5e7
loading = [[0.0, 5e4], [0.05, 1.2e6], [0.08, 2.4e6]]
unloading = [[0.0, 2e4], [0.05, 0.6e6], [0.08, 1.6e6]]
"""


def _with_table_gear(loading: str) -> str:
    head, _, rest = EXAMPLE.partition("[couplers.default]")
    tail = rest[rest.index("[[couplers.override]]"):].replace("k3 = 7.998176e6",
                                                               "k_locked = 6e7")
    gear = TABLE_GEAR.replace("[[0.0, 5e4], [0.05, 1.2e6], [0.08, 2.4e6]]", loading)
    return head + gear + "\n" + tail


def test_a_falling_loading_curve_is_refused_naming_the_key_and_the_place(tmp_path):
    ltdsim.load_scenario(write(tmp_path, _with_table_gear(
        "[[0.0, 5e4], [0.05, 1.2e6], [0.08, 2.4e6]]")))  # the gear itself is valid
    flat = ltdsim.load_scenario(write(tmp_path, _with_table_gear(
        "[[0.0, 5e4], [0.05, 1.6e6], [0.08, 1.6e6]]")))  # level is allowed (non-decreasing)
    assert flat.coupler(0).loading[-1][1] == 1.6e6
    text = _with_table_gear("[[0.0, 5e4], [0.05, 2.4e6], [0.08, 1.7e6]]")
    msg = cli_refused("run", write(tmp_path, text), "-q")
    assert "couplers.default: loading: the force must not decrease" in msg, msg
    assert "from 2.4e+06 N at 0.05 m to 1.7e+06 N at 0.08 m" in msg


# bad options: each numeric option of each command is checked before any work
PAPER_TOML = ROOT / "scenarios" / "paper.toml"


@pytest.mark.parametrize("args, option, words", [
    (["modal", SHORT, "--stiffness", "-5"], "--stiffness", "(0, 1e12] N/m"),
    (["modal", SHORT, "--stiffness", "stiff"], "--stiffness", "draft, buff or a coupling"),
    (["spectrum", SHORT, "--couplers", "0,99"], "--couplers",
     "0, 99 out of range 1-4: couplers are numbered 1 to 4"),
    (["spectrum", SHORT, "--couplers", "one"], "--couplers", "not a list of coupler numbers"),
    (["sysid", SHORT, "--poles", "0"], "--poles", "from 1 to 20"),
    (["sysid", SHORT, "--zeros", "5"], "--zeros", "from 0 to 4"),
    (["sysid", SHORT, "--resample-dt", "-1"], "--resample-dt", "(0, 10] s"),
    (["gear", "loop", "--preset", "mt-2", "--amplitude", "-0.1"], "--amplitude", "(0, 1] m"),
    (["gear", "loop", "--preset", "mt-2", "--period", "0"], "--period", "[0.1, 3600] s"),
    (["gear", "loop", "--preset", "mt-2", "--cycles", "0"], "--cycles", "from 1 to 100"),
    (["gear", "impact", "--preset", "mt-2", "--speeds", "1,-1"], "--speeds", "(0, 30] m/s"),
    (["gear", "impact", "--preset", "mt-2", "--mass", "0"], "--mass", "(0, 1e+06] kg"),
    (["gear", "ratings", "--travel", "0.083", "--force", "2.27e6", "--capacity", "5e4",
      "--absorptivity", "0.8", "--slack", "-1"], "--slack", "[0, 1] m"),
    (["reduce", "--preset", "mt-2", "--mass", "-1"], "--mass", "(0, 1e+08] kg"),
    (["reduce", "--preset", "mt-2", "--dt", "0"], "--dt", "(0, 0.01] s"),
    (["reduce", "--preset", "mt-2", "--maxiter", "0"], "--maxiter", "from 1 to 1000000"),
    (["reduce", "--preset", "mt-2", "--seed", "-2"], "--seed", "from 0 to"),
    (["sweep", PAPER_TOML, "--workers", "-3"], "--workers", "from 1 to 1024"),
    (["sweep", PAPER_TOML, "--workers", "0"], "--workers", "from 1 to 1024"),
    (["study", PAPER_TOML, "--workers", "0"], "--workers", "from 1 to 1024"),
    (["sweep", PAPER_TOML, "--scheduler", "somewhere"], "--scheduler", "tcp://HOST:PORT"),
])
def test_a_bad_option_is_named_with_its_range_before_any_work(tmp_path, args, option, words):
    out = tmp_path / "out"
    extra = [] if args[0] == "gear" else ["-o", out]
    if args[:2] in (["gear", "loop"], ["gear", "ratings"]) or args[0] == "reduce":
        extra = ["--plot", tmp_path / "fig.png"]
    msg = cli_refused(*args, *extra)
    assert f"error (invalid input): {option}: " in msg and words in msg, msg
    assert not out.exists() and not (tmp_path / "fig.png").exists()


def test_an_unreachable_scheduler_is_refused_within_seconds(tmp_path):
    import socket
    import time

    with socket.socket() as s:  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.perf_counter()
    msg = cli_refused("sweep", PAPER_TOML, "--scheduler", f"tcp://127.0.0.1:{port}",
                  "-o", tmp_path / "out")
    assert time.perf_counter() - t0 < 30.0  # loading the 16 cases, then a 3 s connect
    assert "--scheduler" in msg and f"tcp://127.0.0.1:{port}" in msg and "cannot reach" in msg
    assert not (tmp_path / "out").exists()


def _listener(answer):
    """A TCP listener on 127.0.0.1 that treats each connection with ``answer(conn)``;
    returns (socket, port)."""
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held = []

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            answer(conn)

    threading.Thread(target=serve, daemon=True).start()
    return srv, srv.getsockname()[1]


@pytest.mark.parametrize("answer, why", [
    # bytes no Dask client can read (an HTTP server, say)
    (lambda c: c.sendall(b"HTTP/1.1 200 OK\r\n\r\n" + bytes(range(256)) * 8),
     ("does not speak Dask's protocol",)),
    # hangs up at once (a Dask client retries the connection until its time is up)
    (lambda c: c.close(), ("does not speak Dask's protocol", "no Dask answer within 3 s")),
    # accepts and says nothing: a Dask client's handshake would wait for ever
    (lambda c: None, ("no Dask answer within 3 s",)),
], ids=["garbage", "hangs-up", "silent"])
def test_a_listener_that_is_not_a_dask_scheduler_is_refused_within_seconds(tmp_path, answer,
                                                                           why):
    import time

    srv, port = _listener(answer)
    t0 = time.perf_counter()
    try:
        res = CliRunner().invoke(app, ["sweep", str(PAPER_TOML), "--scheduler",
                                       f"tcp://127.0.0.1:{port}", "-o", str(tmp_path / "out")])
    finally:
        srv.close()
    elapsed = time.perf_counter() - t0
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output + res.stderr
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    line = " ".join(res.stderr.split())
    assert line.startswith("error (invalid input): --scheduler: "), line
    assert f"tcp://127.0.0.1:{port} is not a Dask scheduler" in line, line
    assert any(w in line for w in why), line
    assert elapsed < 20.0  # loading the 16 cases, then at most a 3 s exchange
    assert not (tmp_path / "out").exists()


def test_a_dask_scheduler_is_accepted_and_a_dask_worker_is_not():
    distributed = pytest.importorskip("distributed")
    from ltdsim.cli.common import check_scheduler

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        check_scheduler(cluster.scheduler_address)  # no refusal
        worker = next(iter(cluster.scheduler_info["workers"]))
        with pytest.raises(ScenarioError) as info:
            check_scheduler(worker)
    assert f"{worker} is not a Dask scheduler (it is a Dask Worker)" in str(info.value)


@pytest.mark.parametrize("param, key, words", [
    ('{ dist = "normal", mean = 9e4, std = -1.0 }', "parameters.vehicles.1.mass.std",
     "must be 0 or more"),
    ('{ dist = "lognormal", mean = 11.4, sigma = -0.1 }', "parameters.vehicles.1.mass.sigma",
     "must be 0 or more"),
    ('{ dist = "uniform", low = 9e4, high = 8e4 }', "parameters.vehicles.1.mass.high",
     "at least low"),
    ('{ dist = "normal", mean = "9e4", std = 1.0 }', "parameters.vehicles.1.mass.mean",
     "must be a finite number"),
    ('{ dist = "normal", mean = 9e4, std = true }', "parameters.vehicles.1.mass.std",
     "must be a finite number"),
    ('{ dist = "normal", mean = 9e4, sd = 1.0, std = 1.0 }', "parameters.vehicles.1.mass.sd",
     "unknown key"),
])
def test_monte_carlo_parameters_are_checked(tmp_path, param, key, words):
    p = tmp_path / "mc.toml"
    p.write_text(f'scenario = "{SHORT}"\n[monte_carlo]\nsamples = 3\nseed = 1\n'
                 f'[monte_carlo.parameters]\n"vehicles.1.mass" = {param}\n')
    msg = cli_refused("sweep", p, "-o", tmp_path / "out")
    assert "mc.toml" in msg and f"monte_carlo.{key}" in msg and words in msg, msg


@pytest.mark.parametrize("line, key", [("samples = true", "samples"),
                                       ("seed = -4", "seed")])
def test_monte_carlo_samples_and_seed_are_whole_numbers(tmp_path, line, key):
    body = {"samples": "samples = 3", "seed": "seed = 1"}
    body[key] = line
    p = tmp_path / "mc.toml"
    p.write_text(f'scenario = "{SHORT}"\n[monte_carlo]\n{body["samples"]}\n{body["seed"]}\n'
                 '[monte_carlo.parameters]\n"vehicles.1.mass" = { dist = "normal", '
                 'mean = 9e4, std = 1e3 }\n')
    msg = cli_refused("sweep", p, "-o", tmp_path / "out")
    assert f"monte_carlo.{key}" in msg


# explicit fixed-step methods: the largest stable step (ltdsim.engine.preflight)
from ltdsim.engine.preflight import (
    WARN_SHARE,
    check,
    imaginary_radius,
    real_radius,
    step_limit,
)


def _taylor(order):
    """exp(z) truncated after z^order: the stability polynomial of every explicit RK
    method with as many stages as its order (euler, heun, ode3, rk4)."""
    import math

    return lambda z: sum(z**k / math.factorial(k) for k in range(order + 1))


@pytest.mark.parametrize("method, order", [("euler", 1), ("heun", 2), ("ode3", 3), ("rk4", 4)])
def test_stability_radii_from_the_tableaux_match_the_closed_forms(method, order):
    from scipy.optimize import brentq

    R = _taylor(order)
    # imaginary axis: |R(iy)|^2 = 1 + y^2 (euler), 1 + y^4/4 (heun): no stable interval;
    # 1 - y^4/12 + y^6/36 (ode3): sqrt(3); 1 - y^6/72 + y^8/576 (rk4): 2 sqrt(2)
    expected_imag = {1: 0.0, 2: 0.0, 3: np.sqrt(3.0), 4: 2.0 * np.sqrt(2.0)}[order]
    assert imaginary_radius(method) == pytest.approx(expected_imag, abs=1e-9)
    # negative real axis: the first x > 0 where |R(-x)| = 1
    x = brentq(lambda x: abs(R(-x)) - 1.0, 1.5, 3.0) if order > 2 else 2.0
    assert real_radius(method) == pytest.approx(x, rel=1e-9)
    assert abs(R(-0.99 * x)) < 1.0 < abs(R(-1.01 * x))


def _two_masses(method, dt, steps, damping, stability_check=True):
    d = train_dict([1.0e4, 1.5e4], force=0.0, dt=dt, t_end=steps * dt, method=method,
                   coupler={"model": "linear", "stiffness": 1.0e7, "damping": damping,
                            "slack": 0.0})
    d["initial"] = {"velocities": [0.5, -1.0 / 3.0]}  # no net momentum: a pure oscillation
    d["solver"]["stability_check"] = stability_check
    return d


def _growth(method, dt, steps, damping):
    """Largest |coupler force| over the last tenth of the run / over the first tenth
    (inf if the run diverged to non-finite values)."""
    try:
        ds = ltdsim.simulate(build(_two_masses(method, dt, steps, damping, False)))
    except SimulationError:
        return np.inf
    f = np.abs(ds.coupler_force.values[:, 0])
    k = len(f) // 10
    return f[-k:].max() / f[:k].max()


@pytest.mark.parametrize("method, damping, steps", [
    ("ode3", 0.0, 3000), ("rk4", 0.0, 3000),       # undamped: the imaginary axis
    ("euler", 5.0e4, 10000), ("heun", 2.0e4, 6000),  # damped (zeta = 0.10, 0.04)
])
def test_a_two_mass_train_diverges_just_above_the_limit_and_not_below(method, damping, steps):
    omega = np.sqrt(1.0e7 * (1 / 1.0e4 + 1 / 1.5e4))  # rad/s, the one oscillating mode
    lim = step_limit(build(_two_masses(method, 1e-4, 10, damping)))
    assert lim.omega == pytest.approx(omega, rel=1e-12)
    assert lim.zeta == pytest.approx(damping * omega / (2 * 1.0e7), rel=1e-12)
    if damping == 0.0:
        assert lim.limit == pytest.approx(imaginary_radius(method) / omega, rel=1e-9)
    if method == "euler":  # |1 + h lambda| = 1 at h = c / k
        assert lim.limit == pytest.approx(damping / 1.0e7, rel=1e-9)
    below, above = 0.97 * lim.limit, 1.03 * lim.limit
    check(build(_two_masses(method, below, steps, damping)))  # accepted
    with pytest.raises(ScenarioError, match="solver.dt"):
        check(build(_two_masses(method, above, steps, damping)))
    assert _growth(method, below, steps, damping) <= 1.0
    assert _growth(method, above, steps, damping) > 3.0


def test_the_issues_euler_run_is_refused_naming_the_key_and_the_largest_stable_step():
    lim = step_limit(ltdsim.load_scenario(SHORT).with_overrides({"solver.method": "euler"}))
    msg = cli_refused("run", SHORT, "-q", "--set", "solver.method=euler", "--set", "solver.dt=0.01",
                  "--set", "solver.output_interval=0.01", "--set", "driver.pid.ts=0.01")
    assert "--set: solver.dt: 0.01 s is above the largest stable step of euler" in msg
    assert f"{lim.limit:.3g} s" in msg and "ode3 (up to" in msg and "bs23" in msg


def test_a_step_near_the_limit_runs_with_a_warning():
    sc = ltdsim.load_scenario(SHORT).with_overrides({"solver.method": "euler"})
    assert WARN_SHARE < step_limit(sc).share <= 1.0  # euler at 1e-4 s: near its limit
    res = RUNNER.invoke(app, ["run", str(SHORT), "-q", "--set", "solver.method=euler",
                              "--set", "solver.t_end=0.2", "--set", "solver.output_interval=0.1"])
    assert res.exit_code == 0, res.output
    text = " ".join(res.stderr.split())
    assert "warning: solver.dt = 0.0001 s is" in text and "largest stable step of euler" in text


def test_no_shipped_scenario_or_study_case_is_near_its_limit_and_adaptive_is_not_checked():
    for path in sorted((ROOT / "scenarios").glob("*.toml")):
        if "scenario = " in path.read_text():
            continue  # a sweep file
        sc = ltdsim.load_scenario(path)
        for case in [None, *sc.cases]:
            lim = step_limit(sc if case is None else sc.with_case(case))
            assert lim is None or lim.share < WARN_SHARE / 10, (path.name, case)
    hh = ltdsim.load_scenario(ROOT / "scenarios" / "heavy-haul.toml")
    assert hh.solver.adaptive and step_limit(hh) is None
    # bs23 with a first step far above euler's limit is accepted
    ltdsim.load_scenario(SHORT).with_overrides({"solver.method": "bs23", "solver.dt": 0.01,
                                                "solver.output_interval": 0.01,
                                                "driver.pid.ts": 0.01})


# property: a mutated shipped scenario loads, or is refused cleanly (ScenarioError naming
# the file on every line); never another exception. Load only (and lowering to kernel
# arrays when it loads): no simulation, so the examples stay fast.
import copy as _copy
import tomllib

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ltdsim.engine.lowering import lower
from ltdsim.scenario import scenario_from_data

SHIPPED = {p.name: p.read_bytes() for p in sorted((ROOT / "scenarios").glob("*.toml"))
           if b"scenario = " not in p.read_bytes()}  # (not the sweep file)
PARSED = {name: tomllib.loads(raw.decode()) for name, raw in SHIPPED.items()}


def _places(node, path=()):
    """Every (path, value) below ``node``, tables and arrays included."""
    items = node.items() if isinstance(node, dict) else enumerate(node) \
        if isinstance(node, list) else ()
    for k, v in items:
        yield path + (k,), v
        yield from _places(v, path + (k,))


TOML_VALUES = st.recursive(
    st.one_of(st.booleans(), st.integers(-2**63, 2**63 - 1), st.floats(allow_nan=True),
              st.text(max_size=12), st.sampled_from(["ode3", "linear", "table", "speed",
                                                      "friction-wedge-high", "karwatzki"])),
    lambda inner: st.one_of(st.lists(inner, max_size=3),
                            st.dictionaries(st.text(max_size=8), inner, max_size=3)),
    max_leaves=6)


def _clean_or_valid(load, source):
    try:
        sc = load()
    except ScenarioError as exc:
        lines = str(exc).splitlines()
        assert lines and all(line.startswith(source) for line in lines), str(exc)
        return
    lower(sc)  # a scenario that loads can be lowered to the kernel's arrays


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(sorted(PARSED)), data=st.data())
def test_a_scenario_with_mutated_values_loads_or_is_refused_cleanly(name, data):
    tree = _copy.deepcopy(PARSED[name])
    for _ in range(data.draw(st.integers(1, 3), label="mutations")):
        places = list(_places(tree))
        path, _ = places[data.draw(st.integers(0, len(places) - 1), label="where")]
        parent = tree
        for part in path[:-1]:
            parent = parent[part]
        op = data.draw(st.sampled_from(["replace", "delete", "add"]), label="op")
        if op == "delete":
            del parent[path[-1]]
        elif op == "replace":
            parent[path[-1]] = data.draw(TOML_VALUES, label="value")
        elif isinstance(parent, dict):
            parent[data.draw(st.text(max_size=8), label="key")] = data.draw(TOML_VALUES)
        else:
            parent.append(data.draw(TOML_VALUES, label="item"))
    _clean_or_valid(lambda: scenario_from_data(tree, name), name)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(sorted(SHIPPED)), data=st.data())
def test_a_scenario_file_with_mutated_text_loads_or_is_refused_cleanly(tmp_path_factory, name,
                                                                       data):
    raw = SHIPPED[name]
    lines = raw.splitlines(keepends=True)
    op = data.draw(st.sampled_from(["duplicate line", "delete line", "insert bytes",
                                    "overwrite bytes", "truncate"]), label="op")
    k = data.draw(st.integers(0, len(lines) - 1), label="line")
    at = data.draw(st.integers(0, len(raw)), label="at")
    noise = data.draw(st.binary(min_size=1, max_size=16), label="bytes")
    if op == "duplicate line":
        lines.insert(k, lines[k])
        raw = b"".join(lines)
    elif op == "delete line":
        del lines[k]
        raw = b"".join(lines)
    elif op == "insert bytes":
        raw = raw[:at] + noise + raw[at:]
    elif op == "overwrite bytes":
        raw = raw[:at] + noise + raw[at + len(noise):]
    else:
        raw = raw[:at]
    p = tmp_path_factory.mktemp("mutated") / name
    p.write_bytes(raw)
    _clean_or_valid(lambda: ltdsim.load_scenario(p), str(p))


def test_a_fast_first_order_lag_sets_the_limit_and_is_named():
    tau = 1.0e-4  # s, a traction lag far faster than the train's oscillations
    sc = ltdsim.load_scenario(SHORT).with_overrides({"traction.time_constant": tau})
    lim = step_limit(sc)
    assert lim.limit == pytest.approx(real_radius("ode3") * tau, rel=1e-12)
    with pytest.raises(ScenarioError) as info:
        ltdsim.simulate(sc.with_overrides({"solver.dt": 5e-4, "driver.pid.ts": 5e-4}))
    assert "solver.dt" in str(info.value) and "traction.time_constant = 0.0001 s" in str(info.value)


# -- issue 13: outputs, memory, result files
import itertools  # noqa: E402
import os  # noqa: E402
import tempfile  # noqa: E402
import tracemalloc  # noqa: E402

import xarray as xr  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

from ltdsim.study import stages as study  # noqa: E402
from ltdsim.sweep import core as sw  # noqa: E402

SHORT = ROOT / "scenarios" / "short-train.toml"
PAPER_TOML = ROOT / "scenarios" / "paper.toml"
SIM = sys.modules["ltdsim.results.simulate"]
import ltdsim.engine.run  # noqa: E402

RUN = sys.modules["ltdsim.engine.run"]


def cli(*args):
    """Run the CLI in this process: (exit code, stderr, everything printed)."""
    res = CliRunner().invoke(app, [str(a) for a in args])
    return res.exit_code, res.stderr, res.output + res.stderr


def refused(args, *names, code=2):
    """The command exits with ``code``, prints one error line without a traceback and
    names each of ``names``; returns that line."""
    rc, err, everything = cli(*args)
    assert rc == code, (args, everything)
    assert "Traceback" not in everything
    line = err.strip()
    assert len(line.splitlines()) == 1, line
    for name in names:
        assert name in line, (name, line)
    return line


@pytest.fixture
def no_run(monkeypatch):
    """Any simulation, study or sweep that starts fails the test: a refusal must come
    before the work."""
    def refuse(*a, **k):
        raise AssertionError("the work started although the input was refused")
    monkeypatch.setattr(SIM, "simulate", refuse)
    monkeypatch.setattr(sw, "run_sweep", refuse)
    monkeypatch.setattr(study, "_warm_up", refuse)  # a study's first work


@pytest.fixture
def unwritable(tmp_path):
    """A folder nobody may create files in: a read-only folder, or /sys when the tests
    run as root (who writes through permission bits)."""
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    candidates = [folder, Path("/sys")]
    for c in candidates:
        try:
            fd, probe = tempfile.mkstemp(dir=c)
        except OSError:
            yield c
            break
        os.close(fd)
        os.unlink(probe)
    else:
        pytest.skip("no folder here refuses to be written")
    folder.chmod(0o755)


# ---------------------------------------------------------------- memory (point 4)
def test_the_memory_estimate_matches_what_a_run_allocates():
    # the recording of 100,001 samples of the short train, measured by tracemalloc
    sc = ltdsim.load_scenario(SHORT).with_overrides(
        {"solver.t_end": 10.0, "solver.output_interval": 1e-4})
    ltdsim.simulate(sc.with_overrides({"solver.t_end": 0.01}))  # kernel loaded first
    ds, peak = traced_peak(lambda: ltdsim.simulate(sc))
    est = RUN.recording_bytes(sc)
    assert ds.sizes["time"] == 100_001
    assert ds.nbytes < est  # the result is part of what was estimated
    assert 0.85 < est / peak < 1.15, (est, peak)


def test_a_run_over_the_memory_share_is_refused_and_one_under_it_runs(monkeypatch):
    sc = build(train_dict([1e5, 1e5], t_end=1.0, dt=1e-3))
    need = RUN.recording_bytes(sc)
    monkeypatch.setattr(RUN, "available_memory", lambda: int(need / RUN.MEMORY_SHARE * 0.99))
    with pytest.raises(ScenarioError) as info:
        ltdsim.simulate(sc)
    msg = str(info.value)
    assert "solver.output_interval" in msg and "solver.t_end" in msg and "GB" in msg
    monkeypatch.setattr(RUN, "available_memory", lambda: int(need / RUN.MEMORY_SHARE * 1.01))
    assert ltdsim.simulate(sc).sizes["time"] == 1001


@pytest.mark.parametrize("method", ["ode3", "bs23"])
def test_t_end_1e7_is_refused_before_anything_is_allocated(tmp_path, method):
    # a fixed-step and an adaptive run of ten million seconds, recorded every 1 ms
    assert 'method = "ode3"' in EXAMPLE
    path = write(tmp_path, EXAMPLE.replace("t_end = 60.0", "t_end = 1e7").replace(
        'method = "ode3"', f'method = "{method}"'))
    sc = ltdsim.load_scenario(path)
    assert sc.solver.method == method and sc.solver.adaptive == (method == "bs23")
    tracemalloc.start()
    try:
        line = refused(["run", path, "-q"], "bad.toml", "solver.output_interval",
                       "solver.t_end", "GB")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 100e6  # refused before the recording (thousands of GB) was asked for
    samples = int(1e7 / sc.solver.output_interval) + 1
    assert f"{samples:,} samples" in line
    gb = float(line.split("about ")[1].split(" GB")[0].replace(",", ""))
    assert gb * 1e9 == pytest.approx(RUN.recording_bytes(sc), rel=0.01)


def test_a_memory_error_while_allocating_is_one_line_failure(monkeypatch):
    def no_memory(low, n, keep=None):
        raise MemoryError
    monkeypatch.setattr(RUN, "_buffers", no_memory)
    with pytest.raises(SimulationError, match="solver.output_interval"):
        RUN.integrate(lower(build(train_dict([1e5, 1e5], t_end=1.0))),
                       build(train_dict([1e5, 1e5], t_end=1.0)), None, 10)


def test_a_sweep_whose_cases_at_once_exceed_the_memory_is_refused_before_running(
        tmp_path, no_run):
    p = tmp_path / "mem.toml"
    p.write_text(f'scenario = "{SHORT}"\n[list]\n"solver.t_end" = [1.0, 2e5, 2.0]\n'
                 '"solver.output_interval" = [1e-4, 1e-4, 1e-4]\n')
    spec = sw.load_sweep(p)
    assert spec.largest[1] == "l0001"  # the longest case needs the most memory
    refused(["sweep", p, "-o", tmp_path / "out", "--workers", "2"], "mem.toml case l0001",
            "solver.t_end", "2 runs at once")
    assert not (tmp_path / "out").exists()


def test_a_grid_of_a_million_cases_is_refused_with_its_count_before_any_case_is_made(
        tmp_path, no_run):
    values = ", ".join(f"{1e6 + i:.1f}" for i in range(100))
    p = tmp_path / "big.toml"
    p.write_text(f'scenario = "{SHORT}"\n[grid]\n' + "".join(
        f'"couplers.default.{k}" = [{values}]\n' for k in ("k1", "k2", "k3")))
    tracemalloc.start()
    try:
        line = refused(["sweep", p, "-o", tmp_path / "out"], "big.toml", "grid",
                       "1,000,000 cases", "100 x 100 x 100", f"{sw.MAX_CASES:,}")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6, peak
    assert "[monte_carlo]" in line


def test_a_lazy_grid_holds_the_full_factorial_in_product_order(tmp_path):
    p = tmp_path / "grid.toml"
    p.write_text(f'scenario = "{SHORT}"\n[overrides]\n"solver.t_end" = 2.0\n[grid]\n'
                 '"couplers.default.k3" = [3.0e6, 6.0e6, 9.0e6]\n'
                 'couplers.default.damping = [1000.0, 3000.0]\n'  # unquoted: dotted key
                 '"vehicles.1.mass" = [8.0e4, 9.0e4]\n')
    spec = sw.load_sweep(p)
    keys = ["couplers.default.k3", "couplers.default.damping", "vehicles.1.mass"]
    want = [{"solver.t_end": 2.0, **dict(zip(keys, c))}
            for c in itertools.product([3e6, 6e6, 9e6], [1e3, 3e3], [8e4, 9e4])]
    assert len(spec.cases) == 12 and [c.overrides for c in spec.cases] == want
    assert spec.cases[-1].id == "g0011" and spec.cases[5].overrides == want[5]
    sc = spec.scenario(spec.cases[7])
    assert sc.couplers.default.damping == want[7]["couplers.default.damping"]
    assert sc.vehicles[1].mass == want[7]["vehicles.1.mass"]


# ----------------------------------------------------------- sweep files (point 9)
@pytest.mark.parametrize("body, words", [
    ('[grid]\n"solver.dt" = [1e-4]\n[list]\n"solver.dt" = [1e-4]\n',
     ["give exactly one of [grid], [list] or [monte_carlo]", "found [grid], [list]"]),
    ("", ["give exactly one of [grid], [list] or [monte_carlo]", "found none"]),
    ("grid = 5\n", ["grid: expected a table [grid]"]),
    ('overrides = 5\n[grid]\n"solver.dt" = [1e-4]\n', ["overrides: expected a table"]),
    ("[grid]\n", ["grid: no keys to vary"]),
    ('[grid]\n"solver.t_end" = 2.0\n', ["grid.solver.t_end", "non-empty list"]),
    ('[list]\n"solver.t_end" = [1.0]\n"solver.dt" = [1e-4, 2e-4]\n', ["list:", "one length"]),
    ('[monte_carlo]\nsamples = 2\nseed = "x"\n[monte_carlo.parameters]\n'
     '"solver.t_end" = {dist = "uniform", low = 1.0, high = 2.0}\n', ["monte_carlo.seed"]),
    ('[monte_carlo]\nsamples = 2\nseed = 1\n[monte_carlo.parameters]\n'
     '"solver.t_end" = {dist = "uniform", low = "a", high = 2.0}\n',
     ["monte_carlo.parameters.solver.t_end.low", "number"]),
    ("[monte_carlo]\nsamples = 2\nseed = 1\nparameters = 5\n", ["monte_carlo.parameters"]),
    ('[grid]\n"solver.dt" = [1e-4, 3e-4]\n', ["case g0001", "solver", "whole multiple"]),
], ids=["both", "neither", "grid-number", "overrides-number", "grid-empty", "grid-scalar",
        "list-lengths", "seed-string", "low-string", "parameters-number", "case-invalid"])
def test_bad_sweep_files_are_refused_in_one_line_naming_the_key(tmp_path, no_run, body,
                                                                 words):
    p = tmp_path / "sw.toml"
    p.write_text(f'scenario = "{SHORT}"\n' + body)
    line = refused(["sweep", p, "-o", tmp_path / "out"], "sw.toml", *words)
    assert ": :" not in line


@pytest.mark.parametrize("make, words", [
    (lambda p: p.write_text('scenario = 5\n[grid]\n"solver.dt" = [1e-4]\n'),
     ["scenario", "expected a string"]),
    (lambda p: p.write_text(f'scenario = "{p.name}"\n[grid]\n"solver.dt" = [1e-4]\n'),
     ["scenario", "names this sweep file"]),
    (lambda p: p.write_bytes(b"scenario = \"\xff\xfe\"\n"), ["not UTF-8"]),
    (lambda p: p.mkdir(), ["is a folder"]),
], ids=["scenario-number", "itself", "not-utf8", "folder"])
def test_unreadable_sweep_files_are_named(tmp_path, no_run, make, words):
    p = tmp_path / "sw.toml"
    make(p)
    refused(["sweep", p, "-o", tmp_path / "out"], "sw.toml", *words)


def test_study_refuses_an_unknown_case_or_a_file_without_cases_before_writing(
        tmp_path, no_run):
    out = tmp_path / "report"
    refused(["study", PAPER_TOML, "--case", "NOPE", "-o", out], "--case", "NOPE", "LHHL")
    refused(["study", SHORT, "-o", out], "short-train.toml", "cases")
    assert not out.exists()


# -------------------------------------------------------------- outputs (point 5)
OUTPUT_COMMANDS = [
    ("run", "{s}", "-o", "{d}/x.nc", "-q"),
    ("run", "{s}", "--plot", "{d}/x.png", "-q"),
    ("gear", "loop", "--preset", "friction-wedge-low", "--plot", "{d}/x.png"),
    ("gear", "impact", "--preset", "friction-wedge-low", "--csv", "{d}/x.csv"),
    ("gear", "ratings", "--travel", "0.083", "--force", "2.27e6", "--capacity", "5e4",
     "--absorptivity", "0.8", "--toml", "{d}/x.toml"),
    ("reduce", "--preset", "friction-wedge-low", "--plot", "{d}/x.png"),
    ("reduce", "--preset", "friction-wedge-low", "--toml", "{d}/x.toml"),
    ("sweep", "{p}", "-o", "{d}/sweep"),
    ("phases", "{s}", "-o", "{d}/phases", "-q"),
    ("modal", "{s}", "-o", "{d}/modal"),
    ("spectrum", "{s}", "-o", "{d}/spectra", "-q"),
    ("sysid", "{s}", "-o", "{d}/sysid", "-q"),
    ("study", "{p}", "-o", "{d}/report"),
]


def _option(args) -> str:
    for a in args:
        if a.startswith("{d}"):
            break
        opt = a
    return {"-o": "--output"}.get(opt, opt)


def _fill(args, **kw):
    return [a.format(**kw) for a in args]


def _id(args) -> str:
    words = [a for a in args[:2] if not a.startswith(("{", "-"))]
    return " ".join(words + [_option(args)])


@pytest.fixture
def reduce_refused(monkeypatch):
    import ltdsim.analysis.reduction

    def refuse(*a, **k):
        raise AssertionError("the fit started although its output was refused")
    monkeypatch.setattr(ltdsim.analysis.reduction, "reduce_gear", refuse)


@pytest.mark.parametrize("args", OUTPUT_COMMANDS, ids=_id)
def test_an_output_in_a_folder_that_cannot_be_written_is_refused_before_the_work(
        tmp_path, unwritable, no_run, reduce_refused, args):
    s = write(tmp_path, EXAMPLE.replace("t_end = 60.0", "t_end = 3600.0"))
    before = sorted(os.listdir(unwritable))
    refused(_fill(args, s=s, p=PAPER_TOML, d=unwritable), _option(args), "cannot write",
            str(unwritable))
    assert sorted(os.listdir(unwritable)) == before


@pytest.mark.parametrize("args", OUTPUT_COMMANDS, ids=_id)
def test_an_output_under_a_file_is_refused_before_the_work(tmp_path, no_run,
                                                           reduce_refused, args):
    s = write(tmp_path, EXAMPLE.replace("t_end = 60.0", "t_end = 3600.0"))
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    refused(_fill(args, s=s, p=PAPER_TOML, d=blocker), _option(args), "is a file")
    assert blocker.read_text() == "not a folder"


@pytest.mark.parametrize("args, inside", [
    (("sweep", "{p}", "-o", "{d}"), "cases"), (("sweep", "{p}", "-o", "{d}"), "figures"),
    (("study", "{p}", "-o", "{d}", "--force"), "cache"),
    (("study", "{p}", "-o", "{d}", "--force"), "sweep")])
def test_a_file_where_a_sweep_or_study_makes_a_folder_is_refused(tmp_path, no_run, args,
                                                                inside):
    out = tmp_path / "out"
    out.mkdir()
    (out / inside).write_text("not a folder")
    refused(_fill(args, p=PAPER_TOML, d=out), "--output", str(out / inside), "is a file")


def test_probing_a_writable_folder_leaves_nothing_behind(tmp_path, no_run):
    out = tmp_path / "out"
    out.mkdir()
    refused(["run", write(tmp_path, EXAMPLE.replace("t_end = 60.0", "t_end = 1e7")), "-q",
             "-o", out / "r.nc"], "solver.t_end")  # refused for its memory, after the probe
    assert os.listdir(out) == []


def test_an_existing_folder_as_output_file_is_named_a_folder(tmp_path, no_run):
    (tmp_path / "r.nc").mkdir()
    refused(["run", SHORT, "-q", "-o", tmp_path / "r.nc"], "--output", "is a folder")
    refused(["run", SHORT, "-q", "-o", tmp_path], "--output", "is a folder")


# -------------------------------------------------------- result files (point 8)
@pytest.fixture(scope="module")
def result_file(tmp_path_factory) -> Path:
    ds = ltdsim.simulate(build(train_dict([1e5, 8e4, 8e4], t_end=2.0, dt=1e-3)))
    return ltdsim.save_result(ds, tmp_path_factory.mktemp("res") / "good.nc")


def _bad_results(folder: Path, good: Path) -> dict:
    data = good.read_bytes()
    made = {}

    def put(name, content):
        made[name] = folder / f"{name}.nc"
        made[name].write_bytes(content)
    put("truncated", data[: len(data) // 2])
    put("empty", b"")
    put("text", b"time,force\n0.0,1.0\n")
    put("random", np.random.default_rng(13).bytes(4096))
    xr.Dataset({"u": ("x", np.arange(3.0))}).to_netcdf(folder / "foreign.nc",
                                                       engine="h5netcdf")
    made["foreign"] = folder / "foreign.nc"
    xr.Dataset({"u": ("x", np.arange(3.0))}).to_netcdf(folder / "classic.nc", engine="scipy")
    made["classic"] = folder / "classic.nc"
    ds = ltdsim.load_result(good).drop_vars("coupler_force")
    made["incomplete"] = ltdsim.save_result(ds, folder / "incomplete.nc")
    sel = build(train_dict([1e5, 8e4, 8e4], t_end=2.0, dt=1e-3))
    sel = sel.with_overrides({"solver.record": ["coupler_force"]})
    made["selected"] = ltdsim.save_result(ltdsim.simulate(sel), folder / "selected.nc")
    made["folder"] = folder / "folder.nc"
    made["folder"].mkdir()
    return made


RESULT_WORDS = {"truncated": "cut short", "empty": "empty file", "text": "a text file",
                "random": "unknown bytes", "foreign": "not a result written by ltdsim",
                "classic": "netCDF-3", "incomplete": "lacks coupler_force",
                "selected": "recorded only some time series (solver.record)",
                "folder": "is a folder"}


def test_load_result_says_what_is_wrong_with_each_bad_file(tmp_path, result_file):
    made = _bad_results(tmp_path, result_file)
    assert ltdsim.load_result(result_file).sizes["vehicle"] == 3
    for kind, path in made.items():
        with pytest.raises(ScenarioError) as info:
            ltdsim.load_result(path)
        msg = str(info.value)
        assert msg.startswith(str(path)) and RESULT_WORDS[kind] in msg, (kind, msg)
        assert len(msg.splitlines()) == 1
    # the truncated file's message gives its size and the size it should have
    msg = str(pytest.raises(ScenarioError, ltdsim.load_result, made["truncated"]).value)
    assert f"{made['truncated'].stat().st_size:,} of its {result_file.stat().st_size:,}" in msg


@pytest.mark.parametrize("command", ["modal", "spectrum", "phases", "sysid"])
def test_analysis_commands_name_what_is_wrong_with_a_bad_result_file(tmp_path, result_file,
                                                                     command):
    made = _bad_results(tmp_path, result_file)
    for kind, path in made.items():
        refused([command, path, "-o", tmp_path / "out"], str(path), RESULT_WORDS[kind])
    assert not (tmp_path / "out").exists()


def test_a_write_that_fails_after_the_run_is_one_line_exit_3(tmp_path, monkeypatch):
    # the output folder passed the check, then the disk filled up while the train ran
    def disk_full(ds, path):
        raise OSError(28, "No space left on device", str(path))
    monkeypatch.setattr(sys.modules["ltdsim.results.io"], "save_result", disk_full)
    path = write(tmp_path, EXAMPLE.replace("t_end = 60.0", "t_end = 0.5"))
    refused(["run", path, "-q", "-o", tmp_path / "r.nc"], "r.nc", "No space left", code=3)


def test_curving_indicators_need_the_positions_and_forces_recorded():
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "heavy-haul-s-curve.toml")
    with pytest.raises(ScenarioError, match=r"solver\.record.*\[curving\].*position"):
        sc.with_overrides({"solver.record": ["coupler_force"]})


FAR = ["-1e300", "1e300", "-1.00001e7"]


@pytest.mark.parametrize("where", ["gradient", "curve", "cant", "transitions", "profile"])
@pytest.mark.parametrize("far", FAR)
def test_a_track_position_beyond_10000_km_is_refused_in_one_line(tmp_path, where, far):
    """A track table's position beyond +-1e7 m (10,000 km: no line is longer) is refused
    at load in one line naming the file, the key and the range, before any run (a
    position of 1e300 m once ended the run, or its curving pass, in a traceback)."""
    tracks = {
        "gradient": f"gradient = [[{far}, 0.0], [300.0, 0.005]]",
        "curve": f"curve = [[0.0, 0.0], [150.0, 300.0], [{far}, 0.0]]"
                 if not far.startswith("-") else f"curve = [[{far}, 0.0], [150.0, 300.0]]",
        "cant": f"curve = [[0.0, 0.0], [150.0, 300.0]]\ncant = [[{far}, 0.0], [1e7, 0.1]]"
                if far.startswith("-") else f"cant = [[0.0, 0.0], [{far}, 0.1]]",
        "transitions": f"curve = [[0.0, 0.0], [{far}, 300.0]]\n"
                       f"transitions = [[{far}, 30.0]]",
        "profile": f"profile = [[{far}, 0.0, 0.0], [1e7, 0.01, 0.0]]"
                   if far.startswith("-") else f"profile = [[0.0, 0.0, 0.0], [{far}, 0.01, 0.0]]",
    }
    text = EXAMPLE.replace("curve = [[0.0, 0.0], [150.0, 300.0], [450.0, 0.0]]", "")
    text = text.replace("gradient = [[0.0, 0.0], [300.0, 0.005]]", tracks[where])
    path = write(tmp_path, text)
    line = cli_refused("run", path, "-q")
    assert "bad.toml" in line and f"track.{where}" in line
    assert "within +-1e+07 m" in line and "10,000 km" in line
    assert f"got {float(far):g} m" in line


def test_a_profile_csv_chainage_beyond_10000_km_names_the_csv_line(tmp_path):
    (tmp_path / "align.csv").write_text("chainage,curvature,cant\n0,0,0\n1e300,0.001,0\n")
    text = EXAMPLE.replace("curve = [[0.0, 0.0], [150.0, 300.0], [450.0, 0.0]]",
                           'profile_file = "align.csv"')
    line = cli_refused("run", write(tmp_path, text), "-q")
    assert "track.profile_file" in line and "align.csv line 3" in line
    assert "within +-1e+07 m" in line and "got 1e+300 m" in line


def test_track_positions_at_the_bound_load():
    """+-1e7 m itself is a place on a (very long) line: accepted."""
    d = train_dict([8e4, 8e4])
    d["track"] = {"gradient": [[-1e7, 0.0], [0.0, 0.001], [1e7, 0.0]],
                  "curve": [[-1e7, 0.0], [1e7, 300.0]]}
    sc = build(d)
    assert sc.track.gradient[0] == (-1e7, 0.0)


def test_a_step_too_small_to_count_is_refused_by_name(tmp_path):
    """A denormal step makes output_interval / dt overflow to infinity (found by the
    random-scenario property): refused naming dt, not an OverflowError."""
    msg = load_error(tmp_path, EXAMPLE.replace("dt = 1e-4", "dt = 5e-324"))
    assert "solver" in msg and "dt (4.94066e-324 s) is too small" in msg
