"""Sweeps: resume without loss, Dask equals local, phase norms, failures recorded."""

import json

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

import ltdsim
from ltdsim import ScenarioError
from ltdsim.sweep import core as sw
from ltdsim.analysis.phases import critical_couplers, phase_norms, traction_check

from conftest import PAPER, ROOT


def write_sweep(tmp_path, body: str):
    p = tmp_path / "sweep.toml"
    p.write_text(f'scenario = "{ROOT / "scenarios" / "short-train.toml"}"\n' + body)
    return p


GRID = '''
[overrides]
"solver.t_end" = 2.0
"solver.output_interval" = 0.01
[grid]
"couplers.default.k3" = [3.0e6, 6.0e6]
"couplers.default.damping" = [1000.0, 3000.0]
'''


def test_grid_list_and_monte_carlo_files_make_the_expected_cases(tmp_path):
    s = sw.load_sweep(write_sweep(tmp_path, GRID))
    assert len(s.cases) == 4
    assert {(c.overrides["couplers.default.k3"], c.overrides["couplers.default.damping"])
            for c in s.cases} == {(3e6, 1e3), (3e6, 3e3), (6e6, 1e3), (6e6, 3e3)}
    mc = '''
[monte_carlo]
samples = 50
seed = 7
[monte_carlo.parameters]
"vehicles.2.mass" = { dist = "normal", mean = 90000.0, std = 3000.0 }
'''
    a = sw.load_sweep(write_sweep(tmp_path, mc))
    b = sw.load_sweep(write_sweep(tmp_path, mc))
    masses = np.array([c.overrides["vehicles.2.mass"] for c in a.cases])
    assert masses.tolist() == [c.overrides["vehicles.2.mass"] for c in b.cases]  # seeded
    assert abs(masses.mean() - 90000.0) < 4 * 3000.0 / np.sqrt(50)


def test_a_bad_case_fails_at_load_naming_the_case_and_key(tmp_path):
    with pytest.raises(ScenarioError) as info:
        sw.load_sweep(write_sweep(tmp_path, '[list]\n"couplers.default.k3" = [3e6, -1.0]\n'))
    assert "case l0001" in str(info.value) and "couplers.default.k3" in str(info.value)


def test_an_interrupted_sweep_resumes_with_only_the_rest_and_equal_results(tmp_path):
    spec = sw.load_sweep(write_sweep(tmp_path, GRID))
    full = sw.run_sweep(spec, tmp_path / "full", workers=2)

    seen = []

    def stop_after_two(done, total, case_id):
        if case_id:
            seen.append(case_id)
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sw.run_sweep(spec, tmp_path / "resumed", workers=1, progress=stop_after_two)
    first = set(seen)
    assert len(first) == 2
    rerun = []
    again = sw.run_sweep(spec, tmp_path / "resumed", workers=2,
                         progress=lambda d, n, c: rerun.append(c) if c else None)
    assert set(rerun) == {c.id for c in spec.cases} - first  # only the rest ran
    pd.testing.assert_frame_equal(again.drop(columns=["error"]), full.drop(columns=["error"]))


def test_dask_local_cluster_gives_the_same_results_as_local_processes(tmp_path):
    distributed = pytest.importorskip("distributed")
    spec = sw.load_sweep(write_sweep(tmp_path, GRID))
    local = sw.run_sweep(spec, tmp_path / "local", workers=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                                  dashboard_address=None, processes=True) as cluster:
        remote = sw.run_sweep(spec, tmp_path / "dask", scheduler=cluster.scheduler_address)
    pd.testing.assert_frame_equal(local.drop(columns=["error"]), remote.drop(columns=["error"]))


def test_a_failing_case_is_recorded_and_the_sweep_goes_on(tmp_path):
    body = '''
[overrides]
"solver.t_end" = 1.0
"solver.method" = "euler"
"solver.dt" = 1e-2
"solver.stability_check" = false
"solver.output_interval" = 1e-2
"driver.pid.ts" = 1e-2
[list]
"couplers.default.k1" = [8e6, 5e11]
"couplers.default.k3" = [3e6, 5e11]
'''
    spec = sw.load_sweep(write_sweep(tmp_path, body))
    summary = sw.run_sweep(spec, tmp_path / "out", workers=1)
    assert summary.loc["l0000", "status"] == "ok"
    assert summary.loc["l0001", "status"] == "failed"
    rec = json.loads((tmp_path / "out" / "cases" / "l0001.json").read_text())
    assert "non-finite" in rec["error"] or "blew up" in rec["error"]


