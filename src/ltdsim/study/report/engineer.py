"""The report's outputs for an engineer, from the results the study already computed:
the coupler-force envelopes along the train per phase, the 16 cases' peaks over the
stiffness and damping factors, the track the base case runs over, and each gear's
travel against its limit (a coupling's deflection beyond its slack shared by its gears
in series).
"""

from __future__ import annotations

import html
import itertools

import numpy as np
import pandas as pd

from ltdsim.study.report.html import (
    csv_table,
    figure_html,
    numbers_text,
    table_html,
)
from ltdsim.study.report.page import Report

#: the four factors of the study's cases (its Table 2): each case sets every one of them
#: at its low (L) or high (H) value; the scenario keys that carry them
FACTORS = (("k1", "k1"), ("k2", "k2"), ("k3", "k3"), ("b", "damping"))


def outputs(rep: Report) -> None:
    """Add the section: envelopes, the cases' heatmaps, the track and the gear travel."""
    nc = rep.out / "base_case.nc"
    ds = None
    if nc.is_file():
        from ltdsim.results.io import load_result

        need = ("position", "velocity", "coupler_force", "coupler_deflection",
                "speed_reference")
        ds = load_result(nc, needs=need, purpose="the report's envelopes and track",
                         keep=need + ("max_coupler_force", "min_coupler_force"))
    rep.parts.append("<h2 id='engineer'>For the engineer: envelopes, the cases, the track "
                     "and the gear travel</h2>")
    if ds is not None and ds.sizes.get("coupler", 0):
        envelopes(rep, ds)
    cases(rep)
    if ds is not None:
        track(rep, ds)
        if ds.sizes.get("coupler", 0):
            gear_travel(rep, ds)


# (a) envelopes along the train
def envelope_table(ds, scenario, peaks: pd.DataFrame | None = None) -> pd.DataFrame:
    """Largest tension and compression of every coupler (kN, both >= 0; couplers from 1)
    in each of the scenario's phases, over the recorded samples in the phase's window,
    and over the whole run (every integration step where ``peaks``, the base run's
    :func:`ltdsim.results.summary.coupler_summary`, is given; else the records)."""
    t = ds.time.values
    f = ds.coupler_force.values
    rows = []
    windows = [(p.name, (t >= p.start) & (t <= p.end)) for p in scenario.phases]
    for name, sel in windows:
        if not sel.any():
            continue
        top, low = f[sel].max(axis=0), f[sel].min(axis=0)
        for j in range(f.shape[1]):
            rows.append({"phase": name, "coupler [1 = behind the locomotive]": j + 1,
                         "max tension [kN]": max(top[j], 0.0) / 1e3,
                         "max compression [kN]": max(-low[j], 0.0) / 1e3})
    if peaks is not None and len(peaks):
        ten, com = np.asarray(peaks["max_tension_N"]), np.asarray(peaks["max_compression_N"])
    else:
        ten, com = np.maximum(f.max(axis=0), 0.0), np.maximum(-f.min(axis=0), 0.0)
    for j in range(f.shape[1]):
        rows.append({"phase": "whole run", "coupler [1 = behind the locomotive]": j + 1,
                     "max tension [kN]": ten[j] / 1e3, "max compression [kN]": com[j] / 1e3})
    return pd.DataFrame(rows)


