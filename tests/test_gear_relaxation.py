"""The hysteretic gears' relaxation time is a property of the gear, not of the solver.

``tracking_time`` (tau) sets how fast a gear's internal force follows the curve it slides
on. It used to be four solver steps; now it is a gear datum (default 0.4 ms), so changing
``solver.dt`` or the method changes only the integration error: the results converge to
one answer as the step halves, and every method converges to the same one.
"""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from ltdsim.gear import drive_deflection, impact
from ltdsim.scenario import CouplerParams

# a table gear whose loading and unloading curves are parallel lines (slope S, N/m) and
# do not depend on speed: the internal force then obeys the plain law in closed form
K_LOCK, S, F0 = 5e7, 1e7, 1e5  # N/m, N/m, N
PARALLEL = dict(model="table", slack=0.0, k_locked=K_LOCK, travel=0.08,
                loading=[[0.0, F0], [0.08, F0 + S * 0.08]],
                unloading=[[0.0, 0.0], [0.08, S * 0.08]])


@pytest.mark.parametrize("method, dt", [("ode3", 1e-5), ("ode3", 2e-5), ("rk4", 5e-5)])
def test_a_reversed_gear_locks_late_by_its_time_constant_at_any_step(method, dt):
    # Closing at v, the internal force runs ahead of the loading curve by e with
    # de/dt = k_locked v - e / tau (so e -> k_locked v tau); reversed to -w, the force
    # stays on the loading curve until e has fallen to 0, after t* = tau ln(1 + v / w),
    # and then follows the locked line. Against an instant lock (tau -> 0) the locked
    # line is raised by k_locked w t*: the time constant, measured on the force.
    c = CouplerParams(**PARALLEL)
    tau = c.tracking_time
    assert tau == 4e-4  # the documented default, whatever the step
    x_rev, v, w = 0.04, 0.1, 0.05  # m, m/s, m/s
    t_rev = x_rev / v
    t = np.linspace(0.0, t_rev + 0.02, int(round((t_rev + 0.02) / 1e-5)) + 1)
    d = np.where(t <= t_rev, v * t, x_rev - w * (t - t_rev))
    ds = drive_deflection(c, t, d, dt=dt, method=method)
    tt, f = ds.time.values, ds.force.values
    # locked, well after the transient and before the unloading curve (reached after
    # F0 / (k_locked w) = 40 ms)
    late = (tt > t_rev + 20 * tau) & (tt < t_rev + 0.015)
    instant = F0 + S * x_rev - (K_LOCK + S) * w * (tt[late] - t_rev)
    raised = f[late] - instant
    expected = K_LOCK * w * tau * math.log(1.0 + v / w)  # 1.1 kN
    assert np.ptp(raised) < 1e-6 * expected  # a parallel shift of the locked line
    assert_allclose(raised.mean(), expected, rtol=0.01)


def _impact_errors(quantity):
    """Error of ``quantity`` of a 1.5 m/s two-wagon impact through the high friction
    gear at ode3 steps 4e-4 ... 5e-5 s against a run at 6.25e-6 s."""
    c = CouplerParams(preset="friction-wedge-high")
    ref = impact(c, 1.5, dt=6.25e-6, t_max=1.0)[quantity]
    steps = (4e-4, 2e-4, 1e-4, 5e-5)
    return np.array([abs(impact(c, 1.5, dt=dt, t_max=1.0)[quantity] - ref) for dt in steps])


@pytest.mark.parametrize("quantity", ["peak_force_N", "kinetic_energy_lost_J"])
def test_a_friction_gear_impact_converges_at_first_order_or_better_as_the_step_halves(quantity):
    # ode3 is third order on smooth problems; the gear's right-hand side has steps (its
    # release force at the slack edge, the plates' pick-up, the locked/sliding switch)
    # that a step without event location straddles, which costs an O(dt) error each:
    # the bound is first order (benchmarks/study_dt_convergence.py measures 1-2).
    err = _impact_errors(quantity)
    assert np.all(err[1:] < err[:-1]), err  # every halving brings it closer
    assert err[-1] <= err[0] / 8.0, err  # 8x smaller step, at least 8x smaller error


def test_bs23_and_a_fine_fixed_step_integrate_the_same_gear():
    # with the old default (4 steps; 4e-4 s under bs23) these were two gears, whose
    # impacts differ by 3.6 % in the energy lost
    c = CouplerParams(preset="friction-wedge-high")
    fine = impact(c, 1.5, dt=6.25e-6, t_max=1.0)
    adaptive = impact(c, 1.5, method="bs23", dt=1e-4, t_max=1.0)
    assert_allclose(adaptive["kinetic_energy_lost_J"], fine["kinetic_energy_lost_J"], rtol=2e-3)
    assert_allclose(adaptive["peak_force_N"], fine["peak_force_N"], rtol=1e-4)