def test_phase_norms_are_numpy_norms_of_the_recorded_signals():
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "short-train.toml").with_overrides(
        {"solver.t_end": 30.0, "phases": [{"name": "start", "start": 0.0, "end": 10.0},
                                          {"name": "cruise", "start": 22.0, "end": 30.0}]})
    ds = ltdsim.simulate(sc)
    norms = phase_norms(ds, sc)
    for name, a, b in (("start", 0.0, 10.0), ("cruise", 22.0, 30.0)):
        keep = (ds.time.values >= a) & (ds.time.values <= b)
        f = ds.coupler_force.values[keep]
        assert_allclose(norms.coupler_force_2norm.sel(phase=name), np.linalg.norm(f, axis=0))
        assert_allclose(norms.coupler_force_infnorm.sel(phase=name),
                        np.linalg.norm(f, ord=np.inf, axis=0))
        e = ds.speed_error.values[keep]
        assert_allclose(norms.speed_error_2norm.sel(phase=name), np.linalg.norm(e))
        assert_allclose(norms.speed_error_rms.sel(phase=name), np.sqrt(np.mean(e**2)))
        a_ = ds.acceleration.values[keep]
        assert_allclose(norms.acceleration_infnorm.sel(phase=name), np.abs(a_).max(axis=0))


@pytest.fixture(scope="module")
def lhhl():
    sc = ltdsim.load_scenario(PAPER, case="LHHL")
    return sc, ltdsim.simulate(sc)


def test_in_acceleration_the_couplers_nearest_the_locomotive_carry_the_most(lhhl):
    sc, ds = lhhl
    norms = phase_norms(ds, sc)
    rms = norms.coupler_force_rms.sel(phase="acceleration").values
    # steady pull on a rigid train: coupler j carries the mass behind it; so does the RMS
    assert np.all(np.diff(rms) < 0)
    assert critical_couplers(norms, by="rms").query("phase == 'acceleration' and rank == 1"
                                                     ).coupler.item() == 0
    m = np.array([v.mass for v in sc.vehicles])
    behind = np.array([m[j + 1:].sum() for j in range(len(m) - 1)]) / m.sum()
    w = ds.sel(time=slice(2.0, 10.0))
    mean_pull = w.coupler_force.mean("time").values
    assert_allclose(mean_pull / mean_pull[0], behind / behind[0], atol=0.05)


def test_traction_never_exceeds_adhesion_and_the_check_counts_slip_risk(lhhl):
    sc, ds = lhhl
    check = traction_check(ds, sc)
    assert (check.max_traction_over_adhesion <= 1.0 + 1e-12).all()
    over = (np.abs(ds.traction_demand.values) > ds.adhesion_limit.values).sum()
    assert check.loc[check.phase == "whole run", "samples_demand_over_adhesion"].item() == over
    # the study's adhesion rests on the whole train's 876.6 t; on the locomotive's own
    # 66.63 t the study's Curtius-Kniffler curve (0.161 + 7.5 / (3.6 v + 44)) gives
    # 216.7 kN at standstill, so the study's 863 kN force limit is 4 times the
    # locomotive's adhesion (a coefficient of 1.3)
    whole = check[check.phase == "whole run"].iloc[0]
    loco = sc.vehicles[0]
    g = sc.track.gravity
    top = np.abs(ds.traction_force.values)
    k = int(np.argmax(top))
    v = 3.6 * abs(float(ds.velocity.values[k, 0]))
    assert whole.own_weight_adhesion_coefficient == pytest.approx(
        top[k] / (loco.static_mass * g), rel=1e-12)
    assert whole.max_traction_over_own_adhesion >= top[k] / (
        loco.static_mass * g * (0.161 + 7.5 / (v + 44.0))) * (1 - 1e-12)
    assert loco.static_mass * g * (0.161 + 7.5 / 44.0) == pytest.approx(216.7e3, rel=1e-3)


def test_amplitude_spectrum_reads_back_known_sines_and_parseval():
    from ltdsim.analysis.spectra import amplitude_spectrum, band_stats

    dt, n = 1e-3, 10_000  # the study's 0.1 Hz resolution
    t = np.arange(n) * dt
    x = 5.0 + 3.0 * np.sin(2 * np.pi * 0.7 * t) + 1.5 * np.sin(2 * np.pi * 4.2 * t + 0.3)
    f, a = amplitude_spectrum(x, dt)
    assert_allclose(a[np.argmin(abs(f - 0.7))], 3.0, rtol=1e-9)
    assert_allclose(a[np.argmin(abs(f - 4.2))], 1.5, rtol=1e-9)
    s = band_stats(f, a, 10.0)
    assert s["f_at_max_hz"] == pytest.approx(0.7) and s["max"] == pytest.approx(3.0)
    assert_allclose(s["rms"], np.std(x), rtol=1e-9)  # all content is inside the band


