"""Fatigue damage of a run's couplers (docs/fatigue.md): each coupler's recorded force
reduced to its turning points, counted into cycles by rainflow counting (ASTM E1049-85,
section 5.4.4, through the ``rainflow`` package) and the cycles' damage summed by
Miner's rule on the S-N curve of its ``fatigue`` key.

A cycle of force range dF does 1 / N(dF) of the life, a half cycle half that, N the
cycles to failure of the curve (:func:`cycles_to_failure`); a damage of 1 is the curve's
life used up. The curves carry no mean-force correction: a cycle's damage depends on its
range alone, once the curve's ``load`` has chosen the part of the force that loads the
part ("draft": the tension, compression counted as zero; "buff": the compression;
"both": the signed force).

Only the recorded samples are counted (``solver.output_interval``): an excursion
between two samples is not seen, so a coarse interval gives a lower bound of the damage.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.results.io import scenario_of

#: the result attribute that carries the per-coupler damage (JSON, a list of records as
#: :func:`fatigue_damage` gives them), written by ltdsim.simulate
ATTR = "fatigue_json"

COLUMNS = ("coupler", "curve", "load", "damage", "damage_per_km", "cycles",
           "largest_range_N", "cutoff_range_N", "distance_m")

#: -: reversals smaller than this share of a history's largest magnitude are rounding,
#: not load, and always dropped (on a curve of slope m their damage is 1e-12^m of a cycle
#: of the history's scale: 1e-36 at m = 3); it also keeps the slopes whose product the
#: rainflow package tests for a reversal from underflowing
NOISE = 1e-12

#: m: the least distance the train must run for a damage per km (below it, one metre,
#: the run stood still and a damage per km would be a division by almost nothing)
MIN_DISTANCE = 1.0


# --------------------------------------------------------------- counting (ASTM E1049)
def turning_points(x, gate: float = 0.0) -> np.ndarray:
    """Indices of the turning points of history ``x`` (any unit): its first point, each
    reversal (a sample where the slope changes sign; of a flat extreme, its last sample)
    and its last point; a hysteresis filter then drops every reversal pair smaller than
    ``gate`` (x's unit; at least :data:`NOISE` times the largest magnitude of ``x``), so
    that no cycle or half cycle of range below it remains (the start, and the end, are
    replaced by the nearest extreme when the history moves less than ``gate`` from them
    before it turns), and every other cycle stays as it was.

    Returns
    -------
    numpy.ndarray
        Increasing indices into ``x`` (int).
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 2:
        return np.arange(n)
    d = np.diff(x)
    moving = np.flatnonzero(d != 0.0)
    if moving.size == 0:  # a constant history: one point
        return np.array([0])
    way = np.sign(d[moving])
    turns = moving[1:][way[1:] != way[:-1]]  # where the slope changed sign: the turning
    idx = np.concatenate(([0], turns, [n - 1]))  # sample, last of its flat run
    gate = max(float(gate), NOISE * float(np.max(np.abs(x[idx]))))
    if gate <= 0.0:
        return idx
    return idx[_gated(x[idx], gate)]


def _gated(v: np.ndarray, gate: float) -> np.ndarray:
    """The hysteresis filter of :func:`turning_points` on alternating extremes ``v``:
    positions into ``v`` of the extremes that survive ``gate``."""
    n = v.size
    lo = hi = 0
    k = 1
    while k < n:  # the first excursion of at least the gate sets the direction
        if v[k] > v[hi]:
            hi = k
        if v[k] < v[lo]:
            lo = k
        if v[hi] - v[lo] >= gate:
            break
        k += 1
    else:  # the whole history lies within the gate: nothing to count
        return np.array([0])
    keep = [min(lo, hi)]
    up = hi > lo
    c = max(lo, hi)  # the running extreme in the current direction
    for k in range(k + 1, n):
        if up:
            if v[k] > v[c]:
                c = k
            elif v[c] - v[k] >= gate:
                keep.append(c)
                up, c = False, k
        else:
            if v[k] < v[c]:
                c = k
            elif v[k] - v[c] >= gate:
                keep.append(c)
                up, c = True, k
    keep.append(c)
    return np.array(keep)


def rainflow_cycles(x, gate: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rainflow cycles of history ``x`` (any unit) after :func:`turning_points` with
    ``gate``: ASTM E1049-85's rainflow counting (section 5.4.4), each range of the
    residue counted as a half cycle.

    Returns
    -------
    ranges, means, counts : numpy.ndarray
        Each cycle's range and mean (x's unit) and count (1.0 for a full cycle, 0.5 for
        a half cycle), in the order the count finds them.
    """
    import rainflow

    v = np.asarray(x, dtype=float)[turning_points(x, gate)]
    if v.size == 2:  # one half cycle (rainflow 3.2 yields none for a two-point series)
        return (np.array([abs(v[1] - v[0])]), np.array([0.5 * (v[0] + v[1])]),
                np.array([0.5]))
    out = np.array([c[:3] for c in rainflow.extract_cycles(v.tolist())], dtype=float)
    if out.size == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    return out[:, 0], out[:, 1], out[:, 2]


# ------------------------------------------------------------------- the S-N curve
def knee_range(curve) -> float:
    """The force range at the curve's knee, N (NaN without a knee)."""
    if curve.knee_cycles is None:
        return math.nan
    return curve.reference_range * (curve.reference_cycles / curve.knee_cycles) ** (1.0 / curve.slope)


def cutoff_range(curve) -> float:
    """The force range below which the curve does no damage, N: its cut-off's, or the
    knee's for a curve with no slope below the knee; 0 for a curve that damages at any
    range."""
    if curve.knee_cycles is None:
        return 0.0
    if curve.slope_beyond_knee is None:
        return knee_range(curve)
    if curve.cutoff_cycles is None:
        return 0.0
    return knee_range(curve) * (curve.knee_cycles / curve.cutoff_cycles) ** (1.0 / curve.slope_beyond_knee)


def cycles_to_failure(curve, ranges) -> np.ndarray:
    """Cycles to failure N (-) of force ranges ``ranges`` (N) on S-N curve ``curve``
    (a :class:`ltdsim.scenario.couplers.FatigueCurve`): N = N_ref (dF_ref / dF)^m at and
    above the knee (everywhere without one); below the knee N = N_knee (dF_knee / dF)^m2
    down to the cut-off, or infinite (no damage) without a second slope; infinite below
    the cut-off and for a range of 0."""
    dF = np.asarray(ranges, dtype=float)
    with np.errstate(over="ignore", divide="ignore"):  # (a tiny range: N = inf, no damage)
        return _cycles_to_failure(curve, dF)


def _cycles_to_failure(curve, dF: np.ndarray) -> np.ndarray:
    N = np.full(dF.shape, np.inf)
    pos = dF > 0.0
    ref, n_ref, m = curve.reference_range, curve.reference_cycles, curve.slope
    if curve.knee_cycles is None:
        N[pos] = n_ref * (ref / dF[pos]) ** m
        return N
    knee = knee_range(curve)
    above = pos & (dF >= knee)
    N[above] = n_ref * (ref / dF[above]) ** m
    if curve.slope_beyond_knee is not None:
        below = pos & ~above & (dF >= cutoff_range(curve))
        N[below] = curve.knee_cycles * (knee / dF[below]) ** curve.slope_beyond_knee
    return N


def miner_damage(curve, ranges, counts) -> float:
    """Miner's sum (-) of cycles of ``ranges`` (N) counted ``counts`` times (-, 0.5 for a
    half cycle) on ``curve``: the sum of count / N(range)."""
    counts = np.asarray(counts, dtype=float)
    if counts.size == 0:
        return 0.0
    return float(np.sum(counts / cycles_to_failure(curve, ranges)))


def loading(force, load: str) -> np.ndarray:
    """The part of coupler force ``force`` (N, + tension) that loads a part whose curve
    has ``load``: "draft" the tension (compression as 0), "buff" the compression as a
    positive force (tension as 0), "both" the signed force, N."""
    f = np.asarray(force, dtype=float)
    if load == "draft":
        return np.maximum(f, 0.0)
    if load == "buff":
        return np.maximum(-f, 0.0)
    if load == "both":
        return f
    raise ValueError(f"unknown load {load!r}; one of draft, buff, both")


def history_damage(curve, force) -> dict:
    """Damage of one coupler force history ``force`` (N) on ``curve``: its ``load`` part,
    turning points through the curve's ``gate``, rainflow counted, Miner summed.

    Returns
    -------
    dict
        ``damage`` (-), ``cycles`` (the counted cycles, half cycles as 0.5, -) and
        ``largest_range_N`` (N, 0 without cycles).
    """
    ranges, _, counts = rainflow_cycles(loading(force, curve.load), curve.gate)
    return {"damage": miner_damage(curve, ranges, counts), "cycles": float(counts.sum()),
            "largest_range_N": float(ranges.max()) if ranges.size else 0.0}


# ---------------------------------------------------------------------- a run
def distance_run(ds: xr.Dataset) -> float:
    """How far the train ran, m: the lead vehicle's path, the sum of its recorded
    position steps (a train that backs up runs the way back too); NaN when position was
    not recorded."""
    if "position" not in ds or ds.sizes.get("time", 0) < 2:
        return math.nan
    return float(np.abs(np.diff(ds.position.values[:, 0])).sum())


def _curve_label(fatigue) -> str:
    return fatigue if isinstance(fatigue, str) else "inline"


def fatigue_damage(ds: xr.Dataset, scenario=None) -> pd.DataFrame:
    """Per-coupler fatigue damage of result ``ds``: one row per coupler with a
    ``fatigue`` key, the most damaged first.

    Columns: ``coupler`` (numbered from 1, coupler 1 behind the lead vehicle), ``curve``
    (the curve's name, or "inline"), ``load`` (draft, buff or both), ``damage`` (Miner's
    sum over the run, -), ``damage_per_km`` (over the distance the train ran, 1/km; NaN
    when it ran under :data:`MIN_DISTANCE` or position was not recorded), ``cycles``
    (-), ``largest_range_N`` (N), ``cutoff_range_N`` (the curve's :func:`cutoff_range`,
    N) and ``distance_m`` (:func:`distance_run`, m). Empty when
    no coupler has a curve or the run did not record coupler_force.
    """
    from ltdsim.scenario.couplers import fatigue_curve

    scenario = scenario_of(ds, scenario)
    rows: list[dict] = []
    nc = ds.sizes.get("coupler", 0)
    if nc and "coupler_force" in ds:
        force = ds.coupler_force.values
        dist = distance_run(ds)
        km = dist / 1e3 if dist >= MIN_DISTANCE else math.nan
        for j in range(nc):
            spec = scenario.coupler(j).fatigue
            curve = fatigue_curve(spec)
            if curve is None:
                continue
            d = history_damage(curve, force[:, j])
            rows.append({"coupler": j + 1, "curve": _curve_label(spec), "load": curve.load,
                         "damage": d["damage"], "damage_per_km": d["damage"] / km,
                         "cycles": d["cycles"], "largest_range_N": d["largest_range_N"],
                         "cutoff_range_N": cutoff_range(curve), "distance_m": dist})
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    if table.empty:
        return table
    return table.sort_values(["damage", "coupler"], ascending=[False, True],
                             kind="stable").reset_index(drop=True)


def damage_json(table: pd.DataFrame) -> str:
    """The damage table as the result stores it: a JSON list of records (NaN as null)."""
    from ltdsim.results.strength import events_json

    return events_json(table)


def stored_damage(ds: xr.Dataset) -> pd.DataFrame | None:
    """The damage table a result carries (its :data:`ATTR`), or None for a result
    without."""
    import json

    if ATTR not in ds.attrs:
        return None
    table = pd.DataFrame(json.loads(ds.attrs[ATTR]), columns=list(COLUMNS))
    return table.astype({"damage_per_km": float, "distance_m": float})


def damage_lines(table: pd.DataFrame, limit: int = 3) -> list[str]:
    """The damage as lines for ``ltdsim run``: how many couplers were counted and the
    most damaged ones, at most ``limit``, each with its damage this trip (-) and per km
    (1/km), its cycles and largest range (kN) and its curve; when no coupler took damage,
    one line saying so with the largest range against the curve's cut-off. Empty without
    rows."""
    if table is None or table.empty:
        return []
    n = len(table)
    dist = float(table.distance_m.iloc[0])
    if dist != dist:
        over = "(position not recorded: no damage per km)"
    elif dist < MIN_DISTANCE:
        over = f"(the train ran {dist:.2g} m: no damage per km)"
    else:
        over = f"over {dist / 1e3:.3g} km"
    hurt = table[table.damage > 0.0]
    if hurt.empty:
        worst = table.loc[table.largest_range_N.idxmax()]
        line = (f"fatigue: no damage on the {n} coupler{'s' if n != 1 else ''} counted "
                f"(Miner's rule on rainflow cycles, ASTM E1049-85) {over}: the largest "
                f"force range, {worst.largest_range_N / 1e3:.0f} kN at coupler "
                f"{int(worst.coupler)}")
        if worst.cutoff_range_N > 0.0:
            line += (f", is below the cut-off range of its curve ({worst.curve}), "
                     f"{worst.cutoff_range_N / 1e3:.0f} kN")
        return [line]
    lines = [f"fatigue: Miner damage (-) of {n} coupler{'s' if n != 1 else ''} from rainflow "
             f"cycles of the recorded force (ASTM E1049-85) {over}, {len(hurt)} with "
             "damage; the most damaged first:"]
    for r in hurt.head(limit).itertuples():
        per_km = (f", {r.damage_per_km:.3g} per km" if r.damage_per_km == r.damage_per_km
                  else "")
        lines.append(f"  coupler {r.coupler}: {r.damage:.3g} this trip{per_km} (a life of "
                     f"{1.0 / r.damage:.3g} such trips; {r.cycles:g} cycles, largest range "
                     f"{r.largest_range_N / 1e3:.0f} kN, {r.load}, curve {r.curve})")
    if len(hurt) > limit:
        lines.append(f"  and {len(hurt) - limit} more couplers with damage")
    return lines
