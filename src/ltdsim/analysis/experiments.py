"""Standard experiments on a scenario's train, run by simulation.

* :func:`force_step`: the train running steadily on straight, level track, its
  locomotives' force raised by a step; the first wagon's acceleration per unit of the
  rigid train's acceleration. This is the physical step response that the study's
  identified transfer functions (Table 4) approximate, measured on the nonlinear train
  itself. :func:`force_step_run` is the same run whole, :func:`step_physics` its
  physical quantities (peak acceleration, coupler 1's peak over its steady change, the
  time its force takes to settle).
"""

from __future__ import annotations

import numpy as np

from ltdsim.scenario import Scenario


def running_resistance(scenario: Scenario, speed: float) -> float:
    """Davis resistance of the whole train at ``speed`` (m/s) on level straight track, N."""
    return float(sum(v.davis.a + v.davis.b * speed + v.davis.c * speed * speed
                     for v in scenario.vehicles))


def force_step_run(scenario: Scenario, speed: float = 10.0, step: float | None = None,
                   settle: float = 5.0, duration: float = 60.0):
    """The simulated force step of :func:`force_step`, whole: ``(ds, t0, step, mass)``,
    the result, the time of the step (s), the step (N) and the train's mass (kg)."""
    from ltdsim.results.simulate import simulate

    step = 0.1 * scenario.traction.max_force if step is None else float(step)
    hold = running_resistance(scenario, speed)
    t0 = settle
    dt = scenario.solver.dt
    sc = scenario.with_overrides({
        "driver.mode": "force", "driver.pid": None,
        "driver.force_profile": [[0.0, hold], [t0, hold], [t0 + dt, hold + step]],
        "initial.speed": speed, "initial.velocities": None, "initial.couplers": "stretched",
        "track.gradient": [[0.0, 0.0]], "track.curve": [[0.0, 0.0]],
        "solver.t_end": t0 + duration}, source="force step")
    return simulate(sc), t0, step, float(sum(v.mass for v in sc.vehicles))


def force_step(scenario: Scenario, speed: float = 10.0, step: float | None = None,
               settle: float = 5.0, duration: float = 60.0, output: int = 1):
    """Step response of vehicle ``output``'s acceleration to a step in locomotive force.

    The train runs at ``speed`` (m/s) with its couplers stretched on straight, level
    track; the locomotives' force (driver in force mode) balances the running resistance
    for ``settle`` seconds and then rises by ``step`` newtons (default 10 % of the
    traction curve's force limit) for ``duration`` seconds. Solver and couplers are the
    scenario's.

    Returns ``(t, y)``: time after the step (s) and the acceleration of vehicle
    ``output`` (0 = lead; default the first wagon) minus its mean before the step,
    divided by ``step / train mass`` (-). A rigid train gives ``y = 1``.
    """
    ds, t0, step, mass = force_step_run(scenario, speed, step, settle, duration)
    t = ds.time.values
    a = ds.acceleration.values[:, output]
    before = (t > 0.5 * t0) & (t < t0)
    after = t >= t0 + scenario.solver.dt
    return t[after] - t0, (a[after] - a[before].mean()) / (step / mass)


def step_physics(ds, t0: float, step: float, mass: float, first_mass: float,
                 output: int = 1, band: float = 0.05) -> dict:
    """The force step of :func:`force_step_run` in physical quantities.

    Returns ``step_N``; ``rigid_acceleration_m_s2``, ``step / mass``, what a rigid
    train's every vehicle answers; ``peak_acceleration_m_s2``, the largest change of
    vehicle ``output``'s acceleration after the step (m/s^2, + forward);
    ``steady_coupler_change_N``, the rigid train's change of coupler 1's force,
    ``step`` times the share of the mass behind it, ``(mass - first_mass) / mass`` with
    ``first_mass`` the lead vehicle's (kg) (N); ``coupler_peak_to_steady``, the
    largest change of coupler 1's force over that (-; 2 for an undamped spring meeting
    a step); ``decay_time_s``, the time after the step from which coupler 1's force
    change stays within ``band`` (a share, default 5 %) of the steady change (s; NaN
    when it has not by the record's end); and ``ringing_first``, ``ringing_last``, the
    largest departure of coupler 1's force change from the steady change over the first
    and the last 10 s after the step, as shares of the steady change (-): how fast the
    ringing dies."""
    t = ds.time.values
    before = (t > 0.5 * t0) & (t < t0)
    after = t > t0
    a = ds.acceleration.values[:, output]
    da = a[after] - a[before].mean()
    steady = step * (mass - first_mass) / mass
    f = ds.coupler_force.values[:, 0]
    df = f[after] - f[before].mean()
    tt = t[after] - t0
    out_of_band = np.abs(df - steady) > band * abs(steady)
    last = tt[out_of_band][-1] if out_of_band.any() else 0.0
    ends = tt[-1] - 2.0 * (tt[1] - tt[0]) if tt.size > 1 else 0.0
    return {"step_N": float(step), "rigid_acceleration_m_s2": float(step / mass),
            "peak_acceleration_m_s2": float(da[np.argmax(np.abs(da))]),
            "steady_coupler_change_N": float(steady),
            "coupler_peak_to_steady": float(np.max(df) / steady),
            "decay_time_s": float(last) if last < ends else float("nan"),
            "ringing_first": float(np.max(np.abs(df - steady)[tt <= 10.0]) / abs(steady)),
            "ringing_last": float(np.max(np.abs(df - steady)[tt >= tt[-1] - 10.0])
                                  / abs(steady)),
            "band": band}


def step_info(t, y, final: float = 1.0, settling: float = 0.02) -> dict:
    """python-control's step metrics of a sampled response ``y(t)`` against the final
    value ``final`` (default 1, the rigid train): rise time, settling time (s; NaN when
    the response has not settled within the record), overshoot (%), peak (-), peak
    time (s)."""
    import control

    info = dict(control.step_info(np.asarray(y), np.asarray(t), yfinal=final,
                                  SettlingTimeThreshold=settling))
    if info["SettlingTime"] >= t[-1] - 2 * (t[1] - t[0]):
        info["SettlingTime"] = float("nan")  # still outside the band at the record's end
    return {k: float(v) for k, v in info.items()}
