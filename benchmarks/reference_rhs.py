"""The same train model as a plain NumPy right-hand side for ``scipy.integrate.solve_ivp``.

It is written independently of the compiled kernel (vectorised over vehicles, no
search cursors, no work arrays) and serves two purposes: tests check the kernel's
integrators against ``solve_ivp`` on it, and the benchmark times it as the
"plain SciPy" reference.

The discrete PID cannot live inside an adaptive solver, so in speed mode this model
uses the continuous-time PID with the same gains: ``u = kp e + ki I + N (kd e - F)``,
``dI/dt = e``, ``dF/dt = N (kd e - F)``. With the study's Ts = 1e-4 s the two agree to
first order in Ts.
"""

from __future__ import annotations

import numpy as np

from ltdsim.engine.lowering import rounded_profile
from ltdsim.physics import (
    coupler_linear, coupler_simplified, curve_resistance, davis_resistance, grade_resistance,
    traction_limit,
)
from ltdsim.scenario import Scenario

#: the coupler models this reference covers
MODELS = ("linear", "simplified")


def _step_table(points):
    """A piecewise-constant track table ``[start m, value]`` as arrays (starts, values)."""
    arr = np.asarray(points, dtype=float).reshape(-1, 2)
    return arr[:, 0], arr[:, 1]


def make_rhs(scenario: Scenario):
    """Return ``(f, y0)``: ``f(t, y)`` for ``solve_ivp`` and the initial state.

    The state is ``[x (n), v (n)]`` (displacements m, speeds m/s) plus, in speed mode,
    the PID integrator and filter states. Built from the validated scenario alone (not
    from the kernel's lowered arrays), so that it checks the lowering too.
    """
    s = scenario
    couplers = [s.coupler(j) for j in range(s.n_couplers)]
    consists = s.consists()
    t = s.traction

    def pick(loco, key):
        own = getattr(loco, key)
        return getattr(t, key) if own is None else own

    unsupported = [what for what, present in (
        ("couplers of models other than " + " and ".join(MODELS),
         any(c.model not in MODELS for c in couplers)),
        ("air brakes", any(v.brake is not None for v in s.vehicles)),
        ("several locomotive consists", len(consists) > 1),
        ("traction lag", any(pick(loco, "time_constant") > 0 for loco in consists)),
        ("notch mode", s.driver.mode == "notch")) if present]
    if unsupported:
        raise NotImplementedError("the NumPy reference model covers linear and simplified "
                                  "couplers with one consist only; not: " + ", ".join(unsupported))
    n = s.n_vehicles
    lead = consists[0]
    m = np.array([v.mass for v in s.vehicles])
    wm = np.array([v.weight_mass for v in s.vehicles])
    da, db, dc, v0 = (np.array([getattr(v.davis, k) for v in s.vehicles])
                      for k in ("a", "b", "c", "v0"))
    share = np.zeros(n)
    share[lead.vehicles] = 1.0 / len(lead.vehicles)
    # vehicle centres: lead at 0, the rest behind at half-length spacings
    lengths = np.array([v.length for v in s.vehicles])
    p0 = np.concatenate([[0.0], -np.cumsum(0.5 * (lengths[:-1] + lengths[1:]))])
    grade_at, grade = _step_table(s.track.gradient)
    curve_at, radius = _step_table(s.track.resistance_curve())
    curvature = np.divide(1.0, radius, out=np.zeros_like(radius), where=radius != 0.0)
    g = s.track.gravity
    # couplers: each model's parameters (unused ones 0), the initial state of the slack
    linear = np.array([c.model == "linear" for c in couplers], dtype=bool)

    def par(key, default=0.0):
        return np.array([getattr(c, key, None) if getattr(c, key, None) is not None
                         else default for c in couplers], dtype=float)

    slack = par("slack")
    stiffness, damping, preload = par("stiffness"), par("damping"), par("preload")
    k1, k2, k3, v_c = par("k1"), par("k2"), par("k3"), par("v_c", 1.0)
    by_rate = np.array([getattr(c, "fade", "deflection") == "rate" for c in couplers])
    gears = par("gears", 1.0)
    travel, solid = par("travel", np.inf), par("solid_stiffness")
    sign0 = {"neutral": 0.0, "stretched": 1.0, "bunched": -1.0}[s.initial.couplers]
    d0 = sign0 * 0.5 * slack
    # traction: the lead consist's curve; the speed controller's demand
    fmax, pmax, madh = (pick(lead, k) for k in ("max_force", "max_power", "adhesion_mass"))
    ref = lead.vehicles[0]
    d = s.driver
    speed = d.mode == "speed"
    m_demand = m.sum()
    if speed and d.pid.acceleration_of == "locomotive":
        m_demand = m[lead.vehicles].sum()
    ratio = m.sum() / m_demand  # the output's clip scales with the masses' ratio
    if speed:
        prof_t, prof_y = rounded_profile(d.speed_profile)
    else:
        prof = np.asarray(d.force_profile, dtype=float).reshape(-1, 2)
        prof_t, prof_y = prof[:, 0], prof[:, 1]

    def f(time, y):
        x, v = y[:n], y[n:2 * n]
        p = p0 + x
        kg = np.clip(np.searchsorted(grade_at, p, side="right") - 1, 0, None)
        kc = np.clip(np.searchsorted(curve_at, p, side="right") - 1, 0, None)
        res = (davis_resistance(v, da, db, dc, v0)
               + grade_resistance(wm, grade[kg], g)
               + curve_resistance(v, wm, curvature[kc], s.track.curve_h, g))
        # each of a coupling's gears in series takes its share of the deflection and
        # slack and carries the whole force
        dx = (x[:-1] - x[1:] + d0) / gears
        dv = (v[:-1] - v[1:]) / gears
        tension = np.where(
            linear,
            coupler_linear(dx, dv, slack / gears, stiffness, damping, travel, solid),
            coupler_simplified(dx, dv, slack / gears, preload, damping, k1, k2, k3, v_c,
                               by_rate, travel, solid))
        extra = []
        if speed:
            pid = d.pid
            e = np.interp(time, prof_t, prof_y) - v[ref]
            u_d = pid.n * (pid.kd * e - y[2 * n + 1])
            u = pid.kp * e + pid.ki * y[2 * n] + u_d
            a_dem = min(max(u, -t.max_decel * ratio), t.max_accel * ratio)
            demand = a_dem * m_demand + (1.0 if t.feedforward else 0.0) * res.sum()
            extra = [e, u_d]
        else:
            demand = np.interp(time, prof_t, prof_y)
        lim = traction_limit(v[ref], fmax, pmax, madh, g)
        force = share * min(max(demand, -lim), lim) - res
        force[:-1] -= tension
        force[1:] += tension
        return np.concatenate([v, force / m, extra])

    vel = (np.full(n, float(s.initial.speed)) if s.initial.velocities is None
           else np.asarray(s.initial.velocities, dtype=float))
    y0 = np.concatenate([np.zeros(n), vel])
    if speed:
        y0 = np.concatenate([y0, [0.0, 0.0]])
    return f, y0