def envelopes(rep: Report, ds) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cs = pd.DataFrame(rep.results["base"].get("couplers") or [])
    te = envelope_table(ds, rep.sc, cs if len(cs) else None)
    col = "coupler [1 = behind the locomotive]"
    fig, ax = plt.subplots(figsize=(9, 4.2), dpi=90)
    names = list(dict.fromkeys(te.phase))
    colours = plt.get_cmap("tab10")
    for k, name in enumerate(names):
        d = te[te.phase == name]
        whole = name == "whole run"
        style = dict(color="k" if whole else colours(k), lw=3.0 if whole else 1.3,
                     marker="o", ms=4.5 if whole else 3.0, zorder=1 if whole else 3,
                     alpha=0.55 if whole else 1.0)
        ax.plot(d[col], d["max tension [kN]"], label=name.replace("_", " "), **style)
        ax.plot(d[col], -d["max compression [kN]"], ls="--", **style)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("coupler [1 = behind the locomotive]")
    ax.set_ylabel("coupler force [kN] (+ tension, − compression)")
    n = int(te[col].max())
    ax.set_xticks(range(1, n + 1) if n <= 30 else None)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=min(len(names), 5), loc="best")
    ax.set_title(f"Coupler-force envelopes along the train, case {rep.case}: largest "
                 "tension (solid) and compression (dashed)", fontsize=9)
    fig.tight_layout()
    path = rep.out / "report_envelopes.png"
    fig.savefig(path)
    plt.close(fig)
    whole = te[te.phase == "whole run"]
    jt = int(whole.loc[whole["max tension [kN]"].idxmax(), col])
    jc = int(whole.loc[whole["max compression [kN]"].idxmax(), col])
    where = (f"tension peak at coupler {jt} and compression at coupler {jc}"
             if whole["max compression [kN]"].max() > 0 else
             f"tension peak at coupler {jt} (no coupler is compressed)")
    rep.parts += [
        "<h3 id='envelopes'>Coupler-force envelopes along the train</h3>",
        "<p class='note'>For every coupler its largest tension and its largest "
        "compression, in each phase (over the recorded samples in its window) and over "
        "the whole run (over every integration step). The whole run's envelope is what "
        "a coupler and its gear must carry; the phases say when.</p>",
        figure_html(path, f"Coupler-force envelopes, case {rep.case}: largest tension "
                    "(solid, up) and compression (dashed, down) of each coupler, kN, per "
                    f"phase and over the whole run (black). See {where}, and how the "
                    "phases order the loads along the train"),
        csv_table(te, rep.out, "coupler_envelopes.csv")]


# (b) the cases over the four factors
def case_levels(rep: Report) -> dict[str, dict[str, str]]:
    """Each case's level, "L" or "H", of each of the four factors (:data:`FACTORS`),
    read from its coupler's values: the nearer of the study's Table 1 low and high values
    (its simplified model's two sets). Without them, the lower of the values the cases
    give a factor is L."""
    values = {}
    for name in rep.sc.cases:
        c = rep.sc.with_case(name).coupler(0)
        values[name] = {f: float(getattr(c, key)) for f, key in FACTORS}
    table = (rep.T.get("table1") or {}).get("simplified_model") or {}
    ref = {f: table.get(col) for f, col in zip([f for f, _ in FACTORS],
                                               ("k1_N_m", "k2_N_m", "k3_N_m", "b_N_s_m"))}

    def level(f, v):
        pair = ref.get(f)
        if pair and len(pair) == 2:
            return "H" if abs(v - pair[1]) < abs(v - pair[0]) else "L"
        low = min(x[f] for x in values.values())
        return "L" if np.isclose(v, low) else "H"

    return {n: {f: level(f, v[f]) for f, _ in FACTORS} for n, v in values.items()}


def case_table(rep: Report) -> pd.DataFrame:
    """One row per finished case: its factor levels and its peak tension and compression
    (kN, over all couplers), largest wagon |acceleration| (m/s^2, vehicles 2 on) and RMS
    speed error (m/s), from each case's summary."""
    levels = case_levels(rep)
    rows = []
    for name, rec in rep.results["sweep"].items():
        if rec.get("status") != "ok" or name not in levels:
            continue
        s = rec["summary"]
        acc = np.asarray(s["max_abs_acceleration_m_s2"], dtype=float)
        rows.append({"case": name, **{f"{f} level": levels[name][f] for f, _ in FACTORS},
                     "peak tension [kN]": max(s["max_tension_N"]) / 1e3,
                     "peak compression [kN]": max(s["max_compression_N"]) / 1e3,
                     "largest wagon |acceleration| [m/s²]":
                         float(np.nanmax(acc[1:] if acc.size > 1 else acc)),
                     "RMS speed error [m/s]": s["rms_speed_error_m_s"]})
    return pd.DataFrame(rows)


