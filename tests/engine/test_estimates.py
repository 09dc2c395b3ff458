"""Estimates before work: steps, time and memory of a run from the scenario alone.

A fixed step's count is exact (t_end / dt); bs23's comes from the stiffest rate of the
train (the largest step ode3's stability region, which the pair shares, keeps stable on
the train linearised at its stiffest), so it is checked against the steps bs23 actually
takes. A run estimated beyond the limit is refused before anything is compiled, with the
estimate, the keys and the option that lets it run; the induction drive's lags join the
fixed step's stability check.
"""

import math

import pytest

import ltdsim
from ltdsim.engine.preflight import ADAPTIVE_STEP_FACTOR, expected_steps, real_radius
from ltdsim.engine.run import TIME_LIMIT, check_time, duration, estimate
from ltdsim.errors import ScenarioError
from ltdsim.progress import remaining

from conftest import ROOT, cli_refused

SCEN = ROOT / "scenarios"


def test_a_fixed_step_counts_t_end_over_dt_and_costs_in_proportion():
    s = ltdsim.load_scenario(SCEN / "paper.toml")
    e1 = estimate(s.with_overrides({"solver.t_end": 10.0}))
    e2 = estimate(s.with_overrides({"solver.t_end": 10.0, "solver.dt": 5e-5}))
    assert e1.exact and e1.steps == round(10.0 / s.solver.dt)
    assert e2.steps == 2 * e1.steps
    assert e2.seconds == pytest.approx(2.0 * e1.seconds, rel=1e-12)
    # rk4 has 4 stages to ode3's 3: a third more work per step
    e4 = estimate(s.with_overrides({"solver.t_end": 10.0, "solver.method": "rk4"}))
    assert e4.seconds == pytest.approx(4.0 / 3.0 * e1.seconds, rel=1e-12)


@pytest.mark.parametrize("name, t_end", [("heavy-haul", 20.0), ("uic-freight", 20.0)])
def test_bs23_steps_estimated_from_the_stiffest_rate_within_a_factor_of_three(name, t_end):
    s = ltdsim.load_scenario(SCEN / f"{name}.toml").with_overrides({"solver.t_end": t_end})
    count = expected_steps(s)
    # the stiffest rate is the hysteretic gears' tracking lag: ode3 holds a lag tau
    # for steps up to 2.513 tau
    tau = min(s.coupler(j).tracking_time for j in range(s.n_couplers))
    assert count.h == pytest.approx(real_radius("ode3") * tau, rel=1e-9)
    assert count.steps == pytest.approx(ADAPTIVE_STEP_FACTOR * t_end / count.h, rel=1e-9)
    ds = ltdsim.simulate(s)
    taken = ds.attrs["steps"] + ds.attrs["rejected_steps"]
    assert 1.0 / 3.0 < count.steps / taken < 3.0, (count.steps, taken)
    if s.brake.model == "fluid":
        air = ds.attrs["air_steps"] + ds.attrs["air_rejected_steps"]
        assert count.air_steps > 0.0 and count.air_steps / air < 6.0, (count.air_steps, air)


def test_a_nanosecond_step_is_refused_before_anything_compiles_with_the_option():
    text = cli_refused("run", SCEN / "paper.toml", "--set", "solver.dt=1e-9")
    assert "solver.dt, solver.t_end: the run would take about" in text
    assert "270,000,000,000 steps (step set by solver.dt = 1e-09 s (ode3))" in text
    assert f"beyond the limit of {duration(TIME_LIMIT)}" in text
    assert "--max-time SECONDS (0: no limit)" in text
    # the analysis commands, which have no such option, say how to run it anyway
    text = cli_refused("phases", SCEN / "paper.toml", "--set", "solver.dt=1e-9")
    assert "ltdsim run FILE --max-time SECONDS --output RESULT.nc" in text


def test_the_limit_is_the_callers_to_raise():
    s = ltdsim.load_scenario(SCEN / "paper.toml").with_overrides({"solver.dt": 1e-8})
    est = estimate(s)
    assert est.seconds > TIME_LIMIT
    with pytest.raises(ScenarioError, match="pass time_limit = None"):
        ltdsim.simulate(s)
    assert check_time(s, None) == est
    assert check_time(s, 2.0 * est.seconds) == est
    cli_refused("run", SCEN / "paper.toml", "--max-time", "-1")


