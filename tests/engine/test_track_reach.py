"""Track tables reaching 10,000 km cost what the run needs, not what the tables reach
(issue 37): the kernel's curve steps and the curving pass use the track over the stretch
the train can reach only, and give the results of the same run on the tables cut by
hand to a stretch around it."""

from __future__ import annotations


import numpy as np
import pytest

import ltdsim
from ltdsim.physics.alignment import Alignment, alignment_of
from ltdsim.scenario import Track

from conftest import ROOT, traced_peak

#: a curve of 250 m (60 mm of cant) under the train, with ramps of curvature and cant
#: out to +-1e7 m on both sides: gridded over their whole extent the ramps alone are
#: millions of steps (the kernel's curve resistance) and of grid nodes (the curving pass)
FAR = [[-1e7, 0.0, 0.0], [-300.0, 0.004, 0.05], [-200.0, 1 / 250, 0.06],
       [200.0, 1 / 250, 0.06], [300.0, 0.004, 0.05], [1e7, 0.0, 0.0]]
FAR_GRADE = [[-1e7, 0.01], [-50.0, 0.0], [1e7, -0.01]]


def _cut(points, lo, hi):
    """``points`` (chainage first, linear between them) cut by hand to [lo, hi]: the
    values at lo and hi by linear interpolation, the points between kept."""
    p = np.asarray(points, dtype=float)
    inside = p[(p[:, 0] > lo) & (p[:, 0] < hi)]
    ends = [[x] + [float(np.interp(x, p[:, 0], p[:, c])) for c in range(1, p.shape[1])]
            for x in (lo, hi)]
    return [ends[0], *inside.tolist(), ends[1]]


def _cut_steps(points, lo, hi):
    """A piecewise-constant table (``[start, value]``, the first piece also before it)
    cut by hand to [lo, hi]: the piece in force at lo starting there, the starts after
    it up to hi kept."""
    before = [p for p in points if p[0] <= lo]
    first = [lo, (before[-1] if before else points[0])[1]]
    return [first] + [list(p) for p in points if lo < p[0] <= hi]


def _scenario(profile, gradient):
    sc = ltdsim.load_scenario(ROOT / "scenarios" / "short-train.toml")
    return sc.with_overrides({"solver.t_end": 2.0, "solver.output_interval": 0.01,
                              "track": {"profile": profile, "gradient": gradient},
                              "curving": {}})


def test_clipped_alignment_keeps_every_value_inside_and_its_ends_beyond():
    """Curvature and cant of the alignment clipped to [lo, hi] equal the whole one's at
    every chainage in [lo, hi] (and its values at lo, hi beyond them); the clipped one
    has only the knots inside plus the two cuts."""
    whole = alignment_of(Track(profile=FAR))
    lo, hi = -5000.0, 250.0
    part = whole.clipped(lo, hi)
    assert part.s[0] == lo and part.s[-1] == hi and len(part.s) == 5
    x = np.concatenate([np.linspace(lo, hi, 2001), [-300.0, -200.0, 200.0]])
    np.testing.assert_allclose(part.curvature(x), whole.curvature(x), rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(part.cant(x), whole.cant(x), rtol=1e-12, atol=1e-18)
    for beyond, at in ((-1e6, lo), (1e6, hi)):
        assert part.curvature(beyond) == pytest.approx(float(whole.curvature(at)), rel=1e-12)
        assert part.cant(beyond) == pytest.approx(float(whole.cant(at)), rel=1e-12)
    # the ramp's value at the cut is the straight line between its ends
    assert float(part.curvature(lo)) == pytest.approx(0.004 * (lo + 1e7) / (1e7 - 300.0),
                                                      rel=1e-12)
    # wholly within: the alignment itself; wholly beyond the knots: its end value
    assert whole.clipped(-2e7, 2e7) is whole
    end = whole.clipped(2e7, 3e7)
    assert float(end.curvature(2.5e7)) == 0.0 and float(end.cant(2.5e7)) == 0.0
    straight = Alignment.from_knots([0.0, 10.0], [0.01], [0.01], [0.1], [0.1])
    assert float(straight.clipped(-50.0, -20.0).curvature(-30.0)) == 0.01


def test_a_run_on_tables_reaching_10000_km_is_small_and_equals_the_cut_tables():
    """A 2 s run of the short train with a curve profile and a grade table reaching
    +-1e7 m: the track arrays it builds (traced by tracemalloc, run and curving pass)
    stay under 50 MB where gridding the whole tables took 2 GB, and its results equal
    those of the same run on the tables cut by hand to +-20 km (the stretch the train
    reaches in 2 s lies well within): the kernel's bit for bit, the curving
    indicators to rounding (their heading is integrated from another start)."""
    far = _scenario(FAR, FAR_GRADE)
    near = _scenario(_cut(FAR, -2e4, 2e4), _cut_steps(FAR_GRADE, -2e4, 2e4))
    ltdsim.simulate(near)  # (compiles or loads the kernel outside the trace)
    ds, peak = traced_peak(lambda: ltdsim.simulate(far))
    assert peak < 50e6, f"{peak / 1e6:.0f} MB"
    ref = ltdsim.simulate(near)
    curving = {"coupler_angle", "coupler_lateral_force", "wheel_l_over_v",
               "wheelset_lateral_force"}
    assert curving <= set(ds.data_vars)
    # the train is on the 250 m curve: the curve resistance and indicators are not nil
    assert float(ds.coupler_angle.max()) > 0.01
    for name in ref.data_vars:
        a, b = ds[name].values, ref[name].values
        if name in curving:
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * np.abs(b).max())
        else:
            np.testing.assert_array_equal(a, b, err_msg=name)