def cases(rep: Report) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tc = case_table(rep)
    if tc.empty:
        return
    metrics = ["peak tension [kN]", "peak compression [kN]",
               "largest wagon |acceleration| [m/s²]", "RMS speed error [m/s]"]
    rows = ["".join(p) for p in itertools.product("LH", repeat=2)]  # k1 k2
    cols = ["".join(p) for p in itertools.product("LH", repeat=2)]  # k3 b
    short = dict(zip(metrics, ["peak tension [kN]", "peak compression [kN]",
                               "largest wagon |a| [m/s²]", "RMS speed error [m/s]"]))
    fig, axes = plt.subplots(1, 4, figsize=(13, 3.4), dpi=90)
    for ax, m in zip(axes, metrics):
        grid = np.full((4, 4), np.nan)
        for _, r in tc.iterrows():
            i = rows.index(r["k1 level"] + r["k2 level"])
            j = cols.index(r["k3 level"] + r["b level"])
            grid[i, j] = r[m]
        im = ax.imshow(np.ma.masked_invalid(grid), cmap="viridis")
        lo, hi = np.nanmin(grid), np.nanmax(grid)
        for i, j in itertools.product(range(4), range(4)):
            if np.isfinite(grid[i, j]):
                dark = hi > lo and (grid[i, j] - lo) / (hi - lo) < 0.5
                ax.text(j, i, f"{grid[i, j]:.3g}", ha="center", va="center", fontsize=8,
                        color="w" if dark else "k")
        ax.set_xticks(range(4), cols)
        ax.set_yticks(range(4), rows)
        ax.set_xlabel("k3, b level [L/H]")
        ax.set_ylabel("k1, k2 level [L/H]")
        ax.set_title(short[m], fontsize=9)
        fig.colorbar(im, ax=ax, shrink=0.8)
    fig.suptitle("The cases over the coupler's four factors (blank: case not run)",
                 fontsize=10)
    fig.tight_layout()
    path = rep.out / "report_cases_heatmap.png"
    fig.savefig(path)
    plt.close(fig)
    worst = tc.loc[tc["peak tension [kN]"].idxmax(), "case"]
    rep.parts += [
        "<h3 id='cases'>The cases over the four factors</h3>",
        "<p class='note'>Each case sets the recoil stiffness k1, the nonlinear stiffness "
        "k2, the linear stiffness k3 and the damping b at a low (L) or high (H) value "
        "(Table 1's two sets; each case's levels are read from its values, the nearer of "
        "the two). Per case: the "
        "largest tension and compression over all couplers, the largest |acceleration| "
        "of a wagon and the RMS speed error, over the whole run.</p>",
        table_html(tc), csv_table(tc, rep.out, "cases_summary.csv"),
        figure_html(path, "The cases over the four factors: rows k1, k2 and columns k3, b "
                    "at low (L) or high (H); peak tension and compression (kN), largest "
                    "wagon acceleration (m/s²), RMS speed error (m/s). See which factors "
                    f"move each quantity; the largest tension is in case {worst}")]


# (c) the track
def step_lookup(table, x) -> np.ndarray:
    """A piecewise-constant function of position (``[start m, value]`` pieces, the first
    covering everything before it) at positions ``x`` (m)."""
    starts = np.array([p[0] for p in table], dtype=float)
    vals = np.array([p[1] for p in table], dtype=float)
    return vals[np.clip(np.searchsorted(starts, x, side="right") - 1, 0, None)]


def track(rep: Report, ds) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = rep.sc.track
    if tr is None or getattr(tr, "profile_file", None):
        return
    t = ds.time.values
    x = ds.position.values[:, 0]
    grade = step_lookup(tr.gradient, x)
    radius = step_lookup(tr.curve, x)
    curv = np.where(radius != 0.0, 1e3 / np.where(radius != 0.0, np.abs(radius), 1.0), 0.0)
    fig, axes = plt.subplots(3, 1, figsize=(9, 5.6), dpi=90, sharex=True)
    axes[0].plot(t, ds.speed_reference.values, label="speed reference")
    axes[0].plot(t, ds.velocity.values[:, 0], lw=0.9, label="locomotive")
    axes[0].set_ylabel("speed [m/s]")
    axes[0].legend(fontsize=8)
    axes[1].plot(t, 1e3 * grade, color="tab:brown")
    axes[1].set_ylabel("grade [‰, + up]")
    axes[2].plot(t, curv, color="tab:green")
    axes[2].set_ylabel("curvature 1/R [1/km]")
    axes[2].set_xlabel("time [s] (grade and curvature under the locomotive)")
    shown = [p for p in rep.sc.phases if p.start < t[-1]]
    for ax in axes:
        ax.grid(alpha=0.3)
        for p in shown:
            ax.axvspan(p.start, min(p.end, t[-1]), color="0.85", zorder=0)
    for p in shown:
        axes[0].text(0.5 * (p.start + min(p.end, t[-1])), axes[0].get_ylim()[1],
                     p.name.replace("_", " "), ha="center", va="top", fontsize=7)
    fig.tight_layout()
    path = rep.out / "report_track.png"
    fig.savefig(path)
    plt.close(fig)
    rep.parts += [
        "<h3 id='track'>The track and the speed reference</h3>",
        figure_html(path, "The base case's speed reference and the locomotive's speed "
                    "(m/s), the grade (‰) and the curvature (1/km) under the locomotive, "
                    "against time, the phases shaded. See which phase meets the curve "
                    "and which the climb")]


