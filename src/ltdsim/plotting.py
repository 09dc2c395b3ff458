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
    """Speed tracking, air brakes (if any), traction against the adhesion limit, and
    coupler forces over time (one line per coupler, or for long trains a time x coupler
    map).

    Returns the matplotlib ``Figure``.
    """
    t = ds.time.values
    tracking = bool(np.isfinite(ds.speed_error.values).any())
    braked = "brake_force" in ds
    panels = ["speed"] + (["error"] if tracking else []) + (["brake"] if braked else []) + [
        "traction", "couplers"]
    heights = [2.0 if p == "couplers" else 1.0 for p in panels]
    fig, axes = plt.subplots(len(panels), 1, figsize=(11, 2.6 * len(panels) + 1.5), sharex=True,
                             constrained_layout=True, height_ratios=heights)
    ax_of = dict(zip(panels, axes))
    ax = ax_of["speed"]
    if np.isfinite(ds.speed_reference.values).any():
        ax.plot(t, ds.speed_reference, "k--", lw=1.2, label="reference")
    ax.plot(t, ds.velocity.isel(vehicle=0), lw=1.0, label=f"{ds.vehicle_name.values[0]} (lead)")
    ax.set_ylabel("speed [m/s]")
    ax.legend(loc="lower right")
    if tracking:
        ax = ax_of["error"]
        ax.plot(t, ds.speed_error, lw=0.8, color="tab:red")
        ax.set_ylabel("speed error [m/s]")
    if braked:
        ax = ax_of["brake"]
        ax.plot(t, ds.brake_force.sum("vehicle") / 1e3, lw=1.0, color="tab:brown",
                label="air brake, whole train")
        ax.set_ylabel("air brake [kN]")
        ax2 = ax.twinx()
        ax2.step(t, ds.brake_command, where="post", lw=0.8, color="k", alpha=0.6,
                 label="command (right)")
        ax2.set_ylabel("brake command [-]")
        ax2.set_ylim(-0.05, 1.05)
        ax.legend(loc="upper left")
        ax2.legend(loc="upper right")
    ax = ax_of["traction"]
    if "locomotive_force" in ds:
        for name in ds.locomotive.values:
            ax.plot(t, ds.locomotive_force.sel(locomotive=name) / 1e3, lw=0.8, label=str(name))
    else:
        ax.plot(t, ds.traction_force / 1e3, lw=0.8, label="traction / dynamic brake")
    ax.plot(t, ds.adhesion_limit / 1e3, "k:", lw=1.0, label="adhesion limit (all)")
    ax.plot(t, -ds.adhesion_limit / 1e3, "k:", lw=1.0)
    ax.set_ylabel("force [kN]")
    ax.legend(loc="lower right")
    ax = ax_of["couplers"]
    nc = ds.sizes["coupler"]
    if nc <= 30:
        cmap = plt.get_cmap("viridis")
        for j in range(nc):
            ax.plot(t, ds.coupler_force.isel(coupler=j) / 1e3, lw=0.5,
                    color=cmap(j / max(nc - 1, 1)), label=f"coupler {j + 1}")
        ax.set_ylabel("coupler force [kN]\n(+ tension)")
        if nc <= 12:
            ax.legend(loc="upper right", ncol=min(nc, 6), fontsize=7)
    else:  # a map reads better than hundreds of lines
        f = ds.coupler_force.values.T / 1e3
        lim = np.abs(f).max() or 1.0
        mesh = ax.pcolormesh(t, ds.coupler.values + 1, f, cmap="RdBu_r", vmin=-lim, vmax=lim,
                             shading="auto", rasterized=True)
        fig.colorbar(mesh, ax=ax, label="coupler force [kN] (+ tension)")
        ax.set_ylabel("coupler (1 = behind the lead)")
        ax.yaxis.set_major_locator(plt.MaxNLocator(integer=True))
        ax.invert_yaxis()
    ax.set_xlabel("time [s]")
    for a in axes:
        a.grid(alpha=0.3)
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