def test_an_induction_drive_faster_than_the_step_is_refused_before_the_run():
    """5 kHz current loops (31.8 us) under ode3 at 0.1 ms: ode3 holds a lag only down to
    dt / 2.513 = 39.8 us; the step check names the drive's key before anything runs."""
    s = ltdsim.load_scenario(SCEN / "paper-induction.toml").with_overrides(
        {"traction.motor.current_bandwidth": 5000.0, "solver.t_end": 0.5})
    tau = 1.0 / (2.0 * math.pi * 5000.0)
    with pytest.raises(ScenarioError) as e:
        ltdsim.simulate(s)
    text = str(e.value)
    assert "solver.dt: 0.0001 s is above the largest stable step of ode3" in text
    assert (f"the first-order lag the induction drive's current loops (consist 1), 1 / "
            f"(2 pi traction.motor.current_bandwidth) = {tau:.3g} s") in text
    assert f"at most {real_radius('ode3') * tau:.3g} s" in text
    # the shipped drive (250 Hz loops, 0.64 ms) passes at the shipped step
    ok = ltdsim.load_scenario(SCEN / "paper-induction.toml")
    from ltdsim.engine.preflight import step_limit
    assert step_limit(ok).share < 1.0


@pytest.mark.parametrize("seconds, words", [
    (0.42, "0.42 s"), (45.0, "45 s"), (725.0, "12 min 05 s"), (12000.0, "3 h 20 min"),
    (1e9, "1.16e+04 days"), (math.inf, "forever")])
def test_durations_in_words(seconds, words):
    assert duration(seconds) == words


def test_progress_in_a_log_gives_the_time_left_at_the_rate_so_far(monkeypatch):
    import io
    import re

    from rich.console import Console

    import ltdsim.progress as progress

    now = [100.0]
    monkeypatch.setattr(progress.time, "monotonic", lambda: now[0])
    log = io.StringIO()
    with progress.Display(Console(file=log, force_terminal=False, width=200),
                          interval=0.0) as show:
        update = show.bar("simulating x", 270.0, "s simulated")
        update(0.0)
        now[0] = 130.0
        update(135.0)  # 135 s simulated in 30 s: 135 s more take 30 s
        now[0] = 190.0
        update(270.0)
    lines = log.getvalue().splitlines()
    assert re.search(r"135/270 s simulated, 30 s, about 30 s left$", lines[1]), lines
    assert lines[2].endswith("270/270 s simulated, 90 s"), lines
    assert remaining(5400.0) == "1.5 h" and remaining(600.0) == "10 min"


def test_a_sweep_with_a_case_beyond_the_limit_is_refused_before_any_case_runs(tmp_path):
    """One case at a nanosecond step among ordinary ones: refused naming that case and
    the option, nothing written; the estimates of the cases add up to the sweep's."""
    from ltdsim.sweep import core as sw

    path = tmp_path / "sweep.toml"
    path.write_text(f'scenario = "{SCEN / "short-train.toml"}"\n'
                    '[list]\n"solver.dt" = [1e-4, 1e-10]\n')
    spec = sw.load_sweep(path)
    each = [estimate(spec.scenario(c)).seconds for c in spec.cases]
    assert spec.seconds == pytest.approx(sum(each), rel=1e-12)
    assert spec.slowest[1] == spec.cases[1].id and each[1] == pytest.approx(1e6 * each[0])
    out = tmp_path / "out"
    text = cli_refused("sweep", path, "-o", out, "--workers", "1")
    assert f"case {spec.cases[1].id}: solver.dt, solver.t_end: the case would take about" in text
    assert "give --max-time SECONDS (0: no limit)" in text
    assert not (out / "cases").exists() or not any((out / "cases").iterdir())


def test_a_study_with_a_case_beyond_the_limit_is_refused_before_it_starts(tmp_path):
    from conftest import short_paper

    out = tmp_path / "report"
    text = cli_refused("study", short_paper(tmp_path), "--output", out, "--set",
                       "solver.dt=1e-9", "--no-reduction", "--workers", "1")
    assert "the case would take about" in text and "ltdsim sweep FILE --max-time" in text
    assert not (out / "index.html").exists()
