"""Figures of the analyses: the train's mode shapes (the study's Fig. 8), the phases'
relative motion, forces and traction curve (Fig. 5-7), coupler-force spectra and a
spectrogram (Fig. 9), and the mechanism of a ringing run. Each draws what
:mod:`ltdsim.analysis` computes, with units on every axis, and writes one image file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.analysis.phases import phases_of
from ltdsim.analysis.spectra import amplitude_spectrum, spectrogram
from ltdsim.physics.drive.traction import adhesion_limit
from ltdsim.results.io import scenario_of
from ltdsim.scenario import Scenario


def save_mode_shapes(table: pd.DataFrame, path, title: str = "", table_numbers: bool = False,
                     names: tuple[str, str] = ("", ""), other: pd.DataFrame | None = None):
    """Mode-shape figure (the study's Fig. 8): one panel per mode (the rigid-body mode of
    a free train left out), its amplitude along the train, normalised to the largest,
    with its frequency; ``title`` should say which stiffness was used. The panels are
    numbered from 1 as drawn (the study's count), or with ``table_numbers`` as the rows
    of ``table`` are (1 = the lowest, the rigid-body mode, not drawn), for a figure
    beside that table. With ``other`` (the same train's modes on another branch of the
    coupler law, ``names`` naming the two), each panel draws both shapes, dashed for the
    other, and gives both frequencies: where every coupling has the same stiffness the
    shapes coincide and only the frequencies differ."""
    from ltdsim.viz.plotting import WIDTH, _save, plt

    modes = table[table.frequency_hz > 1e-6]
    shapes = modes.drop(columns="frequency_hz").values
    n = shapes.shape[1]
    cols = 3 if len(modes) > 4 else max(len(modes), 1)
    rows = -(-len(modes) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(WIDTH, 2.2 * rows + 1.0), squeeze=False,
                             sharex=True, sharey=True, constrained_layout=True)
    x = np.arange(1, n + 1)
    numbers = (table.index.get_indexer(modes.index) + 1 if table_numbers else
               np.arange(1, len(modes) + 1))
    for k, (row, f, number) in enumerate(zip(shapes, modes.frequency_hz, numbers)):
        ax = axes.flat[k]
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.plot(x, row / np.abs(row).max(), "o-", ms=4, lw=1.2, color="tab:blue",
                label=names[0] or None)
        text = f"mode {number}: {f:.2f} Hz"
        if other is not None:
            om = other[other.frequency_hz > 1e-6]
            if k < len(om):
                o = om.drop(columns="frequency_hz").values[k]
                o = o / np.abs(o).max() * (1.0 if np.dot(o, row) >= 0 else -1.0)
                ax.plot(x, o, "--", lw=1.4,
                        color="tab:orange", label=names[1] or None)
                text = (f"mode {number}: {f:.2f} Hz {names[0]}, "
                        f"{om.frequency_hz.iloc[k]:.2f} Hz {names[1]}")
        ax.set_title(text, loc="left", fontsize="medium")
        ax.set_ylim(-1.15, 1.15)
        ax.xaxis.set_major_locator(plt.MaxNLocator(integer=True))
    for ax in axes.flat[len(modes):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("vehicle (1 = lead)")
    for ax in axes[:, 0]:
        ax.set_ylabel("displacement [-]")
    if other is not None:
        axes.flat[0].legend(loc="lower left", fontsize="small")
    left = [str(i + 1) for i in range(len(table)) if table.index[i] not in modes.index]
    fig.suptitle((title or "mode shapes") + (f" (mode {', '.join(left)} at 0 Hz, the "
                                             "rigid-body motion, not drawn)"
                                             if table_numbers and left else ""))
    return _save(fig, path)


# ------------------------------------------------------------------------ figures
def phase_figures(ds: xr.Dataset, folder: str | Path, scenario: Scenario | None = None,
                  prefix: str = "", highlight: list[int] | None = None) -> list[Path]:
    """Write the study's Fig. 5 (positions and velocities relative to the lead vehicle),
    Fig. 6 (traction and coupler forces: the ``highlight`` couplers, 0-based, in colour,
    default :func:`ltdsim.viz.plotting.highlight_couplers`) and Fig. 7 (traction against
    speed under the traction curve) per phase into ``folder``; returns the files."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import BoundaryNorm

    from ltdsim.viz.plotting import WIDTH, _save, coupler_lines, highlight_couplers, plt

    scenario = scenario_of(ds, scenario)
    phases = phases_of(ds, scenario)
    folder = Path(folder)
    files = []
    n = len(phases)
    if n == 0:
        return files
    nv = ds.sizes["vehicle"]
    rows = n if n > 1 else 1

    # Fig. 5: one row per phase, vehicles 2..n coloured by their number
    cmap = plt.get_cmap("viridis", max(nv - 1, 1))
    norm = BoundaryNorm(np.arange(1.5, nv + 1.0), cmap.N)
    fig, axes = plt.subplots(rows, 2, figsize=(WIDTH, 2.6 * rows + 1.2), squeeze=False,
                             constrained_layout=True)
    for k, (name, a, b) in enumerate(phases):
        w = ds.sel(time=slice(a, b))
        label = name.replace("_", " ")
        for i in range(1, nv):
            c = cmap(norm(i + 1))
            axes[k, 0].plot(w.time, w.relative_position.isel(vehicle=i) * 1e3, lw=0.8, color=c)
        # the velocities as a map (vehicle against time): nine lines of the same
        # oscillation are a tangle, a map shows which vehicles move together and when
        if nv > 1:
            rv = w.relative_velocity.values[:, 1:].T
            lim = max(float(np.abs(rv).max()), 1e-9)
            mesh = axes[k, 1].pcolormesh(w.time.values, np.arange(2, nv + 1), rv,
                                         cmap="RdBu_r", vmin=-lim, vmax=lim,
                                         shading="nearest", rasterized=True)
            fig.colorbar(mesh, ax=axes[k, 1], label="[m/s]", pad=0.01, aspect=15)
            axes[k, 1].set_yticks(np.arange(2, nv + 1, max(1, (nv - 1) // 9)))
        axes[k, 0].set_title(f"{label}: position relative to vehicle 1", loc="left")
        axes[k, 1].set_title(f"{label}: velocity relative to vehicle 1", loc="left")
        axes[k, 0].set_ylabel("[mm]")
        axes[k, 1].set_ylabel("vehicle [-]")
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    if nv > 1:
        bar = fig.colorbar(ScalarMappable(norm, cmap), ax=axes[:, 0], label="vehicle "
                           "(1 = lead), left column", aspect=40, pad=0.01, location="left")
        bar.set_ticks(np.arange(2, nv + 1, max(1, (nv - 1) // 10)))
    fig.suptitle("Vehicles relative to the lead vehicle per phase (study Fig. 5); "
                 "- behind, + ahead of their starting offset")
    files.append(_save(fig, folder / f"{prefix}fig5_relative_motion.png"))

    # Fig. 6: one row per phase: the locomotives' force, and the couplers
    picks = highlight_couplers(ds) if highlight is None else list(highlight)
    nc = ds.sizes["coupler"]
    fig, axes = plt.subplots(rows, 2, figsize=(WIDTH, 2.6 * rows + 1.2), squeeze=False,
                             constrained_layout=True, width_ratios=(1.0, 1.6))
    for k, (name, a, b) in enumerate(phases):
        w = ds.sel(time=slice(a, b))
        axes[k, 0].plot(w.time, w.traction_force / 1e3, lw=0.9, color="k")
        axes[k, 0].set_title(f"{name.replace('_', ' ')}: locomotive force", loc="left")
        axes[k, 0].set_ylabel("[kN]")
        if nc:
            coupler_lines(axes[k, 1], w.time.values, w.coupler_force.values, picks,
                          others=nc <= 30)
        axes[k, 1].set_title(f"{name.replace('_', ' ')}: coupler forces (+ tension)",
                             loc="left")
        axes[k, 1].set_ylabel("[kN]")
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    if nc:  # below the panels, clear of the data
        handles, labels = axes[0, 1].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=len(picks) + 1)
    fig.suptitle("Traction and coupler forces per phase (study Fig. 6)")
    files.append(_save(fig, folder / f"{prefix}fig6_forces.png"))

    # Fig. 7: traction against speed under the curve's three limits
    t = scenario.traction
    g = scenario.track.gravity
    vmax = max(float(np.abs(ds.velocity).max()) * 1.1, 1.0)
    v = np.linspace(0.0, vmax, 300)
    adh = adhesion_limit(v, t.adhesion_mass, g)
    own_mass = sum(vh.static_mass or vh.mass for vh in scenario.vehicles if vh.powered)
    own = adhesion_limit(v, own_mass, g) if abs(own_mass / t.adhesion_mass - 1) > 0.02 else None
    power = np.divide(t.max_power, v, out=np.full_like(v, np.inf), where=v > 0)
    top = 1.08 * max(float(adh.max()), t.max_force, float(np.abs(ds.traction_force).max())) / 1e3
    cols = 2 if n > 1 else 1
    grid_rows = -(-n // cols)
    fig, axes = plt.subplots(grid_rows, cols, figsize=(WIDTH, 3.6 * grid_rows + 0.8),
                             squeeze=False, constrained_layout=True, sharey=True)
    ref = int(np.argmax([vh.powered for vh in scenario.vehicles]))
    for k, (name, a, b) in enumerate(phases):
        ax = axes.flat[k]
        ax.plot(v, adh / 1e3, "k:", lw=1.2, label=f"adhesion limit "
                f"({t.adhesion_mass / 1e3:.0f} t, the scenario's)")
        if own is not None:
            ax.plot(v, own / 1e3, color="tab:red", lw=1.4,
                    label=f"adhesion of the locomotives' own weight ({own_mass / 1e3:.1f} t)")
        ax.plot(v, np.full_like(v, t.max_force) / 1e3, "k--", lw=1, label="force limit")
        ax.plot(v, np.minimum(power, 2 * top * 1e3) / 1e3, "k-.", lw=1, label="power limit")
        w = ds.sel(time=slice(a, b))
        speed = w.velocity.isel(vehicle=ref).values
        ax.plot(speed, np.abs(w.traction_force) / 1e3, ".", ms=2,
                color="tab:blue", label="|locomotive force| (1 dot per sample)")
        ax.set_ylim(0, top)
        # each phase's own speed range (a phase at constant speed is otherwise one dot)
        lo, hi = float(speed.min()), float(speed.max())
        pad = max(0.15 * (hi - lo), 0.02)
        ax.set_xlim(max(lo - pad, 0.0), min(hi + pad, vmax) if hi + pad > lo else vmax)
        ax.set_title(name.replace("_", " "), loc="left")
        ax.set_xlabel("speed of the locomotive [m/s]")
        ax.set_ylabel("force [kN]")
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize="small")
    fig.suptitle("Locomotive force against speed under the traction curve, per phase "
                 "(study Fig. 7); each panel's speed axis spans its phase")
    files.append(_save(fig, folder / f"{prefix}fig7_traction_curve.png"))
    return files


def spectra_figures(ds, folder, scenario=None, couplers=(0, 7, 8), f_max: float = 10.0,
                    lead: str = "held", span_db: float = 50.0):
    """Two figures of the coupler forces ``couplers`` (indices from 0, labelled from 1):

    * ``spectra_per_phase.png``: amplitude spectra per phase up to ``f_max`` Hz, with the
      train's modal bands on the buff (k1) and draft (k2 + k3) branches shaded;
    * ``spectrogram.png``: a time-frequency map of each over the whole run, linearly
      detrended per 10 s window (the steady force is not an oscillation), in dB
      relative to 1 kN over the top ``span_db`` dB, up to the frequency below which 99.5 %
      of the content lies.

    Returns the files."""
    import json
    from pathlib import Path

    from ltdsim.analysis.modal import train_modes
    from ltdsim.analysis.phases import phases_of
    from ltdsim.viz.plotting import HIGHLIGHT_COLOURS, WIDTH, _save, plt
    from ltdsim.scenario import Scenario

    if scenario is None:
        scenario = Scenario.from_saved(json.loads(ds.attrs["scenario_json"]), "result")
    folder = Path(folder)
    dt = float(ds.time[1] - ds.time[0])
    phases = phases_of(ds, scenario)
    bands = {}
    for which, colour in (("buff", "tab:cyan"), ("draft", "tab:olive")):
        try:
            f = train_modes(scenario, which, lead).frequency_hz.values
            bands[which] = (f[f > 0].min(), f.max(), colour)
        except ValueError:  # couplers without k1/k2/k3
            pass
    files = []
    cols = 2 if len(phases) > 1 else 1
    rows = -(-len(phases) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(WIDTH, 3.4 * rows + 0.8), squeeze=False,
                             constrained_layout=True)
    for k, (name, a, b) in enumerate(phases):
        ax = axes.flat[k]
        w = ds.coupler_force.sel(time=slice(a, b - 0.5 * dt))
        for which, (lo, hi, colour) in bands.items():
            ax.axvspan(lo, hi, color=colour, alpha=0.15, lw=0,
                       label=f"{which}-branch modes {lo:.2f}-{hi:.2f} Hz")
        floor = np.inf
        for j, c in enumerate(couplers):
            f, amp = amplitude_spectrum(w.isel(coupler=c).values, dt, detrend="linear")
            band = (f <= f_max) & (f > 0)
            ax.semilogy(f[band], np.maximum(amp[band] / 1e3, 1e-6), lw=1.0,
                        color=HIGHLIGHT_COLOURS[j % 5], label=f"coupler {c + 1}")
            floor = min(floor, float(np.max(amp[band])) / 1e3 * 1e-4)
        res = 1.0 / (b - a)
        # below twice the resolution a line is the window's trend, not a mode
        ax.axvspan(0.0, 2.0 * res, color="0.85", lw=0, label="trend, not a mode")
        ax.set_title(f"{name.replace('_', ' ')} ({b - a:.0f} s: lines {res:.2g} Hz apart)",
                     loc="left")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("amplitude [kN] (log)")
        ax.set_xlim(0, f_max)
        if np.isfinite(floor):
            ax.set_ylim(bottom=floor)
    for ax in axes.flat[len(phases):]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 6),
               fontsize="small")
    fig.suptitle("Coupler force spectra per phase (linear trend removed), with the train's modal "
                 "bands (lead held)")
    files.append(_save(fig, folder / "spectra_per_phase.png"))

    maps = []
    for c in couplers:
        f, t, z = spectrogram(ds.coupler_force.isel(coupler=c).values, dt, detrend="linear")
        maps.append((c, f, t, z))
    # from twice the resolution: the lowest lines hold each window's residual trend; a run
    # too short for a line there keeps its lowest nonzero line
    if maps:
        f0 = maps[0][1]
        low = 2.0 * f0[1] if np.any((f0 >= 2.0 * f0[1]) & (f0 <= f_max)) else f0[1]
        maps = [m for m in maps if np.any((m[1] >= low) & (m[1] <= f_max))]
    if maps:
        power = sum(np.sum(z[f <= f_max] ** 2, axis=1) for _, f, _, z in maps)
        f = maps[0][1][maps[0][1] <= f_max]
        share = np.cumsum(power) / power.sum() if power.sum() > 0 else np.ones_like(f)
        f_top = min(f_max, max(1.0, float(np.ceil(1.2 * f[np.searchsorted(share, 0.995)]))))
        top = max(float(np.max(z)) for *_, z in maps) / 1e3
        ref = 20 * np.log10(max(top, 1e-9))
        fig, axes = plt.subplots(len(maps), 1, figsize=(WIDTH, 2.4 * len(maps) + 1.0),
                                 squeeze=False, sharex=True, constrained_layout=True)
        for k, (c, f, t, z) in enumerate(maps):
            band = (f <= f_top) & (f >= low)
            db = 20 * np.log10(np.maximum(z[band] / 1e3, 1e-12))
            mesh = axes[k, 0].pcolormesh(t + float(ds.time[0]), f[band], db, shading="auto",
                                         cmap="magma", vmin=ref - span_db, vmax=ref,
                                         rasterized=True)
            axes[k, 0].set_ylabel(f"coupler {c + 1}\nfrequency [Hz]")
            axes[k, 0].grid(False)
            for name, a, b in phases:  # the study's phase windows
                axes[k, 0].axvspan(a, b, fill=False, ec="w", lw=1.0, ls="--")
                if k == 0:
                    span_t = float(ds.time[-1] - ds.time[0])
                    axes[k, 0].text(max(a, float(ds.time[0])) + 0.006 * span_t, f[band][-1],
                                    name.replace("_", " "),
                                    color="w", ha="left", va="top", fontsize="small",
                                    bbox={"fc": "k", "alpha": 0.6, "lw": 0, "pad": 1.5})
        axes[0, 0].set_xlim(float(ds.time[0]), float(ds.time[-1]))
        fig.colorbar(mesh, ax=axes[:, 0], label="amplitude [dB re 1 kN]", aspect=30, pad=0.01)
        axes[-1, 0].set_xlabel("time [s] (window centres)")
        fig.suptitle(f"Time-frequency map of coupler forces: 10 s Hann windows, trend removed, "
                     f"from {low:.2g} Hz\n(0-{f_top:g} Hz holds 99.5 % of the "
                     f"content below {f_max:g} Hz; dashed boxes: the study's phases)")
        files.append(_save(fig, folder / "spectrogram.png"))
    return files


def hunt_figure(results, path, t_range: tuple[float, float] = (0.0, 120.0),
                reference_travel: float = 0.083):
    """The mechanism of a ringing run in three panels, one line per run: the acceleration
    the speed reference demands (m/s^2, its slope), the locomotive force (kN) and the
    first coupler's gear deflection beyond its slack (mm, with the reference travel).

    Parameters
    ----------
    results : mapping of label -> xarray.Dataset
        Results of :func:`ltdsim.simulate` in speed mode (e.g. the study's train with
        two reference profiles).
    path : str or Path
        Image file to write (PNG, SVG or PDF).
    t_range : (float, float)
        Time window shown, s.
    reference_travel : float
        Travel drawn as a dashed line, m (default 0.083 m, AAR 3-1/4 in).

    Returns the path written.
    """
    from ltdsim.viz.plotting import _save, plt

    fig, axes = plt.subplots(3, 1, figsize=(11, 8.5), sharex=True, constrained_layout=True)
    a, b = t_range
    for k, (label, ds) in enumerate(results.items()):
        sc = scenario_of(ds, None)
        sel = ds.sel(time=slice(a, b))
        t = sel.time.values
        colour = f"C{k}"
        vref = sel.speed_reference.values
        axes[0].plot(t[1:], np.diff(vref) / np.diff(t), color=colour, lw=1.2, label=label)
        axes[1].plot(t, sel.traction_force.values / 1e3, color=colour, lw=0.9, label=label)
        h = 0.5 * sc.coupler(0).slack
        d = sel.coupler_deflection.values[:, 0]
        beyond = np.where(d > h, d - h, np.where(d < -h, d + h, 0.0))
        axes[2].plot(t, beyond * 1e3, color=colour, lw=0.9, label=label)
    for sign in (1, -1):
        axes[2].axhline(sign * reference_travel * 1e3, color="k", ls="--", lw=0.8)
    axes[2].text(b, reference_travel * 1e3, f"±{reference_travel * 1e3:.0f} mm: a real gear's "
                 "travel (AAR 3-1/4 in) ", va="bottom", ha="right", fontsize=9)
    axes[0].set_ylabel("reference acceleration\n[m/s²]")
    axes[1].set_ylabel("locomotive force [kN]")
    axes[2].set_ylabel("coupler 1 gear deflection\nbeyond slack [mm]\n(+ draft, − buff)")
    axes[2].set_xlabel("time [s]")
    axes[0].set_title("What the reference demands, what the locomotive does, what the first "
                      "gear takes", fontsize=11)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=9)
    axes[0].legend(fontsize=9, loc="upper right")
    axes[2].set_xlim(a, b)
    return _save(fig, path)
