"""The first run's compile split (:func:`ltdsim.engine.warmup._compile_parts`) is only
worth its worker when each part is compiled with the argument types the kernel gives
that callee: then the kernel's own compile loads the part from the cache. Checked
against the cache the kernel itself wrote: after the kernel is compiled (the suite's
shared compile, or here), every part's signature is one numba has on disk."""

from __future__ import annotations

from pathlib import Path

import pytest

from ltdsim.engine.warmup import scenario_kernels
from ltdsim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", ["paper.toml", "heavy-haul.toml"])
def test_every_part_has_the_types_the_kernel_compiled_it_with(name):
    (call,) = scenario_kernels([load_scenario(ROOT / "scenarios" / name)])
    call()  # the kernel: loaded from the cache (or compiled, with its callees, into it)
    assert [p.name for p in call.parts][0] == "right-hand side"
    missing = [p.name for p in call.parts if p.ready() is not True]
    assert not missing, f"{name}: parts whose types the kernel did not compile: {missing}"
