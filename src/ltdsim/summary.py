"""Summary numbers of a result: what an engineer checks first."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import xarray as xr

#: m: rating travel of an AAR M-901 draft gear of 3-1/4 in (82.55 mm), the reference
#: against which gears without a stated travel (the study's simplified coupler) are checked
REFERENCE_TRAVEL = 0.083


def coupler_summary(ds: xr.Dataset) -> pd.DataFrame:
    """Per coupler: largest tension and compression (N) and when they occur (s). The
    peaks are taken over every integration step where the result tracks them
    (``max_coupler_force`` etc.), else over the recorded samples."""
    f = ds.coupler_force
    if "time_max_coupler_force" in ds:
        top, low = ds.max_coupler_force.values, ds.min_coupler_force.values
        t_top, t_low = ds.time_max_coupler_force.values, ds.time_min_coupler_force.values
    else:  # a result written before the kernel tracked peaks
        t = ds.time.values
        top, low = f.max("time").values, f.min("time").values
        t_top, t_low = t[f.argmax("time").values], t[f.argmin("time").values]
    return pd.DataFrame({
        "coupler": ds.coupler.values,
        "max_tension_N": np.maximum(top, 0.0),
        "t_max_tension_s": t_top,
        "max_compression_N": np.maximum(-low, 0.0),
        "t_max_compression_s": t_low,
    }).set_index("coupler")


def critical_rows(table: pd.DataFrame, limit: int = 20) -> pd.DataFrame:
    """The whole coupler summary for short trains; for longer ones the ``limit`` couplers
    with the largest tension or compression, in coupler order."""
    if len(table) <= limit:
        return table
    worst = table[["max_tension_N", "max_compression_N"]].max(axis=1)
    return table.loc[worst.nlargest(limit).index].sort_index()


def run_summary(ds: xr.Dataset) -> dict[str, float]:
    """Scalar facts of a run: RMS and max speed error (m/s), max |acceleration| (m/s^2),
    peak traction (N), whether traction ever exceeded adhesion, the largest gear
    deflection beyond the slack (m) and how many couplers exceed their travel (or the
    reference travel, :func:`gear_travel_check`)."""
    err = ds.speed_error.values
    finite = np.isfinite(err)
    gears = {}
    if "scenario_json" in ds.attrs and ds.sizes.get("coupler", 0):
        table = gear_travel_check(ds)
        gears = {"max_gear_deflection_m": float(table.max_deflection_m.max()),
                 "couplers_beyond_travel": int(table.exceeds.sum())}
    return {
        "rms_speed_error_m_s": float(np.sqrt(np.mean(err[finite] ** 2))) if finite.any() else float("nan"),
        "max_speed_error_m_s": float(np.max(np.abs(err[finite]))) if finite.any() else float("nan"),
        "max_abs_acceleration_m_s2": float(np.abs(ds.acceleration.values).max()),
        "max_traction_N": float(ds.traction_force.max()),
        "max_brake_N": float(max(-ds.traction_force.min().item(), 0.0)),
        "max_air_brake_N": float(ds.brake_force.sum("vehicle").max()) if "brake_force" in ds
        else 0.0,
        "samples_over_adhesion": int((np.abs(ds.traction_force) > ds.adhesion_limit).sum()),
        "simulated_s": float(ds.time.values[-1]),
        "wall_time_s": float(ds.attrs.get("wall_time_s", float("nan"))),
        "compile_time_s": float(ds.attrs.get("compile_time_s", 0.0)),
        **gears,
    }


#: the lead vehicle counts as stopped below this speed, m/s (0.036 km/h): the air and
#: dynamic brakes and the Davis constant term fade out below about 0.01 m/s
STOP_SPEED = 0.01


def stopping(ds: xr.Dataset, stop_speed: float = STOP_SPEED) -> dict[str, float] | None:
    """Stopping distance and time of a run that brakes to a stop, else None.

    A run brakes to a stop when the lead vehicle's speed ends at or below ``stop_speed``
    (m/s) after the driver braked while it was moving. The brake application is the
    first recorded sample at which the driver brakes, an air-brake command above 0
    (``brake_command``) or a negative (dynamic-brake) traction demand, after the last
    sample at which traction was demanded (``traction_demand > 0``) before the stop;
    the stop is the moment the lead vehicle's speed last falls to ``stop_speed``
    (interpolated between samples). Times are resolved to the recording interval.

    Returns
    -------
    dict
        ``brake_time_s`` (the brake application), ``stop_time_s``, ``speed_m_s`` (the
        lead's speed at the brake application), ``stopping_time_s`` and
        ``stopping_distance_m`` (the lead vehicle's travel from the brake application to
        the stop).
    """
    t = ds.time.values
    v = ds.velocity.values[:, 0]
    x = ds.position.values[:, 0]
    if t.size < 2 or abs(v[-1]) > stop_speed:
        return None
    moving = np.flatnonzero(np.abs(v) > stop_speed)
    if moving.size == 0 or moving[-1] == t.size - 1:
        return None
    k = int(moving[-1])  # last sample above the stop speed; the stop lies in (k, k + 1]
    v0, v1 = abs(v[k]), abs(v[k + 1])
    w = (v0 - stop_speed) / (v0 - v1) if v0 > v1 else 1.0
    t_stop = t[k] + w * (t[k + 1] - t[k])
    x_stop = x[k] + w * (x[k + 1] - x[k])
    demand = ds.traction_demand.values[: k + 1]
    braking = demand < 0.0
    if "brake_command" in ds:
        braking |= ds.brake_command.values[: k + 1] > 0.0
    pulling = np.flatnonzero(demand > 0.0)
    start = int(pulling[-1]) + 1 if pulling.size else 0
    applied = np.flatnonzero(braking[start:])
    if applied.size == 0:
        return None  # rolled to a stop on its resistance alone
    b = start + int(applied[0])
    if abs(v[b]) <= stop_speed:
        return None
    return {"brake_time_s": float(t[b]), "stop_time_s": float(t_stop),
            "speed_m_s": float(abs(v[b])), "stopping_time_s": float(t_stop - t[b]),
            "stopping_distance_m": float(abs(x_stop - x[b]))}


def speeds(ds: xr.Dataset) -> dict[str, float]:
    """The lead vehicle's largest and final speed, m/s."""
    v = ds.velocity.values[:, 0]
    return {"max_speed_m_s": float(np.abs(v).max()), "final_speed_m_s": float(v[-1])}


def gear_travel_check(ds: xr.Dataset, scenario=None,
                      reference_travel: float = REFERENCE_TRAVEL) -> pd.DataFrame:
    """How far each gear deflected beyond its slack, against its travel.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`ltdsim.simulate` (its recorded ``coupler_deflection``; peaks
        between recorded samples are not seen).
    scenario : Scenario, optional
        The scenario that made ``ds``; by default the one stored in the result.
    reference_travel : float
        Travel, m, for gears without a stated ``travel`` (the linear and simplified
        couplers unless one is given): default 0.083 m, an AAR M-901 gear of 3-1/4 in.

    Returns
    -------
    pandas.DataFrame
        Indexed by coupler (0 = between vehicles 0 and 1, as ``ds.coupler``):
        ``slack_m`` (total free play), ``travel_m`` (the travel checked against),
        ``travel_stated`` (True if the coupler has its own ``travel``, False if the
        reference is used), ``max_draft_m`` and ``max_buff_m`` (largest gear deflection
        beyond the slack in draft and in buff, >= 0), ``max_deflection_m`` (the larger),
        ``excess_m`` (beyond the travel, >= 0) and ``exceeds`` (bool).
    """
    if scenario is None:
        from ltdsim.scenario import Scenario

        scenario = Scenario.from_saved(json.loads(ds.attrs["scenario_json"]), "result")
    d = ds.coupler_deflection.values
    nc = d.shape[1]
    params = [scenario.coupler(j) for j in range(nc)]
    half = 0.5 * np.array([c.slack for c in params])
    stated = np.array([c.travel is not None for c in params], dtype=bool)
    travel = np.array([c.travel if c.travel is not None else reference_travel for c in params])
    if d.shape[0]:
        draft = np.clip(d.max(axis=0) - half, 0.0, None)
        buff = np.clip(-d.min(axis=0) - half, 0.0, None)
    else:
        draft = buff = np.zeros(nc)
    largest = np.maximum(draft, buff)
    excess = np.clip(largest - travel, 0.0, None)
    return pd.DataFrame({
        "coupler": ds.coupler.values, "slack_m": 2.0 * half, "travel_m": travel,
        "travel_stated": stated, "max_draft_m": draft, "max_buff_m": buff,
        "max_deflection_m": largest, "excess_m": excess, "exceeds": excess > 0.0,
    }).set_index("coupler")


def travel_warning(ds: xr.Dataset, scenario=None,
                   reference_travel: float = REFERENCE_TRAVEL) -> str | None:
    """One line naming the couplers (counted from 1, coupler 1 behind the lead vehicle)
    whose gears deflected beyond their travel (see :func:`gear_travel_check`) and by how
    much, mm; None when none did."""
    table = gear_travel_check(ds, scenario, reference_travel)
    over = table[table.exceeds]
    if over.empty:
        return None
    parts = [f"{j + 1} by {row.excess_m * 1e3:.0f} mm" for j, row in over.iterrows()]
    stated = over.travel_stated.all()
    reference = f"{reference_travel * 1e3:.0f} mm, a real gear's travel (AAR 3-1/4 in)"
    if stated:
        limit = "their stated travel"
    elif not over.travel_stated.any():
        limit = reference
    else:
        limit = f"their travel (stated, or {reference})"
    worst = over.max_deflection_m.max()
    return (f"gears deflect beyond {limit}: coupler{'s' if len(over) > 1 else ''} "
            f"{', '.join(parts)} (largest deflection beyond the slack {worst * 1e3:.0f} mm)")
