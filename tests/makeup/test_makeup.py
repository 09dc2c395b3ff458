"""Make-up studies: the draws keep their rules (hypothesis) and their seed, a study gives
the same results on local processes and on a Dask scheduler with two worker processes
on loopback, resumes after a stop without running a finished run again, and an
emergency loads empties at the front of a train of loads more than the same couplers of
the uniform train."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ltdsim
from ltdsim import ScenarioError
from ltdsim.makeup import results as mr
from ltdsim.makeup.draws import Makeup, draw_population, makeup_overrides, train_of
from ltdsim.makeup.manoeuvres import manoeuvre_overrides
from ltdsim.makeup.run import plan, run_plan
from ltdsim.makeup.study import load_study

from conftest import cli_refused



#: a short heavy-haul train without distributed power: the heavy-haul scenario's
#: locomotives, wagons, gears, traction and lumped brake (scenarios/heavy-haul.toml)
BASE = """
name = "makeup-test-base"
[solver]
method = "bs23"
dt = 1e-4
t_end = 10.0
output_interval = 0.05
rtol = 1e-3
atol = 1e-4
max_step = 0.05
[[vehicles]]
name = "loco"
count = 2
mass = 196000.0
length = 22.6
davis = { a = 1120.0, b = 21.0, c = 4.5 }
powered = true
[[vehicles]]
name = "wagon"
count = 20
mass = 130000.0
length = 12.2
davis = { a = 740.0, b = 14.0, c = 1.6 }
brake = { cylinder_force = 38300.0, rigging_ratio = 4.0, shoes = 8, friction_table = [[0.0, 0.38], [10.0, 0.34], [20.0, 0.32], [30.0, 0.30]] }
[couplers.default]
preset = "friction-wedge-high"
slack = 0.02
tracking_time = 2e-3
fatigue = "aar-e-knuckle"
[traction]
max_force = 1.4e6
max_power = 6.4e6
adhesion_mass = 3.92e5
max_accel = 0.1
max_decel = 0.15
time_constant = 1.5
jerk_limit = 0.01
dynamic_brake_fade = 2.5
[brake]
mode = "pneumatic"
propagation_speed = 250.0
apply_time_constant = 4.0
release_time_constant = 15.0
[driver]
mode = "force"
"""

#: an empty ore wagon: 24 t, its resistance for that weight (modified Davis with the
#: scenario's formula: a = (0.6 + 20/w) lb/ton, b = 0.01 lb/ton/mph, c as loaded), the
#: loaded wagon's brake (no empty-load device)
TYPES = """
[[types]]
name = "ore"
vehicle = "wagon"
loaded = { limits = "example-heavy-haul-loaded" }
empty = { mass = 24000.0, davis = { a = 427.0, b = 2.6, c = 1.6 }, limits = "example-heavy-haul-empty" }
"""


#: the test base with a remote consist of two locomotives at its rear, for the draws
BASE_DP = BASE.replace('[couplers.default]', '''[[vehicles]]
name = "loco-remote"
count = 2
mass = 196000.0
length = 22.6
davis = { a = 1120.0, b = 21.0, c = 4.5 }
powered = true
[[locomotives]]
name = "lead"
vehicles = [0, 1]
[[locomotives]]
name = "remote"
vehicles = [22, 23]
[couplers.default]''')


def write_study(tmp_path, body: str, base: str = BASE, name: str = "study.toml"):
    (tmp_path / "base.toml").write_text(base)
    p = tmp_path / name
    p.write_text('scenario = "base.toml"\n' + body + TYPES)
    return p


def emergency(duration: float = 10.0) -> str:
    return f"""
[[manoeuvres]]
name = "emergency"
kind = "emergency"
speed = 18.0
duration = {duration}
"""


# ------------------------------------------------------------------ the draws
@st.composite
def rules(draw):
    block = draw(st.integers(1, 4), label="block")
    nb = draw(st.integers(2, 12), label="blocks")
    wagons = block * nb
    lo = draw(st.floats(0.0, 0.6), label="low share")
    hi = draw(st.floats(lo, 0.6), label="high share")
    behind = draw(st.integers(0, wagons), label="empties_behind")
    # room behind for the most empties the range can give (whole blocks)
    front = math.ceil(behind / block)
    most = math.floor(hi * nb + 0.5)
    if most > nb - front:
        behind = (nb - most) * block
    r_lo = draw(st.integers(1, wagons), label="remote low")
    r_hi = draw(st.integers(r_lo, wagons), label="remote high")
    seed = draw(st.integers(0, 2**32), label="seed")
    return {"block": block, "wagons": wagons, "share": (lo, hi), "behind": behind,
            "remote": (r_lo, r_hi), "seed": seed}


def rules_file(r, makeups=6) -> str:
    lo, hi = r["share"]
    return f"""