# ------------------------------------------------ the swept values in the summary
def test_the_summary_csv_has_a_column_of_each_swept_value_with_its_unit(tmp_path,
                                                                       monkeypatch):
    from typer.testing import CliRunner

    from ltdsim.cli.app import app
    from ltdsim.cli.common import console

    monkeypatch.setattr(console, "_width", 250)  # the printed table unabridged

    p = tmp_path / "sw.toml"
    p.write_text(f'scenario = "{ROOT / "scenarios" / "two-wagons-linear.toml"}"\n'
                 '[overrides]\n"solver.t_end" = 1.0\n'
                 '[list]\n"couplers.default.stiffness" = [2e6, 8e6]\n'
                 '"vehicles.1.mass" = [5e4, 7e4]\n"couplers.default.damping" = [1e5, 2e5]\n')
    res = CliRunner().invoke(app, ["sweep", str(p), "-o", str(tmp_path / "out"), "--workers",
                                   "1", "--no-figures", "--best-by", "max_tension"])
    assert res.exit_code == 0, res.output + res.stderr
    table = pd.read_csv(tmp_path / "out" / "summary.csv")
    swept = ["couplers.default.stiffness [N/m]", "vehicles.1.mass [kg]",
             "couplers.default.damping [N s/m]"]
    assert list(table.columns[:4]) == ["case", *swept]
    assert table[swept].values.tolist() == [[2e6, 5e4, 1e5], [8e6, 7e4, 2e5]]
    assert not any(c.startswith("solver.t_end") for c in table.columns)  # common, not swept
    printed = " ".join(res.stdout.split())
    assert "vehicles.1.mass [kg]" in printed and "70000" in printed, res.stdout  # printed too


def test_grid_monte_carlo_and_named_cases_give_their_values_in_case_order(tmp_path):
    import tomllib

    empty = tmp_path / "not-run"
    grid = sw.summary_table(empty, sw.load_sweep(write_sweep(tmp_path, GRID)))
    assert grid[["couplers.default.k3 [N/m]", "couplers.default.damping [N s/m]"]
                ].values.tolist() == [[3e6, 1e3], [3e6, 3e3], [6e6, 1e3], [6e6, 3e3]]
    assert (grid.status == "not run").all()
    mc = sw.load_sweep(write_sweep(tmp_path, '''
[monte_carlo]
samples = 5
seed = 3
[monte_carlo.parameters]
"vehicles.2.mass" = { dist = "uniform", low = 8e4, high = 9e4 }
'''))
    masses = sw.summary_table(empty, mc)["vehicles.2.mass [kg]"]
    expected = np.random.default_rng(3).uniform(8e4, 9e4, size=5)
    assert_allclose(masses.values, expected, rtol=0)
    # a scenario file's named cases: every key they set, as the file gives it
    named = sw.summary_table(empty, sw.load_sweep(ROOT / "scenarios" / "paper.toml"))
    cases = tomllib.loads((ROOT / "scenarios" / "paper.toml").read_text())["cases"]
    assert list(named.index) == list(cases)
    for case, keys in cases.items():
        for key, value in keys.items():
            column = next(c for c in named.columns if c.startswith(f"{key} ["))
            assert named.loc[case, column] == value, (case, key)
    assert {"driver.pid.kp [1/s]", "driver.pid.kd [-]"} <= set(named.columns)


def test_a_swept_key_without_a_unit_says_so_and_none_is_invented(tmp_path):
    s = sw.load_sweep(write_sweep(tmp_path, '[grid]\n"solver.method" = ["rk4", "heun"]\n'
                                            '"solver.t_end" = [1.0]\n'))
    table = sw.summary_table(tmp_path / "not-run", s)
    assert table["solver.method [no unit]"].tolist() == ["rk4", "heun"]
    assert table["solver.t_end [s]"].tolist() == [1.0, 1.0]
    assert sw.swept_column("solver.not_a_key") == "solver.not_a_key [unit not known]"


# ------------------------------------------ couplers numbered from 1 where reported
def test_phase_spectra_and_the_sweep_record_number_couplers_from_1():
    from ltdsim.analysis.spectra import phase_spectra

    sc = ltdsim.load_scenario(ROOT / "scenarios" / "short-train.toml").with_overrides(
        {"solver.t_end": 4.0})
    ds = ltdsim.simulate(sc)
    nc = ds.sizes["coupler"]
    table = phase_spectra(ds, sc, (0, nc - 1))
    assert table.coupler_number.tolist() == [1, nc]  # behind the lead, and the last
    rec = sw.run_case(sc.to_dict(), "c", extras=("spectra",))
    spectra = pd.DataFrame(rec["spectra"])
    assert "coupler" not in spectra  # (the library's 0-based index stays out of the file)
    assert sorted(spectra.coupler_number) == [1, nc - 1, nc]
    for number in (1, nc):
        # each entry is that coupler's spectrum: coupler k is index k - 1
        alone = phase_spectra(ds, sc, (number - 1,))
        row = spectra[spectra.coupler_number == number].iloc[0]
        assert_allclose(row.max_N, alone.max_N.item(), rtol=1e-12)
        assert_allclose(row.band_rms_N, alone.band_rms_N.item(), rtol=1e-12)
