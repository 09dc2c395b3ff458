"""A plain hand-written numba kernel of one train: the in-run reference of bench_kernel.py.

What it simulates: a train of vehicles joined by the study's simplified couplers (paper
Eq. 9), with Davis, grade and curve resistance on a piecewise-constant track (paper Eq.
11-14), driven in force mode (a piecewise-linear force profile clipped to the traction
curve, paper §4, Eq. 15-16), stepped by ode3 (Bogacki-Shampine, third order, fixed step)
and recording the coupler forces into a preallocated array every ``record_every`` steps.
That is all it does: no brakes, no speed controller, no other coupler model, no
traction lag, no other recorded variable. It is what a programmer would write by hand
for this one case, to measure what ltdsim's general engine costs on top of it.

It reads the validated :class:`ltdsim.scenario.model.Scenario` directly (not ltdsim's lowered
tables) and calls the same compiled force laws as ltdsim's kernel
(:func:`ltdsim.physics.gears.couplers.simplified_force`,
:func:`ltdsim.physics.resistance.davis_force`, ``grade_force``,
``curve_force``, :func:`ltdsim.physics.drive.traction.traction_max`), so that its
coupler forces agree with ltdsim's to round-off: a check that the two simulate the same
train. The stepping, the force balance, the track and profile look-ups and the
recording are written out here.

Used by benchmarks/bench_kernel.py and tests/engine/test_reference_kernel.py.
"""

from __future__ import annotations

import numpy as np
from numba import njit

import ltdsim  # noqa: F401  (sets numba's cache folder before anything compiles)
from ltdsim.physics.gears.couplers import simplified_force
from ltdsim.physics.resistance import (
    PURE_SIGN,
    curve_force,
    davis_force,
    grade_force,
)
from ltdsim.physics.drive.traction import traction_max

# ode3 (Bogacki-Shampine 3(2), its third-order solution; Simulink's ode3)
_A21 = 0.5
_A32 = 0.75
_B1, _B2, _B3 = 2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0


def inputs(sc) -> dict:
    """The arrays and numbers :func:`run` takes, read from scenario ``sc`` (SI units).

    Refuses, with ValueError, a scenario outside what this kernel simulates."""
    veh = sc.vehicles
    n = len(veh)
    if sc.driver.mode != "force":
        raise ValueError("the reference kernel runs driver.mode = 'force' only")
    if sc.solver.method != "ode3" or sc.solver.adaptive:
        raise ValueError("the reference kernel steps with fixed-step ode3 only")
    if any(v.brake is not None for v in veh):
        raise ValueError("the reference kernel has no air brakes")
    if sc.traction.time_constant > 0.0:
        raise ValueError("the reference kernel has no traction lag")
    consists = sc.consists()
    if len(consists) != 1 or len(consists[0].vehicles) != 1:
        raise ValueError("the reference kernel has one locomotive")
    if sc.initial.velocities is not None:
        raise ValueError("the reference kernel starts every vehicle at initial.speed")
    cpl = [sc.coupler(j) for j in range(n - 1)]
    if any(c.model != "simplified" for c in cpl):
        raise ValueError("the reference kernel has simplified couplers only")
    if sc.initial.couplers != "neutral":
        raise ValueError("the reference kernel starts with the couplers at neutral")
    loco = consists[0].vehicles[0]
    t = sc.traction
    lengths = np.array([v.length for v in veh])
    p0 = np.zeros(n)  # vehicle centres, lead at 0
    p0[1:] = -np.cumsum(0.5 * (lengths[:-1] + lengths[1:]))
    grade = np.array(sc.track.gradient, dtype=float).reshape(-1, 2)
    curve = np.array(sc.track.curve, dtype=float).reshape(-1, 2)
    radius = curve[:, 1]
    curvature = np.where(radius != 0.0, 1.0 / np.where(radius != 0.0, radius, 1.0), 0.0)
    prof = np.array(sc.driver.force_profile, dtype=float).reshape(-1, 2)
    y0 = np.zeros(2 * n)
    y0[n:] = sc.initial.speed
    sv = sc.solver
    return dict(
        y=y0, dt=float(sv.dt), n_steps=int(sv.n_steps), record_every=int(sv.record_every),
        inv_m=np.array([1.0 / v.mass for v in veh]),
        weight_mass=np.array([v.weight_mass for v in veh]),
        davis_a=np.array([v.davis.a for v in veh]), davis_b=np.array([v.davis.b for v in veh]),
        davis_c=np.array([v.davis.c for v in veh]),
        davis_inv_v0=np.array([1.0 / v.davis.v0 if v.davis.v0 > 1e-12 else PURE_SIGN
                               for v in veh]),
        p0=p0, grade_x=grade[:, 0].copy(), grade=grade[:, 1].copy(),
        curve_x=curve[:, 0].copy(), curvature=curvature, curve_h=float(sc.track.curve_h),
        g=float(sc.track.gravity),
        slack=np.array([c.slack for c in cpl]), preload=np.array([c.preload for c in cpl]),
        damping=np.array([c.damping for c in cpl]), k1=np.array([c.k1 for c in cpl]),
        k2=np.array([c.k2 for c in cpl]), k3=np.array([c.k3 for c in cpl]),
        inv_vc=np.array([1.0 / c.v_c for c in cpl]),
        by_rate=np.array([c.fade == "rate" for c in cpl]),
        travel=np.array([np.inf if c.travel is None else c.travel for c in cpl]),
        solid_stiffness=np.array([c.solid_stiffness for c in cpl]),
        prof_t=prof[:, 0].copy(), prof_f=prof[:, 1].copy(), loco=int(loco),
        max_force=float(t.max_force if consists[0].max_force is None else consists[0].max_force),
        max_power=float(t.max_power if consists[0].max_power is None else consists[0].max_power),
        adhesion_mass=float(t.adhesion_mass if consists[0].adhesion_mass is None
                            else consists[0].adhesion_mass),
        fade=float(t.brake_fade),
    )


