"""Figures of a simulation result (matplotlib, no screen needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ltdsim.io import atomic_path  # noqa: E402


def overview_figure(ds: xr.Dataset):
    """Speed tracking, traction against the adhesion limit, and coupler forces over time.

    Returns the matplotlib ``Figure``.
    """
    t = ds.time.values
    fig, axes = plt.subplots(4, 1, figsize=(11, 12), sharex=True, constrained_layout=True)
    ax = axes[0]
    if np.isfinite(ds.speed_reference.values).any():
        ax.plot(t, ds.speed_reference, "k--", lw=1.2, label="reference")
    ax.plot(t, ds.velocity.isel(vehicle=0), lw=1.0, label=f"{ds.vehicle_name.values[0]} (lead)")
    ax.set_ylabel("speed [m/s]")
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    ax = axes[1]
    ax.plot(t, ds.speed_error, lw=0.8, color="tab:red")
    ax.set_ylabel("speed error [m/s]")
    ax.grid(alpha=0.3)
    ax = axes[2]
    ax.plot(t, ds.traction_force / 1e3, lw=0.8, label="traction / dynamic brake")
    ax.plot(t, ds.adhesion_limit / 1e3, "k:", lw=1.0, label="adhesion limit")
    ax.plot(t, -ds.adhesion_limit / 1e3, "k:", lw=1.0)
    ax.set_ylabel("force [kN]")
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    ax = axes[3]
    nc = ds.sizes["coupler"]
    cmap = plt.get_cmap("viridis")
    for j in range(nc):
        ax.plot(t, ds.coupler_force.isel(coupler=j) / 1e3, lw=0.5,
                color=cmap(j / max(nc - 1, 1)), label=f"coupler {j}")
    ax.set_ylabel("coupler force [kN]\n(+ tension)")
    ax.set_xlabel("time [s]")
    ax.grid(alpha=0.3)
    if nc <= 12:
        ax.legend(loc="upper right", ncol=min(nc, 6), fontsize=7)
    title = ds.attrs.get("title", "ltdsim result")
    fig.suptitle(title)
    return fig


def save_overview(ds: xr.Dataset, path: str | Path) -> Path:
    """Write :func:`overview_figure` to ``path`` (PNG, SVG or PDF by suffix), atomically."""
    path = Path(path)
    return _save(overview_figure(ds), path)


def save_gear_loop(ds: xr.Dataset, path: str | Path, title: str = "") -> Path:
    """Force-deflection loop of a gear run (:func:`ltdsim.gear.drive_deflection`)."""
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    ax.plot(ds.deflection * 1e3, ds.force / 1e3, lw=1.0)
    ax.set_xlabel("deflection [mm] (+ draft)")
    ax.set_ylabel("force [kN] (+ tension)")
    ax.grid(alpha=0.3)
    ax.set_title(title or "gear force-deflection loop")
    return _save(fig, path)


def save_reduction(result, path: str | Path, title: str = "") -> Path:
    """The study's Fig. 3: detailed and fitted simplified gear forces over time and
    against deflection."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5), constrained_layout=True)
    a1.plot(result.time, result.target_force / 1e3, lw=0.8, label="detailed gear")
    a1.plot(result.time, result.fitted_force / 1e3, lw=0.8, ls="--", label="simplified, fitted")
    a1.set_xlabel("time [s]")
    a1.set_ylabel("gear force [kN]")
    a1.legend()
    a1.grid(alpha=0.3)
    a2.plot(result.target_deflection * 1e3, result.target_force / 1e3, lw=0.6, label="detailed")
    a2.plot(result.target_deflection * 1e3, result.fitted_force / 1e3, lw=0.6, ls="--",
            label="simplified (same deflection record)")
    a2.set_xlabel("deflection of the detailed gear [mm]")
    a2.set_ylabel("force [kN]")
    a2.grid(alpha=0.3)
    a2.legend()
    fig.suptitle((title + "; " if title else "") + f"fit {result.fit_percent:.1f} %")
    return _save(fig, path)


def _save(fig, path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
