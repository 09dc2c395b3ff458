"""The energy balance of a run (``solver.energy = true``): the work of traction, brakes,
resistances and couplers against the change of the train's kinetic energy, each checked
against something it must equal independently."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import ltdsim
from ltdsim.engine.layout import ENERGY_TERMS
from ltdsim.engine.lowering import merge_track

from conftest import PAPER, ROOT, build, train_dict

HEAVY = ROOT / "scenarios" / "heavy-haul.toml"


def _gear_work_from_balance(ds) -> np.ndarray:
    """What the couplers took by the balance of everything else, J (time): traction in,
    less every other term taken from the train, less the kinetic energy gained."""
    taken = sum(ds[k].values for k in ENERGY_TERMS if k != "traction_energy")
    kin = ds.kinetic_energy.values
    return ds.traction_energy.values - taken - (kin - kin[0])


@pytest.fixture(scope="module")
def study_case():
    sc = ltdsim.load_scenario(PAPER, case="LHHL").with_overrides({"solver.energy": True})
    return sc, ltdsim.simulate(sc)


def test_the_study_case_balance_closes_to_a_millionth_of_the_traction_throughput(study_case):
    sc, ds = study_case
    through = float(ds.traction_energy[-1] + ds.dynamic_brake_energy[-1])
    assert through > 5e8  # the run drives and brakes: hundreds of MJ through the rail
    assert float(np.abs(ds.energy_balance_error).max()) <= 1e-6 * through
    # the couplers' share from the balance of the rest equals their own records
    gears = ds.coupler_energy.values.sum(axis=1)
    assert_allclose(_gear_work_from_balance(ds)[-1], gears[-1], rtol=0.01)
    # Eq. 9 as printed is passive: every coupler took net energy over the run
    assert (ds.coupler_energy.values[-1] > 0.0).all()


def test_the_grade_term_is_the_potential_energy_gained_on_the_track_profile(study_case):
    sc, ds = study_case
    pos, grade, _ = merge_track(sc.track.gradient, sc.track.resistance_curve())
    # height along the track: the grade (rise/run) integrated piece by piece, m
    h_at = np.concatenate([[0.0], np.cumsum(grade[:-1] * np.diff(pos))])

    def height(x):
        k = np.clip(np.searchsorted(pos, x, side="right") - 1, 0, None)
        return h_at[k] + grade[k] * (x - pos[k])

    wm = np.array([v.weight_mass for v in sc.vehicles])
    x = ds.position.values
    pe = (wm * sc.track.gravity * (height(x) - height(x[0]))).sum(axis=1)
    assert pe[-1] > 3e7  # the climb lifts the train by metres
    assert_allclose(ds.grade_energy.values, pe, atol=1e-6 * pe[-1])


def test_a_braked_stop_on_level_track_turns_the_kinetic_energy_into_brake_and_gear_work():
    # three wagons at 10 m/s, no traction, no resistance, brakes applied at once: what the
    # train had is what the brakes and the couplers took when it stands
    d = train_dict([8e4, 9e4, 7e4], force=0.0, t_end=40.0, dt=1e-3, speed=10.0,
                   coupler={"model": "linear", "stiffness": 5e6, "damping": 5e4,
                            "slack": 0.02})
    brake = {"cylinder_force": 3e4, "rigging_ratio": 4.0, "shoes": 8, "friction": 0.3}
    for v in d["vehicles"]:
        v["brake"] = dict(brake)
    d["brake"] = {"mode": "pneumatic", "propagation_speed": 250.0}
    d["driver"]["brake_profile"] = [[0.0, 1.0]]
    d["solver"]["energy"] = True
    ds = ltdsim.simulate(build(d))
    assert float(np.abs(ds.velocity[-1]).max()) < 1e-3  # it stands
    kin0 = 0.5 * 10.0**2 * (8e4 + 9e4 + 7e4)
    took = float(ds.air_brake_energy[-1] + ds.coupler_energy[-1].sum())
    assert_allclose(took, kin0, rtol=1e-6)
    assert float(ds.air_brake_energy[-1]) > 0.95 * kin0


def test_accounting_for_the_energy_changes_no_result():
    # the energy states feed nothing back and stay out of bs23's error norm: every result
    # of a run with the accounting is the run's without it, bit for bit
    d = train_dict([8e4, 9e4, 7e4], t_end=5.0, dt=1e-3, method="bs23",
                   coupler={"preset": "friction-wedge-high", "slack": 0.02})
    plain = ltdsim.simulate(build(d))
    d["solver"]["energy"] = True
    counted = ltdsim.simulate(build(d))
    for name in plain.data_vars:
        np.testing.assert_array_equal(plain[name].values, counted[name].values, err_msg=name)
    assert plain.attrs["steps"] == counted.attrs["steps"]


def test_the_heavy_haul_start_balance_closes_under_bs23():
    # the 214-vehicle train's first 300 s (traction from rest, friction and polymer gears,
    # two consists), adaptive steps: within 1e-4 of the traction throughput
    sc = ltdsim.load_scenario(HEAVY).with_overrides({"solver.t_end": 300.0,
                                                     "solver.energy": True})
    ds = ltdsim.simulate(sc)
    through = float(ds.traction_energy[-1] + ds.dynamic_brake_energy[-1])
    assert through > 1e8
    assert float(np.abs(ds.energy_balance_error).max()) <= 1e-4 * through
    # (the gears take about 0.04 % of it here: the balance of the rest gives their share
    # to within about 5 %, bs23's tolerance on the speeds; docs/energy.md)
    assert (ds.coupler_energy.values[-1] > 0.0).all()


def test_sampling_the_body_powers_coarser_than_the_step_keeps_every_term():
    # under a fixed step the brakes', resistances' and couplers' powers are sampled every
    # solver.energy_interval (5 steps of the study case's 0.1 ms here), traction's every
    # step; against sampling all of them every step (the finer trapezoid, the reference)
    # the couplers' records agree within 1e-3 and every balance still closes, and neither
    # changes any other result of the run without the accounting
    base = ltdsim.load_scenario(PAPER, case="LHHL").with_overrides({"solver.t_end": 60.0})
    plain = ltdsim.simulate(base)
    coarse_sc = base.with_overrides({"solver.energy": True})
    fine_sc = base.with_overrides({"solver.energy": True, "solver.energy_interval": 1e-4})
    assert (coarse_sc.solver.energy_every, fine_sc.solver.energy_every) == (5, 1)
    coarse, fine = ltdsim.simulate(coarse_sc), ltdsim.simulate(fine_sc)
    through = float(fine.traction_energy[-1] + fine.dynamic_brake_energy[-1])
    for ds in (coarse, fine):
        assert float(np.abs(ds.energy_balance_error).max()) <= 1e-6 * through
        for name in plain.data_vars:
            np.testing.assert_array_equal(plain[name].values, ds[name].values, err_msg=name)
    assert_allclose(coarse.coupler_energy.values[-1], fine.coupler_energy.values[-1],
                    rtol=1e-3)
    np.testing.assert_array_equal(coarse.traction_energy.values, fine.traction_energy.values)
    for name in ("davis_energy", "grade_energy", "curve_energy"):
        assert_allclose(coarse[name].values, fine[name].values, rtol=0,
                        atol=1e-6 * abs(float(fine[name][-1])) + 1e-9 * through)


@pytest.mark.parametrize("output, interval, every", [
    (1e-3, 5e-4, 5),   # 10 steps a record: the largest divisor within 0.5 ms
    (1e-3, 3e-4, 2),   # 3 does not divide 10
    (7e-4, 5e-4, 1),   # 7 steps a record: no divisor but 1 within 0.5 ms
    (1e-3, 1.0, 10),   # never beyond the record interval
    (1e-3, 5e-5, 1),   # an interval below the step: every step
])
def test_the_body_powers_are_sampled_on_a_grid_that_holds_every_record(output, interval,
                                                                        every):
    sc = ltdsim.load_scenario(PAPER, case="LHHL").with_overrides(
        {"solver.energy": True, "solver.output_interval": output,
         "solver.energy_interval": interval})
    assert sc.solver.record_every % sc.solver.energy_every == 0
    assert sc.solver.energy_every == every