# (d) gear travel
def gear_travel(rep: Report, ds) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ltdsim.results.summary import gear_travel_check

    g = gear_travel_check(ds, rep.sc)
    n = len(g)
    gears = g.gears.to_numpy()
    tg = pd.DataFrame({
        "coupler [1 = behind the locomotive]": np.arange(1, n + 1),
        "gears in series [-]": gears,
        "coupling beyond slack, draft [mm]": 1e3 * g.max_draft_m.to_numpy() * gears,
        "coupling beyond slack, buff [mm]": 1e3 * g.max_buff_m.to_numpy() * gears,
        "per gear, draft [mm]": 1e3 * g.max_draft_m.to_numpy(),
        "per gear, buff [mm]": 1e3 * g.max_buff_m.to_numpy(),
        "gear travel [mm]": 1e3 * g.travel_m.to_numpy(),
        "beyond the travel [mm]": 1e3 * g.excess_m.to_numpy()})
    fig, ax = plt.subplots(figsize=(9, 3.8), dpi=90)
    c = np.arange(1, n + 1)
    w = 0.38
    ax.bar(c - w / 2, tg["per gear, draft [mm]"], w, label="per gear, draft (tension)")
    ax.bar(c + w / 2, tg["per gear, buff [mm]"], w, label="per gear, buff (compression)")
    if (gears > 1).any():
        ax.plot(c, np.maximum(tg["coupling beyond slack, draft [mm]"],
                              tg["coupling beyond slack, buff [mm]"]), "kx",
                label="whole coupling (not compared)")
    ax.step(np.r_[c - 0.5, c[-1] + 0.5], np.r_[tg["gear travel [mm]"],
                                                tg["gear travel [mm]"].iloc[-1]],
            where="post", color="r", ls="--", label="one gear's travel")
    ax.set_xlabel("coupler [1 = behind the locomotive]")
    ax.set_ylabel("deflection beyond the slack [mm]")
    ax.set_xticks(c if n <= 30 else None)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8)
    ax.set_title(f"Gear travel per coupler, case {rep.case}", fontsize=9)
    fig.tight_layout()
    path = rep.out / "report_gear_travel.png"
    fig.savefig(path)
    plt.close(fig)
    # (beyond by more than the check's resolution, as the run's own warning counts them)
    beyond = [int(j) + 1 for j in np.flatnonzero(g.exceeds.to_numpy())]
    k = int(gears[0])
    stated = bool(g.travel_stated.iloc[0])
    rep.parts += [
        "<h3 id='gear-travel'>Gear travel against its limit</h3>",
        "<p class='note'>A coupling holds <code>gears</code> draft gears in series "
        f"(here {k}: " + ("one law per coupling, as the study's Eq. 10 writes it"
                          if k == 1 else "a gear in each wagon end") +
        "). Each gear carries the coupling's force and takes an equal share of its "
        "deflection beyond the slack, so <b>per-gear travel = coupling deflection beyond "
        "the slack / gears</b>; that, not the coupling's, is compared with one gear's "
        "travel of " + (f"{1e3 * g.travel_m.iloc[0]:.0f} mm (the coupler's own)" if stated
                        else f"{1e3 * g.travel_m.iloc[0]:.0f} mm (AAR M-901's 3-1/4 in, the "
                        "scenario giving none)") +
        ". The simulation's kernel and the modal analysis (<a href='#fig8'>Fig. 8</a>) "
        "use the same coupling. Deflections are the recorded samples' largest. "
        + (f"Couplers {html.escape(numbers_text(beyond))} go beyond it."
           if beyond else "No gear goes beyond it.") + "</p>",
        table_html(tg), csv_table(tg, rep.out, "gear_travel.csv"),
        figure_html(path, "Gear travel per coupler: each gear's largest deflection beyond "
                    "its share of the slack in draft and in buff (mm) against one gear's "
                    "travel (red dashed). See the front couplers, which carry the pull of "
                    "the most mass, go furthest")]
