"""Figures of a simulation result (matplotlib, no screen needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ltdsim.results.io import atomic_path  # noqa: E402

#: every figure is this wide (inches) and saved at :data:`DPI`, so on a page 1400 px wide
#: (the report's column is at most 1200 px) text shows at about its point size
WIDTH = 11.0
DPI = 110
plt.rcParams.update({"font.size": 10.5, "axes.titlesize": 11, "axes.labelsize": 10.5,
                     "xtick.labelsize": 10, "ytick.labelsize": 10, "legend.fontsize": 9.5,
                     "figure.titlesize": 12, "axes.grid": True, "grid.alpha": 0.3})
#: colours of the highlighted couplers, in the study's Fig. 9 order (1, 8, 9)
HIGHLIGHT_COLOURS = ("tab:blue", "tab:red", "tab:orange", "tab:green", "tab:purple")


def highlight_couplers(ds: xr.Dataset, count: int = 3) -> list[int]:
    """Coupler indices (0-based) to draw as lines: for the study's ten-vehicle train and
    other short ones the first and the last two (the study's couplers 1, 8 and 9); for
    trains of more than 12 vehicles the ``count`` couplers with the largest |force|."""
    nc = ds.sizes["coupler"]
    if nc <= 11:
        return sorted({0, max(nc - 2, 0), nc - 1})[:count] if nc else []
    if "max_coupler_force" in ds:
        peak = np.maximum(ds.max_coupler_force.values, -ds.min_coupler_force.values)
    else:
        peak = np.abs(ds.coupler_force).max("time").values
    return sorted(np.argsort(-peak)[:count].tolist())


def coupler_lines(ax, t, force, couplers, others: bool = True, lw: float = 0.9) -> None:
    """Coupler forces (N, time x coupler) in kN: the ``couplers`` (0-based) in distinct
    colours, labelled from 1; with ``others`` every other coupler thin and grey."""
    force = np.asarray(force)
    if others:
        rest = [j for j in range(force.shape[1]) if j not in couplers]
        for k, j in enumerate(rest):
            ax.plot(t, force[:, j] / 1e3, lw=0.4, color="0.7",
                    label="other couplers" if k == 0 else None)
    for k, j in enumerate(couplers):
        ax.plot(t, force[:, j] / 1e3, lw=lw, color=HIGHLIGHT_COLOURS[k % 5],
                label=f"coupler {j + 1}")


def coupler_map(fig, ax, t, force, label="coupler force [kN] (+ tension)") -> None:
    """Every coupler's force (N, time x coupler) as a time x coupler colour map in kN,
    tension red, compression blue, coupler 1 at the top."""
    f = np.asarray(force).T / 1e3
    lim = np.abs(f).max() or 1.0
    nc = f.shape[0]
    mesh = ax.pcolormesh(t, np.arange(1, nc + 1), f, cmap="RdBu_r", vmin=-lim, vmax=lim,
                         shading="nearest", rasterized=True)
    fig.colorbar(mesh, ax=ax, label=label, pad=0.01)
    ax.set_ylabel("coupler\n(1 = behind the lead)")
    ax.yaxis.set_major_locator(plt.MaxNLocator(integer=True, nbins=min(nc, 10)))
    ax.set_ylim(nc + 0.5, 0.5)
    ax.grid(False)


def overview_figure(ds: xr.Dataset, highlight: list[int] | None = None):
    """Speed tracking, air brakes (if any), traction against the adhesion limit, the
    forces of a few couplers (``highlight``, 0-based; default :func:`highlight_couplers`)
    as lines and every coupler's force as a time x coupler map.

    Returns the matplotlib ``Figure``.
    """
    t = ds.time.values
    tracking = bool(np.isfinite(ds.speed_error.values).any())
    braked = "brake_force" in ds
    nc = ds.sizes["coupler"]
    panels = (["speed"] + (["error"] if tracking else []) + (["brake"] if braked else [])
              + ["traction"] + (["couplers", "map"] if nc else []))
    heights = [1.6 if p in ("couplers", "map") else 1.0 for p in panels]
    fig, axes = plt.subplots(len(panels), 1, figsize=(WIDTH, 2.2 * len(panels) + 1.5),
                             sharex=True, constrained_layout=True, height_ratios=heights)
    ax_of = dict(zip(panels, axes))
    ax = ax_of["speed"]
    if np.isfinite(ds.speed_reference.values).any():
        ax.plot(t, ds.speed_reference, "k--", lw=1.2, label="reference")
    ax.plot(t, ds.velocity.isel(vehicle=0), lw=1.0, label=f"{ds.vehicle_name.values[0]} "
                                                          "(vehicle 1, lead)")
    ax.set_ylabel("speed [m/s]")
    ax.legend(loc="lower right")
    if tracking:
        ax = ax_of["error"]
        ax.plot(t, ds.speed_error, lw=0.8, color="tab:red")
        ax.set_ylabel("speed error [m/s]\n(reference - lead)")
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
        ax2.grid(False)
        ax.legend(loc="upper left")
        ax2.legend(loc="upper right")
    ax = ax_of["traction"]
    if "locomotive_force" in ds:
        for name in ds.locomotive.values:
            ax.plot(t, ds.locomotive_force.sel(locomotive=name) / 1e3, lw=0.8, label=str(name))
    else:
        ax.plot(t, ds.traction_force / 1e3, lw=0.8, label="traction (+) / dynamic brake (-)")
    ax.plot(t, ds.adhesion_limit / 1e3, "k:", lw=1.0, label="± adhesion limit")
    ax.plot(t, -ds.adhesion_limit / 1e3, "k:", lw=1.0)
    ax.set_ylabel("locomotive force [kN]")
    ax.legend(loc="lower right", ncol=2)
    if nc:
        picks = highlight_couplers(ds) if highlight is None else list(highlight)
        ax = ax_of["couplers"]
        coupler_lines(ax, t, ds.coupler_force.values, picks, others=nc <= 30)
        ax.set_ylabel("coupler force [kN]\n(+ tension)")
        ax.legend(loc="upper right", ncol=len(picks) + 1)
        coupler_map(fig, ax_of["map"], t, ds.coupler_force.values)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(ds.attrs.get("title", "ltdsim result"))
    return fig


def save_overview(ds: xr.Dataset, path: str | Path) -> Path:
    """Write :func:`overview_figure` to ``path`` (PNG, SVG or PDF by suffix), atomically."""
    path = Path(path)
    return _save(overview_figure(ds), path)


def _vehicle_map(fig, ax, t, values, label, cmap, vmax=None):
    """A time x vehicle map of ``values`` (Pa gauge, time x vehicle) in bar, vehicle 1 at
    the top; NaN (no such state on that vehicle) in light grey."""
    bar = np.asarray(values, float).T / 1e5
    n = bar.shape[0]
    top = vmax if vmax is not None else (np.nanmax(bar) if np.isfinite(bar).any() else 1.0)
    colours = plt.get_cmap(cmap).copy()
    colours.set_bad("0.88")
    dt = (t[-1] - t[0]) / max(t.size - 1, 1)
    image = ax.imshow(bar, aspect="auto", interpolation="nearest", cmap=colours, vmin=0.0,
                      vmax=top or 1.0, extent=(t[0] - dt / 2, t[-1] + dt / 2, n + 0.5, 0.5))
    fig.colorbar(image, ax=ax, label=label, pad=0.01)
    ax.set_ylabel("vehicle\n(1 = lead)")
    ax.set_xlabel("time [s]")
    ax.yaxis.set_major_locator(plt.MaxNLocator(integer=True, nbins=min(n, 10)))
    ax.grid(False)


def application_window(ds: xr.Dataset, summary: dict) -> tuple[float, float]:
    """Time window (s, s) around the application of ``summary``
    (:func:`ltdsim.results.summary.fluid_brake_summary`): from a tenth of its length before the
    command until half as long again after the slowest cylinder reached 95 % (or the
    drop reached the farthest vehicle), within the record and the application."""
    t_cmd = summary["command_time_s"]
    reach = [summary[k] for k in ("slowest_cylinder_95_s", "propagation_time_s")
             if np.isfinite(summary[k])]
    span = 1.5 * max(reach) + 2.0 if reach else summary["end_time_s"] - t_cmd
    t0, t1 = float(ds.time[0]), min(float(ds.time[-1]), summary["end_time_s"])
    return max(t0, t_cmd - 0.1 * span), min(t1, t_cmd + span)


def _profiles(ax, values, times, t, label, cmap):
    """``values`` (Pa gauge, time x vehicle) along the train (bar against vehicle number)
    at the recorded samples nearest ``times`` (s), coloured from early to late."""
    n = values.shape[1]
    colours = plt.get_cmap(cmap)(np.linspace(0.0, 0.9, len(times)))
    for colour, when in zip(colours, times):
        k = int(np.argmin(np.abs(t - when)))
        ax.plot(np.arange(1, n + 1), values[k] / 1e5, color=colour, lw=1.1, marker=".",
                ms=2.5, label=f"{t[k]:.1f} s")
    ax.set_xlabel("vehicle (1 = lead)")
    ax.set_ylabel(f"{label} [bar, gauge]")
    ax.set_xlim(0.5, n + 0.5)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=3, fontsize=8.5,
              title="time", title_fontsize=8.5)


def brake_pressure_figure(ds: xr.Dataset, window: tuple[float, float] | None = None,
                          summary: dict | None = None):
    """Pipe and cylinder pressure along the train over time, for a run with the fluid
    brake: the brake-pipe pressure and the brake-cylinder pressure of every vehicle as
    time x vehicle maps (bar, gauge; vehicle 1 = the lead at the top; light grey where a
    vehicle has no cylinder); both pressures against time at the first, middle and last
    braked vehicles; and, below, the pipe and the cylinder pressure along the train
    (against vehicle number) at six moments of the application.

    With ``summary`` (:func:`ltdsim.results.summary.fluid_brake_summary`) the figure shows its
    application (:func:`application_window`, unless ``window`` (s, s) is given), the
    pipe's arrival line (0.3 bar fallen) on the pipe map, and its propagation speed and
    the rear cylinder's 95 % time in the title; the moments of the profiles are spread
    over the drop's travel to the farthest vehicle (pipe) and up to the slowest cylinder's
    95 % time (cylinders). Without it, the whole record (or ``window``) and moments
    spread over it.

    Returns the matplotlib ``Figure``.
    """
    if window is None and summary is not None:
        window = application_window(ds, summary)
    sel = ds if window is None else ds.sel(time=slice(*window))
    t = sel.time.values
    pipe = sel.brake_pipe_pressure.values
    cyl = sel.brake_cylinder_pressure.values
    n = pipe.shape[1]
    fig = plt.figure(figsize=(WIDTH, 13.5), constrained_layout=True)
    grid = fig.add_gridspec(4, 2, height_ratios=(1.25, 1.25, 1.0, 1.1))
    a_pipe = fig.add_subplot(grid[0, :])
    a_cyl = fig.add_subplot(grid[1, :], sharex=a_pipe)
    a_line = fig.add_subplot(grid[2, :], sharex=a_pipe)
    a_pp, a_cp = fig.add_subplot(grid[3, 0]), fig.add_subplot(grid[3, 1])
    _vehicle_map(fig, a_pipe, t, pipe, "brake pipe [bar, gauge]", "viridis")
    a_pipe.set_title("brake-pipe pressure along the train")
    _vehicle_map(fig, a_cyl, t, cyl, "brake cylinder [bar, gauge]", "inferno")
    a_cyl.set_title("brake-cylinder pressure along the train (grey: no cylinder)")
    if summary is not None:
        arr = summary["command_time_s"] + np.asarray(summary["arrival_s"])
        veh = np.arange(1, n + 1)
        ok = np.isfinite(arr)
        a_pipe.plot(arr[ok], veh[ok], color="w", lw=1.2, ls="--",
                    label=f"arrival: pipe {summary['threshold_Pa'] / 1e5:.1f} bar below "
                          "its pressure before the command")
        a_pipe.legend(loc="lower right", framealpha=0.8)
    braked = np.flatnonzero(np.isfinite(cyl).all(axis=0))
    picks = sorted({int(braked[0]), int(braked[len(braked) // 2]), int(braked[-1])}) \
        if braked.size else [0, n - 1]
    for k, i in enumerate(picks):
        colour = HIGHLIGHT_COLOURS[k % 5]
        a_line.plot(t, pipe[:, i] / 1e5, color=colour, lw=1.0, label=f"pipe, vehicle {i + 1}")
        if np.isfinite(cyl[:, i]).all():
            a_line.plot(t, cyl[:, i] / 1e5, color=colour, lw=1.0, ls="--",
                        label=f"cylinder, vehicle {i + 1}")
    a_line.set_ylabel("pressure [bar, gauge]")
    a_line.set_xlabel("time [s]")
    a_line.legend(loc="best", ncol=3)
    a_line.set_title("pipe (solid) and cylinder (dashed) at the first, middle and last "
                     "braked vehicles")
    t_pipe = t_cyl = np.linspace(t[0], t[-1], 6)
    if summary is not None:
        t_cmd = summary["command_time_s"]
        if np.isfinite(summary["propagation_time_s"]):
            t_pipe = t_cmd + np.linspace(0.0, 1.25 * summary["propagation_time_s"], 6)
        if np.isfinite(summary["slowest_cylinder_95_s"]):
            t_cyl = t_cmd + np.linspace(0.0, summary["slowest_cylinder_95_s"], 6)
    _profiles(a_pp, pipe, t_pipe, t, "brake pipe", "viridis")
    a_pp.set_title("brake pipe along the train")
    _profiles(a_cp, cyl, t_cyl, t, "brake cylinder", "inferno")
    a_cp.set_title("brake cylinders along the train")
    title = ds.attrs.get("title", "ltdsim result") + ": fluid air brake"
    if summary is not None:
        bits = []
        away = summary["farthest_distance_m"] > 0.0  # (one vehicle: no speed to give)
        if away and np.isfinite(summary["end_to_end_speed_m_s"]):
            bits.append(f"propagation {summary['end_to_end_speed_m_s']:.0f} m/s end to end")
        if away and np.isfinite(summary.get("vent_front_speed_m_s", np.nan)):
            bits.append(f"vent front {summary['vent_front_speed_m_s']:.0f} m/s")
        if np.isfinite(summary["last_cylinder_95_s"]):
            bits.append(f"rear cylinder (vehicle {summary['last_vehicle'] + 1}) at 95 % "
                        f"{summary['last_cylinder_95_s']:.1f} s after the command at "
                        f"{summary['command_time_s']:.1f} s")
        if bits:
            title += "\n" + "; ".join(bits)
    fig.suptitle(title)
    return fig


def save_brake_pressures(ds: xr.Dataset, path: str | Path, window=None, summary=None) -> Path:
    """Write :func:`brake_pressure_figure` to ``path`` (PNG, SVG or PDF by suffix),
    atomically."""
    return _save(brake_pressure_figure(ds, window, summary), Path(path))


def save_gear_loop(ds: xr.Dataset, path: str | Path, title: str = "") -> Path:
    """Force-deflection loop of a gear run (:func:`ltdsim.analysis.gears.drive_deflection`)."""
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    ax.plot(ds.deflection * 1e3, ds.force / 1e3, lw=1.0)
    ax.set_xlabel("deflection [mm] (+ draft)")
    ax.set_ylabel("force [kN] (+ tension)")
    ax.grid(alpha=0.3)
    ax.set_title(title or "gear force-deflection loop")
    return _save(fig, path)


def save_reduction(result, path: str | Path, title: str = "", burst: tuple = (14.0, 14.6)
                   ) -> Path:
    """The study's Fig. 3: detailed and fitted simplified gear forces over time (with the
    excitation's fast ``burst`` window, s, magnified below) and against deflection."""
    fig = plt.figure(figsize=(WIDTH, 7.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, height_ratios=(1.0, 0.8))
    a1, a2, a3 = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[:, 1]), fig.add_subplot(
        grid[1, 0])
    for ax in (a1, a3):
        ax.plot(result.time, result.target_force / 1e3, lw=0.9, label="detailed gear")
        ax.plot(result.time, result.fitted_force / 1e3, lw=0.9, ls="--",
                label="simplified, fitted")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("gear force [kN]")
    a1.axvspan(*burst, color="0.85", zorder=0, label=f"{burst[0]:g}-{burst[1]:g} s, below")
    a1.legend(loc="lower left")
    a1.set_title("force against time")
    a3.set_xlim(*burst)
    a3.set_title(f"the last {burst[1] - burst[0]:.1f} s magnified (5 and 10 Hz excitation)")
    a2.plot(result.target_deflection * 1e3, result.target_force / 1e3, lw=0.7, label="detailed")
    a2.plot(result.target_deflection * 1e3, result.fitted_force / 1e3, lw=0.7, ls="--",
            label="simplified (same deflection record)")
    a2.set_xlabel("deflection of the detailed gear [mm] (+ draft)")
    a2.set_ylabel("gear force [kN] (+ tension)")
    a2.set_title("force against deflection")
    a2.legend(loc="upper left")
    fig.suptitle((title + "; " if title else "") + f"fit {result.fit_percent:.1f} %")
    return _save(fig, path)


def _save(fig, path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=DPI, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path


def curving_figure(ds: xr.Dataset, summary: dict | None = None):
    """L/V along the train over the run (a time x vehicle map, coloured up to Nadal's
    limit), the envelope of L/V and of the wheelset force over Prud'homme's limit per
    vehicle, and the coupler angles and lateral components of the most angled couplers."""
    t = ds.time.values
    lv = ds.wheel_l_over_v.values
    nadal = float(ds.nadal_limit)
    n = lv.shape[1]
    fig, axes = plt.subplots(3, 1, figsize=(WIDTH, 10.5),
                             gridspec_kw={"height_ratios": [1.3, 1.0, 1.0]})
    ax = axes[0]
    colours = plt.get_cmap("magma_r").with_extremes(over="tab:red")
    dt = (t[-1] - t[0]) / max(t.size - 1, 1)
    image = ax.imshow(np.where(np.isfinite(lv), lv, nadal * 2).T, aspect="auto",
                      interpolation="nearest", cmap=colours, vmin=0.0, vmax=nadal,
                      extent=(t[0] - dt / 2, t[-1] + dt / 2, n + 0.5, 0.5))
    fig.colorbar(image, ax=ax, pad=0.01, extend="max",
                 label=f"wheel L/V [-] (red: over Nadal's {nadal:.2f})")
    ax.set_ylabel("vehicle\n(1 = lead)")
    ax.set_xlabel("time [s]")
    ax.grid(False)
    ax.set_title("L/V of the flanging wheel of each vehicle's worse leading wheelset")
    ax = axes[1]
    veh = np.arange(1, n + 1)
    ax.plot(veh, np.nanmax(np.where(np.isfinite(lv), lv, np.nan), axis=0), color="tab:blue",
            lw=1.0, label="max L/V over the run [-]")
    ax.axhline(nadal, color="tab:blue", ls="--", lw=0.9, label=f"Nadal's limit {nadal:.2f}")
    ratio = ds.wheelset_lateral_force.values / ds.prudhomme_limit.values[None, :]
    ax.plot(veh, ratio.max(axis=0), color="tab:orange", lw=1.0,
            label="max wheelset force / Prud'homme limit [-]")
    ax.axhline(1.0, color="tab:orange", ls=":", lw=0.9)
    ax.set_xlabel("vehicle (1 = lead)")
    ax.set_ylabel("ratio [-]")
    ax.set_xlim(0.5, n + 0.5)
    ax.legend(loc="upper left")
    ax.set_title("worst over the run, along the train")
    ax = axes[2]
    if ds.sizes.get("coupler", 0):
        ang = ds.coupler_angle.values
        top = np.argsort(ang.max(axis=0))[::-1][:3]
        lat = ds.coupler_lateral_force.values
        for c, j in zip(HIGHLIGHT_COLOURS, sorted(top)):
            ax.plot(t, lat[:, j] / 1e3, color=c, lw=0.9,
                    label=f"coupler {j + 1} (max angle {1e3 * ang[:, j].max():.1f} mrad)")
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.legend(loc="best")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("lateral component [kN]\n(+ inward, - outward)")
    ax.set_title("lateral coupler force of the three most angled couplers")
    if summary and "wheel_lift_vehicle" in summary:  # (an L/V there is undefined)
        fig.suptitle(f"wheel lift at vehicle {summary['wheel_lift_vehicle']}, "
                     f"{summary['wheel_lift_time_s']:.1f} s, chainage "
                     f"{summary['wheel_lift_position_m']:.0f} m (L/V undefined, shown red)")
    elif summary:
        fig.suptitle(f"worst L/V {summary['max_l_over_v']:.2f} at vehicle "
                     f"{summary['l_over_v_vehicle']}, {summary['l_over_v_time_s']:.1f} s, "
                     f"chainage {summary['l_over_v_position_m']:.0f} m")
    fig.tight_layout()
    return fig


def save_curving(ds: xr.Dataset, path: str | Path, summary: dict | None = None) -> Path:
    """Write :func:`curving_figure` to ``path``."""
    return _save(curving_figure(ds, summary), path)
