"""Strength events of a run: when a coupler's force first went over its proof and its
ultimate load (the strength grade of its ``strength`` key, docs/strength.md), in tension
and in compression, and the gears that closed solid (their deflection beyond the travel,
:func:`ltdsim.results.summary.gear_travel_check`).

ltdsim does not model a coupler yielding or breaking: the forces of the run are those of
couplings that hold. An event says that a real coupling would have deformed permanently
(over its proof load) or broken (over its ultimate load) at that time, so that what the
run shows after it is what an unbroken train would have done.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.results.io import scenario_of
from ltdsim.results.summary import _crossing, coupler_summary, gear_travel_check

#: the result attribute that carries the events (JSON, a list of records as
#: :func:`strength_events` gives them), written by ltdsim.simulate
ATTR = "strength_events_json"

#: the kinds of event, the most severe first
KINDS = ("ultimate", "proof", "solid")

COLUMNS = ("coupler", "kind", "direction", "limit_N", "force_N", "travel_m",
           "deflection_m", "time_s", "peak_time_s", "between_samples", "grade")


def _grade_label(strength) -> str:
    return strength if isinstance(strength, str) else "inline"


def strength_events(ds: xr.Dataset, scenario=None) -> pd.DataFrame:
    """Every strength event of result ``ds``, the most severe first.

    One row per coupler, kind and direction that happened:

    ``coupler`` (numbered from 1, coupler 1 behind the lead vehicle), ``kind``
    ("ultimate": over the ultimate load, the coupling would break; "proof": over the proof
    load, it would deform permanently; "solid": its gear closed solid, deflected beyond
    its travel), ``direction`` ("tension" or "compression"), ``limit_N`` (the load, N)
    and ``force_N`` (the run's peak force that way, N, >= 0) of a load event (NaN for
    "solid"), ``travel_m`` (the gear's travel, m) and ``deflection_m`` (the largest
    deflection of one gear beyond the slack, m) of a "solid" one (NaN for a load), ``time_s``
    (when the recorded force first reached the limit, linear between samples; a peak over
    the limit between two samples, seen only in the step-by-step peaks, gives its own
    time and ``between_samples`` True), ``peak_time_s`` and ``grade`` (the strength
    grade's name, or "inline", or "" for "solid").

    Ordered by kind (ultimate, proof, solid), then by how far over the limit (force over
    limit, largest first). Couplers without a ``strength`` key have no load events; a
    run that did not record coupler_deflection has no "solid" ones.
    """
    from ltdsim.scenario.couplers import strength_limits

    scenario = scenario_of(ds, scenario)
    nc = ds.sizes.get("coupler", 0)
    rows: list[dict] = []
    if nc:
        peaks = coupler_summary(ds)
        t = ds.time.values
        force = ds.coupler_force.values if "coupler_force" in ds else None
        for j in range(nc):
            spec = scenario.coupler(j).strength
            limits = strength_limits(spec)
            if limits is None:
                continue
            row = peaks.iloc[j]
            for direction, peak, t_peak, sign in (
                    ("tension", row.max_tension_N, row.t_max_tension_s, 1.0),
                    ("compression", row.max_compression_N, row.t_max_compression_s, -1.0)):
                way = "draft" if sign > 0 else "buff"
                for kind in ("ultimate", "proof"):
                    limit = getattr(limits, f"{way}_{kind}")
                    if limit is None or not peak >= limit:
                        continue
                    series = (sign * force[:, j] if force is not None and force.shape[0]
                              else None)
                    when, between = _first_over(t, series, limit, float(peak), float(t_peak))
                    rows.append({"coupler": j + 1, "kind": kind, "direction": direction,
                                 "limit_N": float(limit), "force_N": float(peak),
                                 "travel_m": math.nan, "deflection_m": math.nan,
                                 "time_s": when,
                                 "peak_time_s": float(t_peak), "between_samples": between,
                                 "grade": _grade_label(spec)})
        if "coupler_deflection" in ds:
            rows += _solid_events(ds, scenario)
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    if table.empty:
        return table
    table["_kind"] = table.kind.map(KINDS.index)
    table["_over"] = (table.force_N / table.limit_N).fillna(table.deflection_m
                                                           / table.travel_m)
    return (table.sort_values(["_kind", "_over", "coupler"], ascending=[True, False, True])
            .drop(columns=["_kind", "_over"]).reset_index(drop=True))


def _first_over(t: np.ndarray, s: np.ndarray | None, limit: float, peak: float,
                t_peak: float) -> tuple[float, bool]:
    """When the force ``s`` (recorded at times ``t``, signed so that the direction looked
    at is positive; None if not recorded) first reached ``limit``, and whether that was
    between samples. Linear between the last sample below and the first at or over it;
    the step-by-step peak (``peak`` at ``t_peak``, over the limit) is a point of the
    curve too: when it lies before the first sample over (a coarse output interval, or an
    excursion the samples missed), the crossing is between the sample before the peak and
    the peak."""
    k = None if s is None else np.flatnonzero(s >= limit)
    first = float(t[k[0]]) if k is not None and k.size else math.inf
    if t_peak >= first:  # the samples saw it first: linear between them
        return _crossing(t, s, limit, 0, below=False), False
    j = int(np.searchsorted(t, t_peak, side="left"))  # t[j - 1] < t_peak <= t[j]
    if s is None or j == 0:
        return t_peak, s is None or not np.isfinite(first)
    t0, s0 = float(t[j - 1]), float(s[j - 1])
    w = (limit - s0) / (peak - s0) if peak > s0 else 1.0
    return t0 + w * (t_peak - t0), bool(k is None or not k.size or k[0] > j)


def _solid_events(ds: xr.Dataset, scenario) -> list[dict]:
    """The gears beyond their travel (:func:`gear_travel_check`, the check the travel
    warning makes), each with the first recorded time its deflection passed the travel."""
    table = gear_travel_check(ds, scenario)
    over = table[table.exceeds]
    if over.empty:
        return []
    t = ds.time.values
    d = ds.coupler_deflection.values
    rows = []
    for j, r in over.iterrows():
        j = int(j)
        # one gear's deflection beyond the slack is (|d| - slack / 2) / gears
        reach = 0.5 * r.slack_m + r.gears * r.travel_m
        tension = r.max_draft_m >= r.max_buff_m
        when = _crossing(t, d[:, j], reach if tension else -reach, 0, below=not tension)
        rows.append({"coupler": j + 1, "kind": "solid",
                     "direction": "tension" if tension else "compression",
                     "limit_N": math.nan, "force_N": math.nan,
                     "travel_m": float(r.travel_m), "deflection_m": float(r.max_deflection_m),
                     "time_s": when, "peak_time_s": float("nan"),
                     "between_samples": False, "grade": ""})
    return rows


def events_json(table: pd.DataFrame) -> str:
    """The events as the result stores them: a JSON list of records (NaN as null)."""
    records = table.to_dict("records")
    for r in records:
        for k, v in r.items():
            if isinstance(v, float) and not np.isfinite(v):
                r[k] = None
            elif isinstance(v, (np.bool_,)):
                r[k] = bool(v)
            elif isinstance(v, np.integer):
                r[k] = int(v)
    return json.dumps(records)


def stored_events(ds: xr.Dataset) -> pd.DataFrame | None:
    """The events a result carries (its :data:`ATTR`), or None for a result without."""
    if ATTR not in ds.attrs:
        return None
    return pd.DataFrame(json.loads(ds.attrs[ATTR]), columns=list(COLUMNS))


def event_lines(table: pd.DataFrame, limit: int = 6) -> list[str]:
    """The load events (ultimate and proof, not "solid": the travel warning names those)
    as lines for ``ltdsim run``: a count of the couplers over each kind of load, then one
    line per coupler, the most severe first (its worst event, with when it first went over
    its proof load that way), at most ``limit`` and "and N more couplers". Empty without
    events."""
    loads = table[table.kind != "solid"]
    if loads.empty:
        return []
    n_ult = loads[loads.kind == "ultimate"].coupler.nunique()
    n_proof = loads[loads.kind == "proof"].coupler.nunique()
    lines = [f"strength: {n_ult} coupler{'s' if n_ult != 1 else ''} over an ultimate load "
             f"(would break), {n_proof} over a proof load (would deform permanently); the "
             "most severe first:"]
    worst = loads.drop_duplicates("coupler")  # (sorted: each coupler's worst event first)
    for r in worst.head(limit).itertuples():
        what = "breaks" if r.kind == "ultimate" else "yields"
        line = (f"  coupler {r.coupler} {what} in {r.direction}: peak {r.force_N / 1e3:.0f} kN "
                f"over its {r.kind} load {r.limit_N / 1e3:.0f} kN ({r.grade}), first at "
                f"{r.time_s:.2f} s" + (" (between samples)" if r.between_samples else ""))
        if r.kind == "ultimate":
            proof = loads[(loads.coupler == r.coupler) & (loads.kind == "proof")
                          & (loads.direction == r.direction)]
            if not proof.empty:
                p = proof.iloc[0]
                line += f"; over its proof load {p.limit_N / 1e3:.0f} kN from {p.time_s:.2f} s"
        lines.append(line)
    if len(worst) > limit:
        lines.append(f"  and {len(worst) - limit} more couplers")
    return lines
