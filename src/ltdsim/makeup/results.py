"""The results of a make-up study, read from its case records: per run the largest
longitudinal compressive force (LCF) and tensile force (LTF), at which coupler, where
in the train and when, and against the couplers' limits; over the population the
distribution (percentiles), the probability that a run exceeds its limits with an
exact (Clopper-Pearson) confidence interval from the number of runs, the worst
make-ups and what they share, and the fatigue damage per coupler.

Forces are in kN in the tables (N inside), positions in m from the front of the train,
times in s from the start of the run; couplers are counted from 1 (coupler 1 behind the
lead vehicle).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim.makeup.draws import coupler_limits, features, train_of
from ltdsim.makeup.run import Plan
from ltdsim.sweep.core import case_path

#: the make-up features the tables and figures read (docs/makeup.md, "Results")
FEATURES = ("empties", "empty_share", "empties_ahead_of_loads", "longest_empty_run",
            "empties_ahead_of_remote")
#: the percentiles of the population's tables, %
PERCENTILES = (50, 90, 95, 99)
#: share of each manoeuvre's runs counted as its worst make-ups (at least one)
WORST_SHARE = 0.10
FORCES = {"lcf": ("max_compression_N", "t_max_compression_s"),
          "ltf": ("max_tension_N", "t_max_tension_s")}


def clopper_pearson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact two-sided confidence interval of a probability seen ``k`` times in ``n``
    trials (Clopper and Pearson, 1934; ``scipy.stats.binomtest``), -; (NaN, NaN) for
    ``n = 0``."""
    if n == 0:
        return math.nan, math.nan
    from scipy.stats import binomtest

    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


def _between(train, j: int) -> str:
    """The two vehicles coupler ``j`` (0-based) joins, as their names."""
    def name(k):
        w = train.wagon[k]
        return "locomotive" if w is None else f"{w[0]}-{w[1]}"
    return f"{name(j)} / {name(j + 1)}"


def run_table(p: Plan, out: str | Path) -> pd.DataFrame:
    """One row per run (make-up and manoeuvre) of plan ``p`` on disk in ``out``: its
    status and, for a finished run, for each of LCF and LTF the largest force (kN),
    its coupler (from 1), its distance from the front (m), its time (s), the two
    vehicles the coupler joins, that coupler's limit (kN), the run's largest force
    over limit of any coupler (its utilisation, -) and whether it exceeds 1; and the
    make-up's features."""
    rows = []
    mans = [m.name for m in p.study.spec.manoeuvres]
    for mk in p.population:
        train = train_of(p.study, mk)
        pos = train.coupler_positions()
        limits = dict(zip(("lcf", "ltf"), coupler_limits(p.study, train)))
        feats = features(mk)
        for man in mans:
            cid = p.case_id(mk, man)
            row = {"run": cid, "makeup": mk.id, "manoeuvre": man}
            path = case_path(Path(out), cid)
            if not path.is_file():
                rows.append({**row, "status": "not run", **feats})
                continue
            rec = json.loads(path.read_text())
            row.update(status=rec["status"], error=rec.get("error"))
            peaks = rec.get("peaks") or {}
            if rec["status"] == "ok" and peaks:
                for key, (col, tcol) in FORCES.items():
                    f = np.asarray(peaks[col], dtype=float)
                    j = int(np.argmax(f))
                    lim = limits[key]
                    with np.errstate(invalid="ignore", divide="ignore"):
                        util = f / lim
                    use = np.nanmax(util) if np.isfinite(util).any() else math.nan
                    row.update({f"max_{key}_kN": f[j] / 1e3, f"{key}_coupler": j + 1,
                                f"{key}_position_m": float(pos[j]),
                                f"{key}_time_s": float(peaks[tcol][j]),
                                f"{key}_between": _between(train, j),
                                f"{key}_limit_kN": lim[j] / 1e3,
                                f"{key}_utilisation": use,
                                f"{key}_exceeds": bool(use > 1.0) if use == use else None})
            rows.append({**row, **feats})
    return pd.DataFrame(rows)


def percentile_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per manoeuvre and force (LCF, LTF): the finished runs, the mean, the
    :data:`PERCENTILES` and the largest of the runs' largest forces, kN (numpy's linear
    percentiles; with few runs the high ones are the largest runs')."""
    rows = []
    for man, g in _finished(runs).groupby("manoeuvre", sort=False):
        for key in FORCES:
            v = g[f"max_{key}_kN"].to_numpy(float)
            row = {"manoeuvre": man, "force": key.upper(), "runs": len(v),
                   "mean_kN": float(np.mean(v))}
            row.update({f"p{q}_kN": float(np.percentile(v, q)) for q in PERCENTILES})
            row["max_kN"] = float(np.max(v))
            rows.append(row)
    return pd.DataFrame(rows)


