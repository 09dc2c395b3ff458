"""A kernel compiled for the study's subsystems computes what the kernel with every
subsystem computes, bit for bit: the flags of ``ltdsim.engine.features`` leave out only
code that the scenario's data never runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ltdsim.engine import features
from ltdsim.engine.features import ALL_FEATURES, ALL_KINDS, OFF
from ltdsim.results.simulate import simulate
from ltdsim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("case", ["LHHL", "HHLL"])
def test_the_study_kernel_gives_the_results_of_the_kernel_with_every_subsystem(monkeypatch,
                                                                                 case):
    sc = load_scenario(ROOT / "scenarios" / "paper.toml", case=case).with_overrides(
        {"solver.t_end": 20.0}, source="test")
    from ltdsim.engine.kernel.structs import make_couplers, make_train
    from ltdsim.engine.lowering import lower

    low = lower(sc)
    # the study's case runs on the kernel without the optional subsystems
    assert set(make_train(low).features) == {OFF} and set(make_couplers(low).kinds) == {OFF}
    light = simulate(sc)
    monkeypatch.setattr(features, "KERNEL_SETS", ((ALL_FEATURES, ALL_KINDS),))
    assert make_train(low).features == ALL_FEATURES
    full = simulate(sc)
    for name in light.data_vars:
        a, b = light[name].values, full[name].values
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), name
