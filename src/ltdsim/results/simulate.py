"""Simulate a scenario and return its result, a labelled ``xarray.Dataset``: the
memory check and the step-stability check before anything runs, the engine's run
(:mod:`ltdsim.engine.run`), every recorded array as a variable with its unit and
description (:mod:`ltdsim.variables`), and the curving indicators where the scenario
asks for them."""

from __future__ import annotations

import json
import time as _time

import numpy as np
import xarray as xr

from ltdsim.engine import kernel, preflight
from ltdsim.engine.layout import E_MOTOR, ENERGY_TERMS, N_ENERGY
from ltdsim.engine.lowering import Lowered, lower
from ltdsim.engine.run import (TIME_LIMIT, ProgressFn, check_memory, check_time, integrate,
                               recorded, zero_step_call)
from ltdsim.scenario import Scenario
from ltdsim.variables import DRIVE_SIGNALS, UNITS, VARIABLES

#: the ``long_name`` of every result variable (declared in :mod:`ltdsim.variables`)
DESCRIPTIONS = {v.name: v.description for v in VARIABLES}

def simulate(scenario: Scenario, progress: ProgressFn | None = None,
             chunks: int = 100, time_limit: float | None = TIME_LIMIT) -> xr.Dataset:
    """Simulate ``scenario`` and return its time series.

    Parameters
    ----------
    scenario : Scenario
        A validated scenario (see :func:`ltdsim.load_scenario`).
    progress : callable, optional
        Called as ``progress(t_done, t_end)`` in seconds of simulated time after each
        chunk of steps.
    chunks : int
        Number of kernel calls the run is split into (for progress and Ctrl-C), at
        least; a long run is split further so that each call lasts about
        :data:`~ltdsim.engine.run.CHUNK_SECONDS`.
    time_limit : float or None
        A run estimated (:func:`~ltdsim.engine.run.estimate`) to take longer than this
        (s of wall time) is refused before it starts; None: no limit.

    Returns
    -------
    xarray.Dataset
        ``position``, ``velocity``, ``acceleration``, ``relative_position``,
        ``relative_velocity`` (time x vehicle); ``coupler_deflection``,
        ``coupler_force`` (time x coupler); ``traction_force``, ``speed_reference``,
        ``speed_error``, ``adhesion_limit``, ``demanded_acceleration``,
        ``traction_demand`` (time); with the induction drive ``motor_torque``,
        ``motor_speed``, ``stator_current``, ``creep``, ``creep_force``, ``dc_power``,
        ``stator_flux_d``, ``stator_flux_q``, ``rotor_flux_d``, ``rotor_flux_q``
        (time x locomotive, NaN for a consist on the traction curve); of the time
        series only those ``solver.record`` names, when it names a selection. Units are
        in each variable's ``units`` attribute; the scenario (JSON) and run facts are in
        the dataset's attributes.

    Raises
    ------
    ScenarioError
        Before anything runs, if a fixed step is above the method's largest stable step
        for the train (:func:`ltdsim.engine.preflight.check`), or if the recording would
        take more than :data:`~ltdsim.engine.run.MEMORY_SHARE` of the memory available
        (:func:`~ltdsim.engine.run.check_memory`), or if it would take longer than
        ``time_limit`` (:func:`~ltdsim.engine.run.check_time`).
    SimulationError
        If the state becomes non-finite; the message names the time, the vehicle and
        coupler, and their values.
    """
    preflight.check(scenario)
    check_memory(scenario)
    check_time(scenario, time_limit)
    low = lower(scenario)
    t0 = _time.perf_counter()
    kern, args = zero_step_call(low)
    kern(*args)  # compile, or load from numba's cache (see ltdsim.engine.warmup)
    t1 = _time.perf_counter()
    rec = integrate(low, scenario, progress, chunks)
    wall = _time.perf_counter() - t1
    return _dataset(scenario, low, rec, wall, compile_time=t1 - t0)