def exceedance_table(runs: pd.DataFrame, confidence: float = 0.95) -> pd.DataFrame:
    """Per manoeuvre and force: of the finished runs whose couplers have limits, how
    many exceeded a limit somewhere in the train, the estimated probability of
    exceeding (-) and its Clopper-Pearson interval at ``confidence`` (-)."""
    rows = []
    for man, g in _finished(runs).groupby("manoeuvre", sort=False):
        for key in FORCES:
            col = f"{key}_exceeds"
            judged = g[col].dropna() if col in g else pd.Series([], dtype=object)
            n, k = len(judged), int(judged.astype(bool).sum())
            lo, hi = clopper_pearson(k, n, confidence)
            rows.append({"manoeuvre": man, "force": key.upper(), "runs_with_limits": n,
                         "runs_exceeding": k, "probability": k / n if n else math.nan,
                         f"ci{confidence * 100:g}_low": lo, f"ci{confidence * 100:g}_high": hi,
                         "largest_utilisation": float(g[f"{key}_utilisation"].max())
                         if n else math.nan})
    return pd.DataFrame(rows)


def exceedance_curve(values, confidence: float = 0.95, points: int = 200):
    """The empirical probability that a run's largest force exceeds F, with its
    Clopper-Pearson band: ``(F, p, low, high)`` arrays over ``points`` forces spanning
    ``values`` (any unit: F is in it)."""
    v = np.sort(np.asarray(values, float))
    n = len(v)
    f = np.linspace(0.9 * v[0], v[-1] * 1.05, points)
    k = n - np.searchsorted(v, f, side="right")
    band = np.array([clopper_pearson(int(x), n, confidence) for x in k])
    return f, k / n, band[:, 0], band[:, 1]


def worst_table(p: Plan, runs: pd.DataFrame, key: str = "lcf") -> pd.DataFrame:
    """Per manoeuvre, its worst make-ups by the largest ``key`` force (the top
    :data:`WORST_SHARE` of its finished runs, at least one), worst first: the run's
    peak, where and when, and the make-up's features and wagons."""
    labels = {m.id: m.label() for m in p.population}
    out = []
    for man, g in _finished(runs).groupby("manoeuvre", sort=False):
        n = max(1, math.ceil(WORST_SHARE * len(g)))
        top = g.sort_values(f"max_{key}_kN", ascending=False, kind="stable").head(n)
        cols = ["manoeuvre", "makeup", f"max_{key}_kN", f"{key}_coupler", f"{key}_position_m",
                f"{key}_time_s", f"{key}_between", *FEATURES]
        t = top[cols].copy()
        t["wagons"] = [labels[m] for m in t.makeup]
        out.append(t)
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame()


def shared_table(runs: pd.DataFrame, key: str = "lcf") -> pd.DataFrame:
    """What the worst make-ups share: per manoeuvre and feature, its mean over the
    worst make-ups (:func:`worst_table`'s) and over the others, and Spearman's rank
    correlation of the feature with the largest ``key`` force over all finished runs
    (-1 to 1; NaN where the feature does not vary)."""
    from scipy.stats import spearmanr

    rows = []
    for man, g in _finished(runs).groupby("manoeuvre", sort=False):
        n = max(1, math.ceil(WORST_SHARE * len(g)))
        g = g.sort_values(f"max_{key}_kN", ascending=False, kind="stable")
        worst, rest = g.head(n), g.iloc[n:]
        for feat in FEATURES:
            x = g[feat].to_numpy(float)
            y = g[f"max_{key}_kN"].to_numpy(float)
            ok = np.isfinite(x)
            rho = (float(spearmanr(x[ok], y[ok]).statistic)
                   if ok.sum() > 2 and np.ptp(x[ok]) > 0 and np.ptp(y[ok]) > 0 else math.nan)
            rows.append({"manoeuvre": man, "force": key.upper(), "feature": feat,
                         "worst_mean": float(worst[feat].mean()),
                         "others_mean": float(rest[feat].mean()) if len(rest) else math.nan,
                         "spearman_with_force": rho})
    return pd.DataFrame(rows)


def fatigue_table(p: Plan, out: str | Path) -> pd.DataFrame:
    """Per manoeuvre and coupler (from 1): the median and largest Miner damage per run
    over the make-ups (-) and the median distance of the coupler from the front (m).
    Empty when no coupler has a fatigue curve."""
    rows = []
    for mk in p.population:
        pos = train_of(p.study, mk).coupler_positions()
        for m in p.study.spec.manoeuvres:
            path = case_path(Path(out), p.case_id(mk, m.name))
            if not path.is_file():
                continue
            rec = json.loads(path.read_text())
            for r in rec.get("fatigue") or []:
                rows.append({"manoeuvre": m.name, "coupler": int(r["coupler"]),
                             "damage": float(r["damage"]),
                             "position_m": float(pos[int(r["coupler"]) - 1])})
    if not rows:
        return pd.DataFrame()
    t = pd.DataFrame(rows)
    return (t.groupby(["manoeuvre", "coupler"], sort=False)
             .agg(median_damage=("damage", "median"), max_damage=("damage", "max"),
                  median_position_m=("position_m", "median"), runs=("damage", "size"))
             .reset_index())


def _finished(runs: pd.DataFrame) -> pd.DataFrame:
    if "max_lcf_kN" not in runs:
        return runs.iloc[0:0].assign(max_lcf_kN=[], max_ltf_kN=[])
    return runs[(runs.status == "ok") & runs.max_lcf_kN.notna()]