makeups = {makeups}
seed = {r["seed"]}
wagons = {r["wagons"]}
block = {r["block"]}
empties_behind = {r["behind"]}
remote_after = [[{r["remote"][0]}, {r["remote"][1]}]]
[[mix]]
type = "ore"
state = "empty"
share = [{lo!r}, {hi!r}]
[[mix]]
type = "ore"
state = "loaded"
""" + emergency()


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(r=rules())
def test_every_draw_keeps_the_rules_and_the_same_seed_gives_the_same_population(tmp_path, r):
    study = load_study(write_study(tmp_path, rules_file(r), base=BASE_DP))
    pop = draw_population(study)
    assert pop == draw_population(load_study(tmp_path / "study.toml"))  # the same seed
    n, b = r["wagons"], r["block"]
    lo, hi = r["share"]
    for m in pop:
        assert len(m.wagons) == n
        for k in range(0, n, b):  # whole blocks of alike wagons
            assert len(set(m.wagons[k:k + b])) == 1
        empties = sum(s == "empty" for _, s in m.wagons)
        # the drawn share, rounded to whole blocks
        assert lo * (n // b) - 0.5 <= empties / b <= hi * (n // b) + 0.5
        assert all(s == "loaded" for _, s in m.wagons[:r["behind"]])
        (at,) = m.remote_after
        assert r["remote"][0] <= at <= r["remote"][1]
        train = train_of(study, m)
        # the remote consist stands behind wagon `at`: 2 lead + `at` wagons ahead of it
        assert train.base_index[2 + at:4 + at] == (22, 23)


def test_a_makeup_is_the_train_its_draw_describes(tmp_path):
    r = {"block": 2, "wagons": 12, "share": (0.2, 0.5), "behind": 2, "remote": (4, 8),
         "seed": 3}
    study = load_study(write_study(tmp_path, rules_file(r), base=BASE_DP))
    m = draw_population(study)[0]
    sc = study.base.with_overrides({**makeup_overrides(study, m),
                                    **manoeuvre_overrides(study.base, study.spec.manoeuvres[0])})
    names = [v.name for v in sc.vehicles]
    expect = ["loco"] * 2 + [f"ore-{s}" for _, s in m.wagons]
    expect[2 + m.remote_after[0]:2 + m.remote_after[0]] = ["loco-remote"] * 2
    assert names == expect
    masses = {"ore-loaded": 130000.0, "ore-empty": 24000.0}
    assert all(v.mass == masses[v.name] for v in sc.vehicles if v.name.startswith("ore"))
    remote = [i for i, n in enumerate(names) if n == "loco-remote"]
    assert sc.locomotives[1].vehicles == remote
    assert sc.solver.t_end == 10.0 and sc.initial.speed == 18.0


def test_rules_that_cannot_be_met_are_refused_naming_the_key(tmp_path):
    body = rules_file({"block": 2, "wagons": 12, "share": (0.2, 0.9), "behind": 6,
                       "remote": (4, 8), "seed": 3})
    with pytest.raises(ScenarioError) as info:
        load_study(write_study(tmp_path, body, base=BASE_DP))
    assert "study.toml: empties_behind" in str(info.value)
    with pytest.raises(ScenarioError) as info:
        load_study(write_study(tmp_path, body.replace("share = [0.2, 0.9]", "share = [0.2, 1.5]"),
                               base=BASE_DP))
    assert "study.toml: mix.0.share" in str(info.value) and "1" in str(info.value)


@pytest.mark.parametrize("change, key, allowed", [
    ("makeups = 8", "makeups", "greater than or equal to 1"),
    ('speed = 18.0', "manoeuvres.0.speed", "required"),
    ('kind = "emergency"', "manoeuvres.0.kind", "traction_start"),
])
def test_the_command_refuses_a_bad_study_in_one_line_naming_file_and_key(tmp_path, change,
                                                                           key, allowed):
    bad = {"makeups = 8": "makeups = 0", "speed = 18.0": "", 'kind = "emergency"':
           'kind = "emergncy"'}[change]
    p = write_study(tmp_path, SMALL.replace(change, bad))
    text = cli_refused("makeup", p, "-o", tmp_path / "out")
    assert f"study.toml: {key}" in text and allowed in text


# ------------------------------------------- local and Dask, stopped and resumed
SMALL = """
makeups = 8
seed = 11
wagons = 8
block = 2
[[mix]]
type = "ore"
state = "empty"
share = [0.25, 0.5]
[[mix]]
type = "ore"
state = "loaded"
""" + emergency(6.0)


def _table(p, out):
    return mr.run_table(p, out).drop(columns=["error"], errors="ignore")


def test_a_study_resumes_after_a_stop_and_dask_gives_the_local_results(tmp_path):
    p = plan(write_study(tmp_path, SMALL))
    run_plan(p, tmp_path / "local", workers=2)
    local = _table(p, tmp_path / "local")
    assert (local.status == "ok").all() and len(local) == 8

    seen = []

    def stop_after_three(done, total, case_id):
        if case_id:
            seen.append(case_id)
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_plan(p, tmp_path / "resumed", workers=1, progress=stop_after_three)
    rerun = []
    run_plan(p, tmp_path / "resumed", workers=2,
             progress=lambda d, n, c: rerun.append(c) if c else None)
    assert set(rerun) == {c.id for c in p.sweep.cases} - set(seen)  # only the rest ran
    pd.testing.assert_frame_equal(_table(p, tmp_path / "resumed"), local)

    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                                  dashboard_address=None, processes=True) as cluster:
        run_plan(p, tmp_path / "dask", scheduler=cluster.scheduler_address)
    pd.testing.assert_frame_equal(_table(p, tmp_path / "dask"), local)


def test_a_killed_study_resumes_without_rerunning_finished_runs(tmp_path):
    """SIGKILL `ltdsim makeup --workers 2` once its first runs are written: the same
    study resumes with only the runs not finished and ends with an undisturbed run's
    results (every record the killed run wrote is whole: atomic writes)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    body = SMALL.replace("makeups = 8", "makeups = 40").replace(emergency(6.0),
                                                              emergency(30.0))
    path = write_study(tmp_path, body)
    out = tmp_path / "killed"
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(root / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-m", "ltdsim.cli.app", "makeup", str(path),
                             "-o", str(out), "--workers", "2"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 300  # (a cold kernel compile on a busy machine)
        while time.monotonic() < deadline and proc.poll() is None:
            if any((out / "cases").glob("*.json")):
                break
            time.sleep(0.02)
        assert proc.poll() is None, "the study ended before it could be killed: " + \
            proc.stderr.read().decode()[-2000:]
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    time.sleep(1.0)  # (forked workers see their parent gone and stop)
    finished = {f.stem for f in (out / "cases").glob("*.json")}
    p = plan(path)
    assert 0 < len(finished) < len(p.sweep.cases)
    ran = []
    run_plan(p, out, workers=2, progress=lambda d, n, c: ran.append(c) if c else None)
    assert set(ran) == {c.id for c in p.sweep.cases} - finished
    run_plan(p, tmp_path / "undisturbed", workers=2)
    pd.testing.assert_frame_equal(_table(p, out), _table(p, tmp_path / "undisturbed"))


# ------------------------------------------------------------------ physics
def test_empties_at_the_front_of_loads_carry_more_compression_in_an_emergency(tmp_path):
    """20 wagons behind two locomotives, an emergency from 18 m/s: with the first four
    wagons empty (24 t, the loaded wagon's brake), the couplers at and around the
    empties (couplers 2-6) carry more compression than the same couplers of the train of
    loads; the numbers are in docs/makeup.md."""
    body = """
makeups = 1
seed = 0
[[mix]]
type = "ore"
state = "loaded"
""" + emergency(30.0)
    study = load_study(write_study(tmp_path, body))
    man = manoeuvre_overrides(study.base, study.spec.manoeuvres[0])
    peaks = {}
    for label, k in (("uniform", 0), ("empties", 4)):
        m = Makeup(label, tuple([("ore", "empty")] * k + [("ore", "loaded")] * (20 - k)), ())
        sc = study.base.with_overrides({**makeup_overrides(study, m), **man})
        ds = ltdsim.simulate(sc)
        peaks[label] = np.maximum(-ds.min_coupler_force.values, 0.0)
    at = slice(1, 6)  # couplers 2-6: locomotive 2 - wagon 1 to wagon 4 - wagon 5
    assert peaks["empties"][at].max() > peaks["uniform"][at].max()
    print({k: np.round(v / 1e3, 1).tolist() for k, v in peaks.items()})


def test_a_crest_stretches_the_train_and_a_sag_bunches_it(tmp_path):
    """Coasting at 10 m/s over a change of grade of 1 % either way where the lead
    starts: over a crest the front runs away downhill first (more tension than over the
    sag), in a sag the front climbs first and the rear runs in (more compression)."""
    body = """
makeups = 1
seed = 0
wagons = 20
[[mix]]
type = "ore"
state = "loaded"
[[manoeuvres]]
name = "crest"
kind = "crest"
speed = 10.0
duration = 40.0
[[manoeuvres]]
name = "sag"
kind = "sag"
speed = 10.0
duration = 40.0
"""
    p = plan(write_study(tmp_path, body))
    run_plan(p, tmp_path / "out", workers=1)
    runs = mr.run_table(p, tmp_path / "out").set_index("manoeuvre")
    assert runs.loc["crest", "max_ltf_kN"] > runs.loc["sag", "max_ltf_kN"]
    assert runs.loc["sag", "max_lcf_kN"] > runs.loc["crest", "max_lcf_kN"]


def test_the_shipped_studies_load_and_are_refused_as_scenarios_or_sweeps():
    from conftest import ROOT
    from ltdsim.sweep.core import load_sweep

    studies = sorted((ROOT / "scenarios" / "makeup").glob("*.toml"))
    assert len(studies) >= 2
    for path in studies:
        study = load_study(path)
        pop = draw_population(study)
        assert len(pop) == study.spec.makeups
        for load in (ltdsim.load_scenario, load_sweep):
            with pytest.raises(ScenarioError, match="make-up study file"):
                load(path)
    assert len(plan(ROOT / "scenarios" / "makeup" / "example.toml").sweep.cases) == 24
