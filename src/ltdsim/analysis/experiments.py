"""Standard experiments on a scenario's train, run by simulation.

* :func:`force_step`: the train running steadily on straight, level track, its
  locomotives' force raised by a step; the first wagon's acceleration per unit of the
  rigid train's acceleration. This is the physical step response that the study's
  identified transfer functions (Table 4) approximate, measured on the nonlinear train
  itself.
"""

from __future__ import annotations

import numpy as np

from ltdsim.scenario import Scenario


def running_resistance(scenario: Scenario, speed: float) -> float:
    """Davis resistance of the whole train at ``speed`` (m/s) on level straight track, N."""
    return float(sum(v.davis.a + v.davis.b * speed + v.davis.c * speed * speed
                     for v in scenario.vehicles))


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
    ds = simulate(sc)
    t = ds.time.values
    a = ds.acceleration.values[:, output]
    before = (t > 0.5 * t0) & (t < t0)
    after = t >= t0 + dt
    mass = sum(v.mass for v in sc.vehicles)
    return t[after] - t0, (a[after] - a[before].mean()) / (step / mass)


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