def allocate(inp: dict) -> np.ndarray:
    """The coupler-force record :func:`run` fills: (records, couplers), N."""
    n_rec = inp["n_steps"] // inp["record_every"] + 1
    return np.empty((n_rec, inp["y"].shape[0] // 2 - 1))


@njit(cache=True, inline="always")
def _lookup(xs, x, k):
    """Index of the segment of the breakpoints ``xs`` (m or s) that holds ``x``, searched
    from the previous answer ``k`` (0 before the first breakpoint)."""
    m = xs.shape[0]
    while k + 1 < m and xs[k + 1] <= x:
        k += 1
    while k > 0 and xs[k] > x:
        k -= 1
    return k


@njit(cache=True)
def run(y, dt, n_steps, record_every, inv_m, weight_mass, davis_a, davis_b, davis_c,
        davis_inv_v0, p0, grade_x, grade, curve_x, curvature, curve_h, g, slack, preload,
        damping, k1, k2, k3, inv_vc, by_rate, travel, solid_stiffness, prof_t, prof_f, loco,
        max_force, max_power, adhesion_mass, fade, out_force):
    """Step ``y = [x (n) m, v (n) m/s]`` (updated in place) ``n_steps`` steps of ``dt``
    (s) with ode3 and write the coupler forces (N, + tension) at every
    ``record_every``-th step and at the end into ``out_force`` (records x couplers).
    Returns the number of records written."""
    n = inv_m.shape[0]
    ny = y.shape[0]
    K = np.empty((3, ny))  # the three stage derivatives
    ys = np.empty(ny)  # the state a stage is evaluated at
    force = np.empty(max(n - 1, 1))
    kg = np.zeros(n, dtype=np.int64)  # search cursors: grade and curve segment per vehicle
    kc = np.zeros(n, dtype=np.int64)
    kp = 0  # and the force profile's segment
    step_a = (0.0, dt * _A21, dt * _A32)  # stage s at y + step_a[s] K[s - 1]
    node = (0.0, _A21, _A32)
    w1, w2, w3 = dt * _B1, dt * _B2, dt * _B3
    r = 0
    c_rec = 0
    for k in range(n_steps + 1):
        t0 = k * dt
        for s in range(3):
            if s == 0:
                for q in range(ny):
                    ys[q] = y[q]
            else:
                for q in range(ny):
                    ys[q] = y[q] + step_a[s] * K[s - 1, q]
            t = t0 + node[s] * dt
            # traction: the force profile at t, within the traction curve at the loco's
            # speed
            kp = _lookup(prof_t, t, kp)
            if t <= prof_t[0]:
                demand = prof_f[0]
            elif kp + 1 >= prof_t.shape[0]:
                demand = prof_f[kp]
            else:
                wt = (t - prof_t[kp]) / (prof_t[kp + 1] - prof_t[kp])
                demand = prof_f[kp] + wt * (prof_f[kp + 1] - prof_f[kp])
            v_loco = ys[n + loco]
            lim = traction_max(v_loco, max_force, max_power, adhesion_mass, g)
            traction = min(max(demand, -lim), lim)
            if traction < 0.0:  # dynamic braking fades near rest, against the motion
                traction *= min(max(v_loco / fade, -1.0), 1.0)
            # couplers: deflection + draft, force + tension
            for j in range(n - 1):
                force[j] = simplified_force(ys[j] - ys[j + 1], ys[n + j] - ys[n + j + 1],
                                            slack[j], preload[j], damping[j], k1[j], k2[j],
                                            k3[j], inv_vc[j], by_rate[j], travel[j],
                                            solid_stiffness[j])
            # each vehicle: traction, resistance, the couplers on either side
            for i in range(n):
                v = ys[n + i]
                x = p0[i] + ys[i]
                kg[i] = _lookup(grade_x, x, kg[i])
                kc[i] = _lookup(curve_x, x, kc[i])
                res = davis_force(v, davis_a[i], davis_b[i], davis_c[i], davis_inv_v0[i])
                res += grade_force(weight_mass[i], grade[kg[i]], g)
                res += curve_force(v, weight_mass[i], curvature[kc[i]], curve_h, g)
                f = (traction if i == loco else 0.0) - res
                if i < n - 1:
                    f -= force[i]
                if i > 0:
                    f += force[i - 1]
                K[s, i] = v
                K[s, n + i] = f * inv_m[i]
            if s == 0:
                if c_rec == 0:  # record the forces at the start of the step
                    for j in range(n - 1):
                        out_force[r, j] = force[j]
                    r += 1
                c_rec += 1
                if c_rec == record_every:
                    c_rec = 0
                if k == n_steps:
                    return r
        for q in range(ny):
            y[q] += (w1 * K[0, q] + w2 * K[1, q]) + w3 * K[2, q]
    return r


def simulate(sc) -> np.ndarray:
    """Coupler forces of scenario ``sc`` (records x couplers, N), by :func:`run`."""
    inp = inputs(sc)
    out = allocate(inp)
    run(**inp, out_force=out)
    return out
