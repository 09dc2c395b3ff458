"""The lumped air brake's constants measured on the fluid-dynamic brake.

The lumped brake (``brake.model = "lumped"``) applies every cylinder with a first-order
lag after a signal delay; the fluid brake computes the pipe's air flow and every valve.
:func:`lumped_from_fluid` runs a fluid-brake scenario's emergency and reads off what the
lumped brake needs to stop the same train in the same distance:

* ``propagation_speed`` (m/s): the end-to-end speed of the emergency's pipe drop
  (:func:`ltdsim.results.summary.fluid_brake_summary`: the farthest braked vehicle's
  distance from its brake-control point over the time from the command until the drop
  reached it). The lumped brake's delay is that distance over this speed, so the rear
  starts braking when it does under the fluid brake.
* ``apply_time_constant`` (s): the median over the braked vehicles of the time constant
  of the first-order lag from the drop's arrival that fits, by least squares, the
  cylinder's pressure over its final pressure while the train is still moving (from the
  arrival to the stop): the force the lumped brake then gives is closest to the fluid
  brake's while it does work. (The area under ``1 - p / p_end`` is exact for a
  first-order lag but weighs a slow creep of the last per cent after the stop as much
  as the fill: with the UIC P valve it gave 3.9 s for a fill 95 % done in 4 s.)
* ``emergency_level`` (-): the emergency's piston force over a full service's, from the
  valve's equalisation pressures: ``(p_em A - S) / (p_full A - S)`` with the vehicles'
  piston area ``A`` (m^2) and return spring ``S`` (N) (the cylinder pressures of the
  emergency run and of a full service on the valve's own law, Pa gauge).
* ``minimum_level`` (-): the same for the minimum reduction.

The cylinder pressures of a full and a minimum service are the valve law's end states
(:func:`ltdsim.engine.lowering.service_pressure`: the UIC distributor's graduated law; an
AAR valve's Boyle equalisation of auxiliary reservoir and cylinder, with the pipe air of
its quick service neglected), so only the emergency needs a run. The numbers that ship in the valve presets'
``[lumped]`` tables were made by ``docs/scripts/lumped_calibration.py``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from ltdsim.engine.lowering import service_pressure
from ltdsim.physics.air import brakevalves as bv
from ltdsim.results.summary import fluid_brake_summary, stopping


def lumped_from_fluid(ds, scenario) -> dict[str, float]:
    """The lumped brake's ``propagation_speed`` (m/s), ``apply_time_constant`` (s),
    ``emergency_level`` and ``minimum_level`` (-) from ``ds``, a fluid-brake
    ``scenario``'s emergency run (module docstring). Raises ``ValueError`` when the run
    is not a fluid-brake emergency that reached every braked vehicle."""
    from ltdsim.scenario import valve_tables

    if scenario.brake.model != "fluid":
        raise ValueError("the calibration reads a fluid-brake run (brake.model = 'fluid')")
    fs = fluid_brake_summary(ds)
    if fs is None or not np.isfinite(fs.get("vent_front_speed_m_s", np.nan)):
        raise ValueError("the run is not an emergency (its pipe never vented at the far end)")
    t = ds.time.values
    cyl = ds.brake_cylinder_pressure.values  # Pa gauge
    arrival = fs["command_time_s"] + fs["arrival_s"]  # s (the summary's, from the command)
    braked = [i for i, v in enumerate(scenario.vehicles) if v.brake is not None]
    stop = stopping(ds)
    if stop is None:
        raise ValueError("the run does not brake the train to a stop")
    t_stop = stop["stop_time_s"]
    taus = []
    for i in braked:
        if not np.isfinite(arrival[i]):
            raise ValueError(f"the emergency did not reach vehicle {i + 1}")
        during = (t >= arrival[i]) & (t <= t_stop)
        p, ta = cyl[during, i], t[during] - arrival[i]
        if p.size < 3 or cyl[-1, i] <= 0.0:
            raise ValueError(f"vehicle {i + 1}'s cylinder did not apply before the stop")
        fill = p / cyl[-1, i]

        def misfit(tau, fill=fill, ta=ta):
            return float(np.sum((fill - (1.0 - np.exp(-ta / tau))) ** 2))

        taus.append(float(minimize_scalar(misfit, bounds=(0.05, 120.0), method="bounded").x))
    cv_table, dv_table = valve_tables(scenario.brake.fluid)
    cv_row, dv_row = bv.control_valve_row(cv_table), bv.driver_valve_row(dv_table)
    emergency = float(np.median(cyl[-1, braked]))
    full = service_pressure(cv_row, dv_row, dv_row[bv.DVP_FULL])
    minimum = service_pressure(cv_row, dv_row, dv_row[bv.DVP_MIN])
    b = scenario.vehicles[braked[0]].brake
    spring = b.return_spring
    # (the piston area the lowering derives when it is left out: a full service gives
    # cylinder_force)
    area = b.piston_area or (b.cylinder_force / b.efficiency + spring) / full

    def force(p):
        return max(p * area - spring, 0.0)

    return {"propagation_speed": float(fs["end_to_end_speed_m_s"]),
            "apply_time_constant": float(np.median(taus)),
            # (a UIC emergency gives the full-service pressure: 1 up to the rounding)
            "emergency_level": max(1.0, round(force(emergency) / force(full), 6)),
            "minimum_level": force(minimum) / force(full)}


def lumped_twin(scenario, calibration: str | None = None, constants: dict | None = None):
    """The fluid-brake ``scenario`` with the lumped brake in its place: the same train,
    track, driver and commands; ``brake.model = "lumped"`` with ``calibration`` (a valve
    preset's name, default the scenario's own preset; its ``[lumped]`` table sets the
    constants); each braked vehicle keeps ``cylinder_force`` (N, the full-service piston
    force both models then share) and drops the keys only the fluid brake reads.
    ``constants`` (the keys :func:`lumped_from_fluid` returns) are given to the lumped
    brake instead of a calibration."""
    from ltdsim.scenario import Scenario

    if scenario.brake.model != "fluid":
        raise ValueError("lumped_twin takes a fluid-brake scenario (brake.model = 'fluid')")
    valve = scenario.brake.fluid.valve
    name = calibration or (valve if isinstance(valve, str) else valve.get("preset"))
    if not isinstance(name, str):
        raise ValueError("an inline valve table without a preset: give the calibration's "
                         "preset name")
    d = scenario.to_dict()
    keep = {k: v for k, v in d["brake"].items()
            if k in ("standstill_speed", "level_step")}
    d["brake"] = ({"model": "lumped", **constants, **keep} if constants is not None else
                  {"model": "lumped", "calibration": name, **keep})
    for v in d["vehicles"]:
        b = v.get("brake")
        if not b:
            continue
        if b.get("cylinder_force") is None:
            raise ValueError(f"vehicle {v.get('name')!r}: the lumped twin needs its "
                             "cylinder_force (N)")
        for key in ("piston_area", "return_spring", "efficiency"):
            b.pop(key, None)
    return Scenario.from_dict(d, f"{scenario.name} (lumped twin)")
