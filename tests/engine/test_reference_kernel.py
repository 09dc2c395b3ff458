"""A second solver of the benchmark's train: the plain hand-written numba kernel of
benchmarks/reference_kernel.py (its own stepping, force balance, look-ups and
recording, read from the Scenario rather than from ltdsim's lowered tables) against
``ltdsim.simulate()``. Agreement to round-off shows the benchmark times the same train."""

from __future__ import annotations

import numpy as np

import ltdsim

from conftest import PAPER

import reference_kernel
import bench_kernel


def test_the_hand_written_kernel_gives_the_coupler_forces_of_simulate_in_draft_and_buff():
    sc = bench_kernel.force_case(ltdsim.load_scenario(PAPER, case="LHHL")).with_overrides({
        # full traction, then a dynamic-brake application that bunches the train
        "driver.force_profile": [[0.0, 0.0], [1.0, 8.63e5], [6.0, 8.63e5], [8.0, -4.0e5],
                                 [15.0, -4.0e5]],
        "solver.t_end": 15.0})
    ref = reference_kernel.simulate(sc)
    ds = ltdsim.simulate(sc)
    sim = ds.coupler_force.values
    assert sim.shape == ref.shape == (15001, 9)
    assert ref.max() > 3e5 and ref.min() < -1e5  # both gear branches (k2, k3 and k1) loaded
    assert np.max(np.abs(sim - ref)) <= 1e-9 * np.max(np.abs(ref))


def test_a_run_recording_the_coupler_forces_only_gives_the_hand_written_kernels_forces():
    # solver.record = ["coupler_force"]: the reference kernel's own recording, the
    # like-for-like case of bench_kernel.py; a bunching dynamic-brake application
    sc = bench_kernel.forces_only(bench_kernel.force_case(
        ltdsim.load_scenario(PAPER, case="LHHL")).with_overrides({
            "driver.force_profile": [[0.0, 0.0], [1.0, 8.63e5], [4.0, 8.63e5],
                                     [5.0, -4.0e5], [10.0, -4.0e5]],
            "solver.t_end": 10.0}))
    ref = reference_kernel.simulate(sc)
    ds = ltdsim.simulate(sc)
    assert "position" not in ds and "acceleration" not in ds
    sim = ds.coupler_force.values
    assert sim.shape == ref.shape and ref.min() < -1e5
    assert np.max(np.abs(sim - ref)) <= 1e-9 * np.max(np.abs(ref))
    # the peaks over every step bound the recorded samples
    assert np.all(ds.max_coupler_force.values >= ref.max(axis=0))
    assert np.all(ds.min_coupler_force.values <= ref.min(axis=0))
