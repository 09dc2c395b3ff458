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


import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.scenario import Scenario

from ltdsim.results.io import scenario_of

#: name of the single phase of a scenario that declares no ``[[phases]]``
WHOLE_RUN = "whole run"

#: the two meanings of "critical coupler" (the largest force in a phase), each with the
#: norm it ranks by: "peak" = the largest |force| (infinity norm), "RMS" = the RMS force
CRITERIA = {"peak": "infnorm", "RMS": "rms"}


def phases_of(ds: xr.Dataset, scenario: Scenario | None = None) -> list[tuple[str, float, float]]:
    """The phases (name, start s, end s) that overlap the record, clipped to it; for a
    scenario without ``[[phases]]`` the whole record as one phase named ``"whole run"``."""
    scenario = scenario_of(ds, scenario)
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


def powered_weight_mass(scenario: Scenario) -> float:
    """Static mass on the powered vehicles' wheels, kg: what a locomotive's own adhesion
    rests on (``static_mass``, else ``mass``, summed over the powered vehicles)."""
    return float(sum(v.static_mass or v.mass for v in scenario.vehicles if v.powered))


def traction_check(ds: xr.Dataset, scenario: Scenario | None = None) -> pd.DataFrame:
    """Per phase (and the whole run): the largest traction and demand relative to the
    adhesion limit, and the samples where the demand exceeded adhesion (wheel-slip
    risk; the drive then delivers only the limit); and the largest traction against the
    adhesion of the powered vehicles' own weight (:func:`powered_weight_mass`, the same
    Curtius-Kniffler coefficient at the leading powered vehicle's speed), with the
    adhesion coefficient that traction implies on that weight (-), whatever mass the
    scenario's ``traction.adhesion_mass`` gives."""
    from ltdsim.physics.drive.traction import adhesion_limit

    scenario = scenario_of(ds, scenario)
    own_mass = powered_weight_mass(scenario)
    g = scenario.track.gravity
    lead = int(np.argmax([v.powered for v in scenario.vehicles]))
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
            "max_traction_over_own_adhesion": float(np.max(np.abs(w.traction_force.values) / (
                adhesion_limit(w.velocity.values[:, lead], own_mass, g)))),
            "own_weight_adhesion_coefficient": float(np.max(np.abs(w.traction_force.values))
                                                     / (own_mass * g)),
        })
    return pd.DataFrame(rows)


