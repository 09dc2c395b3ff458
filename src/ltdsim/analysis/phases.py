"""Per-phase analyses of a result: the study's Table 5 norms, critical couplers, the
traction-curve check (Fig. 7), and the phase figures (Fig. 5, 6, 7).

A phase is a named time window (``[[phases]]`` in the scenario; scenarios/paper.toml
declares the study's acceleration 0-10 s, curving 75-85 s, deceleration 120-130 s and
slope climbing 185-195 s). A scenario without ``[[phases]]`` has one phase, the whole
run (:data:`WHOLE_RUN`). Norms are over the recorded samples of the window: the 2-norm
``sqrt(sum x_k^2)`` depends on the sampling interval (the study samples every 1e-4 s;
ltdsim records every ``output_interval``), so the RMS ``2-norm / sqrt(samples)`` is given
beside it for comparisons across sampling rates.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.physics.drive.traction import adhesion_limit
from ltdsim.scenario.model import Scenario

#: name of the single phase of a scenario that declares no ``[[phases]]``
WHOLE_RUN = "whole run"

#: the two meanings of "critical coupler" (the largest force in a phase), each with the
#: norm it ranks by: "peak" = the largest |force| (infinity norm), "RMS" = the RMS force
CRITERIA = {"peak": "infnorm", "RMS": "rms"}


def _scenario_of(ds: xr.Dataset, scenario: Scenario | None) -> Scenario:
    if scenario is None:
        scenario = Scenario.from_saved(json.loads(ds.attrs["scenario_json"]), "result")
    return scenario


def phases_of(ds: xr.Dataset, scenario: Scenario | None = None) -> list[tuple[str, float, float]]:
    """The phases (name, start s, end s) that overlap the record, clipped to it; for a
    scenario without ``[[phases]]`` the whole record as one phase named ``"whole run"``."""
    scenario = _scenario_of(ds, scenario)
    t0, t1 = float(ds.time[0]), float(ds.time[-1])
    if not scenario.phases:
        return [(WHOLE_RUN, t0, t1)]
    out = []
    for p in scenario.phases:
        a, b = max(p.start, t0), min(p.end, t1)
        if b > a:
            out.append((p.name, a, b))
    return out


def _norms(x: np.ndarray, axis=0):
    two = np.sqrt(np.sum(x * x, axis=axis))
    return two, np.max(np.abs(x), axis=axis), two / np.sqrt(x.shape[axis])


def phase_norms(ds: xr.Dataset, scenario: Scenario | None = None) -> xr.Dataset:
    """2-norm, infinity-norm and RMS per phase (the study's Table 5).

    Returns a dataset over ``phase`` (and ``coupler`` / ``vehicle``) with
    ``coupler_force_{2norm,infnorm,rms}`` (N), ``acceleration_{...}`` (m/s^2, every
    vehicle), ``traction_force_{...}`` (N) and ``speed_error_{...}`` (m/s); a variable
    the run did not record (``solver.record``) is left out.
    """
    phases = phases_of(ds, scenario)
    if not phases:
        raise ValueError("no phase overlaps the record")
    names = [p[0] for p in phases]
    # each phase's samples a <= t <= b, as ds.sel(time=slice(a, b)) picks them on the
    # sorted time axis (found once per phase, not once per variable and phase)
    t = ds.time.values
    spans = [(int(np.searchsorted(t, a, "left")), int(np.searchsorted(t, b, "right")))
             for _, a, b in phases]
    parts = {}
    for var, dim in (("coupler_force", "coupler"), ("acceleration", "vehicle"),
                     ("traction_force", None), ("speed_error", None)):
        if var not in ds:  # not recorded (solver.record)
            continue
        values = ds[var].values
        rows = [_norms(values[i:k]) for i, k in spans]
        for k, kind in enumerate(("2norm", "infnorm", "rms")):
            data = np.array([r[k] for r in rows])
            dims = ("phase",) if dim is None else ("phase", dim)
            parts[f"{var}_{kind}"] = (dims, data, {"units": ds[var].attrs.get("units", "")})
    out = xr.Dataset(parts, coords={"phase": names, "coupler": ds.coupler.values,
                                    "vehicle": ds.vehicle.values})
    out["phase_start"] = ("phase", [p[1] for p in phases], {"units": "s"})
    out["phase_end"] = ("phase", [p[2] for p in phases], {"units": "s"})
    out["samples"] = ("phase", [k - i for i, k in spans])
    return out


def critical_couplers(norms: xr.Dataset, by: str | None = None) -> pd.DataFrame:
    """Couplers ranked per phase by their force (rank 1 = the critical coupler).

    "Critical" has two meanings, both kept (:data:`CRITERIA`): by peak, the largest
    |force| in the phase (infinity norm: the one load that breaks a coupler), and by RMS,
    the largest RMS force (sustained load: fatigue). With ``by=None`` both rankings,
    labelled in column ``criterion`` ("peak" or "RMS"), with the force in ``force_N``.
    With ``by="infnorm"`` or ``"rms"`` one ranking with the force in ``force_<by>_N``.
    ``coupler`` is the coupler index (0 joins vehicles 0 and 1); people's coupler
    number is ``coupler + 1``.
    """
    if by is None:
        parts = []
        for label, norm in CRITERIA.items():
            one = critical_couplers(norms, by=norm).rename(columns={f"force_{norm}_N": "force_N"})
            one.insert(1, "criterion", label)
            parts.append(one)
        return pd.concat(parts, ignore_index=True)
    f = norms[f"coupler_force_{by}"]
    rows = []
    for ph in norms.phase.values:
        vals = f.sel(phase=ph).values
        order = np.argsort(-vals)
        for rank, j in enumerate(order, start=1):
            rows.append({"phase": ph, "rank": rank, "coupler": int(norms.coupler.values[j]),
                         f"force_{by}_N": float(vals[j])})
    return pd.DataFrame(rows)


def traction_check(ds: xr.Dataset, scenario: Scenario | None = None) -> pd.DataFrame:
    """Per phase (and the whole run): the largest traction and demand relative to the
    adhesion limit, and the samples where the demand exceeded adhesion (wheel-slip
    risk; the drive then delivers only the limit)."""
    scenario = _scenario_of(ds, scenario)
    windows = [(WHOLE_RUN, float(ds.time[0]), float(ds.time[-1]))]
    if scenario.phases:
        windows += phases_of(ds, scenario)
    rows = []
    for name, a, b in windows:
        w = ds.sel(time=slice(a, b))
        adh = w.adhesion_limit.values
        demand = np.abs(w.traction_demand.values)
        over = demand > adh
        rows.append({
            "phase": name,
            "max_traction_over_adhesion": float(np.max(np.abs(w.traction_force.values) / adh)),
            "max_demand_over_adhesion": float(np.max(demand / adh)),
            "samples_demand_over_adhesion": int(over.sum()),
            "first_time_over_s": float(w.time.values[over][0]) if over.any() else float("nan"),
        })
    return pd.DataFrame(rows)


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

    scenario = _scenario_of(ds, scenario)
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
        for i in range(1, nv):
            c = cmap(norm(i + 1))
            axes[k, 0].plot(w.time, w.relative_position.isel(vehicle=i) * 1e3, lw=0.8, color=c)
            axes[k, 1].plot(w.time, w.relative_velocity.isel(vehicle=i), lw=0.8, color=c)
        axes[k, 0].set_title(f"{name}: position relative to vehicle 1", loc="left")
        axes[k, 1].set_title(f"{name}: velocity relative to vehicle 1", loc="left")
        axes[k, 0].set_ylabel("[mm]")
        axes[k, 1].set_ylabel("[m/s]")
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    if nv > 1:
        bar = fig.colorbar(ScalarMappable(norm, cmap), ax=axes, label="vehicle (1 = lead)",
                           aspect=40, pad=0.01)
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
        axes[k, 0].set_title(f"{name}: locomotive force", loc="left")
        axes[k, 0].set_ylabel("[kN]")
        if nc:
            coupler_lines(axes[k, 1], w.time.values, w.coupler_force.values, picks,
                          others=nc <= 30)
        axes[k, 1].set_title(f"{name}: coupler forces (+ tension)", loc="left")
        axes[k, 1].set_ylabel("[kN]")
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    if nc:
        axes[0, 1].legend(loc="upper right", ncol=len(picks) + 1)
    fig.suptitle("Traction and coupler forces per phase (study Fig. 6)")
    files.append(_save(fig, folder / f"{prefix}fig6_forces.png"))

    # Fig. 7: traction against speed under the curve's three limits
    t = scenario.traction
    g = scenario.track.gravity
    vmax = max(float(np.abs(ds.velocity).max()) * 1.1, 1.0)
    v = np.linspace(0.0, vmax, 300)
    adh = adhesion_limit(v, t.adhesion_mass, g)
    power = np.divide(t.max_power, v, out=np.full_like(v, np.inf), where=v > 0)
    top = 1.08 * max(float(adh.max()), t.max_force, float(np.abs(ds.traction_force).max())) / 1e3
    cols = 2 if n > 1 else 1
    grid_rows = -(-n // cols)
    fig, axes = plt.subplots(grid_rows, cols, figsize=(WIDTH, 3.6 * grid_rows + 0.8),
                             squeeze=False, constrained_layout=True, sharey=True)
    ref = int(np.argmax([vh.powered for vh in scenario.vehicles]))
    for k, (name, a, b) in enumerate(phases):
        ax = axes.flat[k]
        ax.plot(v, adh / 1e3, "k:", lw=1.2, label="adhesion limit")
        ax.plot(v, np.full_like(v, t.max_force) / 1e3, "k--", lw=1, label="force limit")
        ax.plot(v, np.minimum(power, 2 * top * 1e3) / 1e3, "k-.", lw=1, label="power limit")
        w = ds.sel(time=slice(a, b))
        ax.plot(w.velocity.isel(vehicle=ref), np.abs(w.traction_force) / 1e3, ".", ms=2,
                color="tab:blue", label="|locomotive force|")
        ax.set_ylim(0, top)
        ax.set_xlim(0, vmax)
        ax.set_title(name, loc="left")
        ax.set_xlabel("speed of the locomotive [m/s]")
        ax.set_ylabel("force [kN]")
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    axes.flat[0].legend(loc="upper right")
    fig.suptitle("Locomotive force against speed under the traction curve, per phase "
                 "(study Fig. 7)")
    files.append(_save(fig, folder / f"{prefix}fig7_traction_curve.png"))
    return files
