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
