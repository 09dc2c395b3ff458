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


def save_overview(ds: xr.Dataset, path: str | Path, dpi: int = 110) -> Path:
    """Write :func:`overview_figure` to ``path`` (PNG, SVG or PDF by suffix), atomically."""
    path = Path(path)
    fig = overview_figure(ds)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
