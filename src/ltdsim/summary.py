"""Summary numbers of a result: what an engineer checks first."""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr


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
    peak traction (N), and whether traction ever exceeded adhesion."""
    err = ds.speed_error.values
    finite = np.isfinite(err)
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