def _dataset(scenario: Scenario, low: Lowered, rec: dict, wall: float,
             compile_time: float) -> xr.Dataset:
    n = low.n
    n_rec = rec["s"].shape[0]
    keep = recorded(scenario)
    time = np.arange(n_rec) * (low.record_every * low.dt)
    p0 = low.p0
    position = rec["x"]  # the kernel records track positions
    vel = rec["v"]
    ref = low.speed_vehicle
    s = rec["s"]
    vdims = ("time", "vehicle")
    cdims = ("time", "coupler")
    data = {}
    if "x" in keep:
        data["position"] = (vdims, position)
    if "v" in keep:
        data["velocity"] = (vdims, vel)
    if "a" in keep:
        data["acceleration"] = (vdims, rec["a"])
    if "x" in keep:  # position - position[:, :1] - (p0 - p0[0]), with one temporary less
        rel = np.subtract(position, position[:, :1])
        rel -= p0 - p0[0]
        data["relative_position"] = (vdims, rel)
    if "v" in keep:
        data["relative_velocity"] = (vdims, vel - vel[:, :1])
    if "d" in keep:
        data["coupler_deflection"] = (cdims, rec["d"])
    if "f" in keep:
        data["coupler_force"] = (cdims, rec["f"])
    data.update({
        "traction_force": ("time", s[:, kernel.SG_TRACTION]),
        "speed_reference": ("time", s[:, kernel.SG_VREF]),
    })
    if "v" in keep:
        data["speed_error"] = ("time", s[:, kernel.SG_VREF] - vel[:, ref])
    data.update({
        "adhesion_limit": ("time", s[:, kernel.SG_ADHESION]),
        "demanded_acceleration": ("time", s[:, kernel.SG_ADEM]),
        "traction_demand": ("time", s[:, kernel.SG_DEMAND]),
    })
    coords = {
        "time": ("time", time),
        "vehicle": ("vehicle", np.arange(n)),
        "vehicle_name": ("vehicle", [v.name for v in scenario.vehicles]),
        "coupler": ("coupler", np.arange(n - 1)),
        # the numbers people read: vehicle 1 is the lead, coupler 1 joins vehicles 1 and 2
        "vehicle_number": ("vehicle", np.arange(1, n + 1)),
        "coupler_number": ("coupler", np.arange(1, n)),
    }
    nc = n - 1
    for col, name in ((kernel.PK_MAX, "max_coupler_force"), (kernel.PK_MIN, "min_coupler_force"),
                      (kernel.PK_TMAX, "time_max_coupler_force"),
                      (kernel.PK_TMIN, "time_min_coupler_force")):
        data[name] = ("coupler", rec["peaks"][:, col] if nc else np.zeros(0))
    if low.braked:
        data["brake_command"] = ("time", s[:, kernel.SG_BRAKE])
        for key, name in (("b", "brake_force"), ("p", "brake_cylinder")):
            if key in keep:
                data[name] = (vdims, rec[key])
    if low.fluid:
        for key, name in (("bp", "brake_pipe_pressure"), ("ar", "auxiliary_reservoir_pressure"),
                          ("bc", "brake_cylinder_pressure")):
            if key in keep:
                data[name] = (vdims, rec[key])
        if "ax" in keep:
            data["air_exhausted"] = ("time", rec["ax"][:, 0])
    if rec["c"].shape[1]:
        data["locomotive_force"] = (("time", "locomotive"), rec["c"])
    if rec["c"].shape[1] or (low.drive_z.size and "m" in keep):
        coords["locomotive"] = ("locomotive", [c.name for c in scenario.consists()])
    if low.drive_z.size and "m" in keep:
        # per consist (NaN for one on the traction curve); per motor or per locomotive
        # as DESCRIPTIONS says
        for q, name in enumerate(DRIVE_SIGNALS):
            arr = np.full((n_rec, low.drive_of.size), np.nan)
            for c, kd in enumerate(low.drive_of):
                if kd >= 0:
                    arr[:, c] = rec["m"][:, kd, q]
            data[name] = (("time", "locomotive"), arr)
    if rec["e"].shape[1]:
        e = rec["e"]
        for q, name in enumerate(ENERGY_TERMS):
            data[name] = ("time", e[:, q])
        data["coupler_energy"] = (cdims, e[:, N_ENERGY:N_ENERGY + nc])
        data["kinetic_energy"] = ("time", e[:, -1])
        # motoring less every other term (work taken from the train) less the kinetic
        # energy gained: one product with the signs (numpy's sum over a short row axis
        # takes ten times as long on a long record; einsum's loop, unlike the BLAS
        # product, starts no threads, which on a loaded machine wait for a core)
        signs = np.full(e.shape[1], -1.0)
        signs[E_MOTOR] = 1.0
        data["energy_balance_error"] = ("time", np.einsum("ij,j->i", e, signs) + e[0, -1])
    ds = xr.Dataset(data, coords=coords)
    for name, unit in UNITS.items():
        if name in ds:
            ds[name].attrs["units"] = unit
            if name in DESCRIPTIONS:
                ds[name].attrs["long_name"] = DESCRIPTIONS[name]
    ds["coupler"].attrs["long_name"] = "coupler i joins vehicle i and i + 1 (0 = lead)"
    ds["vehicle"].attrs["long_name"] = "vehicle index, 0 = lead, front to rear"
    ds["vehicle_number"].attrs["long_name"] = "vehicle number as people count: 1 = lead, " \
                                              "front to rear (vehicle index + 1)"
    ds["coupler_number"].attrs["long_name"] = "coupler number as people count: coupler k " \
                                              "joins vehicles k and k + 1, 1 = behind the " \
                                              "lead (coupler index + 1)"
    from ltdsim._version import __version__

    ds.attrs.update({
        "title": f"ltdsim result: {scenario.name}" + (f" case {scenario.case}" if scenario.case else ""),
        "ltdsim_version": __version__,
        "scenario_name": scenario.name,
        "case": scenario.case or "",
        "solver_method": scenario.solver.method,
        "solver_dt_s": scenario.solver.dt,
        "steps": rec["steps"][0],
        "rejected_steps": rec["steps"][1],
        "brake_commands": rec["n_events"],
        "brake_model": scenario.brake.model,
        "wall_time_s": wall,
        "compile_time_s": compile_time,
        "scenario_json": json.dumps(scenario.to_dict()),
        "conventions": "SI units; coupler force + tension; vehicle index 0 (vehicle_number "
                       "1) is the lead; coupler index 0 (coupler_number 1) joins the lead "
                       "and the second vehicle",
    })
    if scenario.brake.model == "fluid" and scenario.solver.adaptive:
        # the pneumatic states' own steps (kernel.run_adaptive)
        ds.attrs["air_steps"] = rec["air_steps"][0]
        ds.attrs["air_rejected_steps"] = rec["air_steps"][1]
    if scenario.solver.adaptive and scenario.solver.hold_speed is not None:
        # couplings held at, or released from, their slack edges (solver.hold_speed)
        ds.attrs["edge_holds"] = rec["holds"]
    if scenario.curving is not None:  # after the run, from the records (ltdsim.results.safety)
        ds = _with_curving(ds, scenario)
    if ds.sizes.get("coupler", 0):  # a saved result carries them (ltdsim.results.strength)
        from ltdsim.results.strength import ATTR, events_json, strength_events

        ds.attrs[ATTR] = events_json(strength_events(ds, scenario))
        # and the couplers' fatigue damage (ltdsim.results.fatigue), of those with a curve
        from ltdsim.results import fatigue

        ds.attrs[fatigue.ATTR] = fatigue.damage_json(fatigue.fatigue_damage(ds, scenario))
    return ds


#: the start of the one line (``attrs["curving_error"]``, a RuntimeWarning) that says the
#: curving pass after a run failed and the run is kept without its indicators
CURVING_FAILED = "curving indicators not computed"


def _with_curving(ds: xr.Dataset, scenario: Scenario) -> xr.Dataset:
    """``ds`` with the curving indicators of ``scenario`` (:func:`ltdsim.results.safety.
    add_curving`). The pass runs on a finished run, so its failure never loses the run:
    ``ds`` comes back without the indicators, with the reason in one line as its
    ``curving_error`` attribute and as a RuntimeWarning."""
    import warnings

    from ltdsim.results.safety import add_curving

    try:
        return add_curving(ds, scenario)
    except Exception as exc:  # (MemoryError, ValueError, ...): whatever it is, keep the run
        why = " ".join(f"{type(exc).__name__}: {exc}".split())
        line = f"{CURVING_FAILED} ({why}); the run's results are kept without them"
        ds.attrs["curving_error"] = line
        warnings.warn(line, RuntimeWarning, stacklevel=3)
        return ds
