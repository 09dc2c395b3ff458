"""The study's base scenario (docs/paper-scenario.md) and its 16 cases."""

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

import ltdsim
from ltdsim.results.io import load_result, save_result

from ltdsim.data import study_tables

TABLES = study_tables()


def test_paper_file_carries_the_sixteen_cases_of_table_2(paper_path):
    sc = ltdsim.load_scenario(paper_path)
    names = sorted(sc.cases)
    assert len(names) == 16
    assert names == sorted(a + b + c + d for a in "LH" for b in "LH" for c in "LH" for d in "LH")
    for name, row in TABLES["table2_pid_and_rms_error"].items():
        case = sc.with_case(name)
        pid = case.driver.pid
        assert (pid.kp, pid.ki, pid.kd) == (row["kp"], row["ki"], row["kd"])
        low_high = TABLES["table1"]["simplified_model"]
        c = case.couplers.default
        for letter, (key, table_key) in zip(name, [("damping", "b_N_s_m"), ("k1", "k1_N_m"),
                                                   ("k2", "k2_N_m"), ("k3", "k3_N_m")]):
            assert getattr(c, key) == low_high[table_key][0 if letter == "L" else 1]


def test_paper_train_has_the_study_masses(paper_path):
    sc = ltdsim.load_scenario(paper_path)
    static = sum(v.weight_mass for v in sc.vehicles)
    assert_allclose(static, 8.7663e5, rtol=1e-6)  # m_stc, Appendix I
    assert len(sc.vehicles) == 10 and sc.n_couplers == 9


@pytest.fixture(scope="module")
def lhhl(paper_path):
    return ltdsim.simulate(ltdsim.load_scenario(paper_path, case="LHHL"))


def test_base_scenario_tracks_speed_and_respects_adhesion(lhhl):
    err = lhhl.speed_error.values
    assert np.sqrt(np.mean(err**2)) < 0.2  # the study reports 0.0709 m/s for LHHL
    assert np.all(np.abs(lhhl.traction_force.values) <= lhhl.adhesion_limit.values * (1 + 1e-12))
    assert lhhl.time.values[-1] == pytest.approx(270.0)


def test_base_scenario_obeys_newton_for_the_whole_train(lhhl, paper_path):
    # sum of m a = traction - sum of resistances: couplers are internal forces
    sc = ltdsim.load_scenario(paper_path, case="LHHL")
    m = np.array([v.mass for v in sc.vehicles])
    ds = lhhl.sel(time=slice(100.0, 110.0))  # cruise on the curve, level track
    v = ds.velocity.values
    ma = (ds.acceleration.values * m).sum(axis=1)
    davis = (8202.0 * np.sign(v) + 106.56 * v + 11.9322 * v * np.abs(v)).sum(axis=1)
    weight = np.array([v_.weight_mass for v_ in sc.vehicles]) * 9.81
    (_, _), (start, radius), (end, _) = sc.track.curve  # R = 300 m from start to end
    on_curve = (ds.position.values >= start) & (ds.position.values < end)
    curve = (weight * 540.0 / radius / 1000.0 * on_curve).sum(axis=1)
    assert_allclose(ma, ds.traction_force.values - davis - curve, atol=1e-6 * 8.63e5)


def test_result_round_trips_through_netcdf(lhhl, tmp_path):
    small = lhhl.isel(time=slice(0, 2000))
    path = save_result(small, tmp_path / "r.nc")
    back = load_result(path)
    assert_allclose(back.coupler_force.values, small.coupler_force.values)
    assert back.coupler_force.attrs["units"] == "N"
    assert json.loads(back.attrs["scenario_json"])["case"] == "LHHL"
