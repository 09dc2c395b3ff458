"""The one-page report of a long-train run (``ltdsim run --report``): the most loaded
couplers and, for a run with ``[curving]``, the curving-safety section."""

from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim._version import __version__
from ltdsim.results.io import atomic_path
from ltdsim.study.report.html import (
    csv_table,
    figure_html,
    page_html,
    table_html,
)


def worst_vehicles(ds, count: int = 15) -> pd.DataFrame:
    """The ``count`` vehicles of a run with curving indicators whose wheel L/V came
    closest to Nadal's limit, those that lift a wheel (their L/V undefined there) first:
    vehicle number (1 = lead), name, worst L/V of the loaded wheels (-, NaN if none),
    whether a wheel lifts, the time (s) and chainage (m) of the first lift or else of
    the worst L/V, the worst wheelset force (kN) and its share of Prud'homme's
    limit (%), the largest buff force in the vehicle's couplers (kN)."""
    raw = ds.wheel_l_over_v.values
    lifted = np.isposinf(raw)  # a flanging wheel unloaded fully: no L/V, wheel lift
    lv = np.where(np.isfinite(raw), raw, -np.inf)
    h = ds.wheelset_lateral_force.values
    prud = ds.prudhomme_limit.values
    f = ds.coupler_force.values if ds.sizes.get("coupler", 0) else np.zeros((lv.shape[0], 0))
    n = lv.shape[1]
    k = np.argmax(lv, axis=0)
    lift = lifted.any(axis=0)
    first = np.argmax(lifted, axis=0)
    # the vehicles that lift a wheel first (earliest first), then by their worst L/V
    order = np.lexsort((-lv[k, np.arange(n)], np.where(lift, first, lv.shape[0]),
                        ~lift))[:count]
    rows = []
    for i in order:
        ends = [j for j in (i - 1, i) if 0 <= j < f.shape[1]]
        buff = max([-f[:, j].min() for j in ends] + [0.0])
        worst = float(lv[k[i], i]) if np.isfinite(lv[k[i], i]) else math.nan
        at = first[i] if lift[i] else k[i]
        rows.append({"vehicle": int(i) + 1, "name": str(ds.vehicle_name.values[i]),
                     "max L/V [-]": worst,
                     "wheel lift": "yes" if lift[i] else "",
                     "at [s]": float(ds.time.values[at]),
                     "chainage [m]": float(ds.position.values[at, i]),
                     "max wheelset force [kN]": float(h[:, i].max()) / 1e3,
                     "of Prud'homme [%]": 100.0 * float(h[:, i].max()) / float(prud[i]),
                     "max buff at its ends [kN]": buff / 1e3})
    table = pd.DataFrame(rows)
    # (the column only where a wheel lifts)
    return table if lift.any() else table.drop(columns="wheel lift")


def lift_html(c: dict) -> str:
    """The sentence on wheel lift of a :func:`~ltdsim.results.summary.curving_summary`
    ``c`` (a flanging wheel unloaded fully: its L/V is undefined, not infinite), or ""
    where no wheel lifts."""
    if "wheel_lift_vehicle" not in c:
        return ""
    n = c["wheel_lift_vehicles"]
    return (f"<b>Wheel lift:</b> the flanging wheel of vehicle {c['wheel_lift_vehicle']} "
            f"unloads fully at {c['wheel_lift_time_s']:.1f} s, chainage "
            f"{c['wheel_lift_position_m']:.0f} m; its L/V is undefined there, beyond "
            f"Nadal's limit ({c['nadal_limit']:.3f}) and any other. {n} "
            f"vehicle{'s lift' if n > 1 else ' lifts'} a wheel in the run. ")


def curving_section(ds, out: Path, figure: Path | None = None) -> str:
    """The curving-safety section of a report for a long-train run with ``[curving]``:
    the worst places against Nadal's and Prud'homme's limits, the most loaded vehicles
    (also as ``curving_worst.csv`` in ``out``) and, if given, the curving figure."""
    from ltdsim.results.summary import curving_summary

    c = curving_summary(ds)
    if c is None:
        return ""
    worst = worst_vehicles(ds)
    parts = [
        "<h2 id='curving'>Curving safety: coupler angles, lateral forces and L/V</h2>",
        "<p>Quasi-static and kinematic, computed after the run from the recorded "
        "positions, speeds and coupler forces (docs/curving.md): each body the chord "
        "between its bogie centres, each coupler a bar between its pivots, the body held "
        "in lateral and yaw balance by its bogies against the lateral components of its "
        "coupler forces and the unbalanced centrifugal force; the leading wheelset's share "
        "of a bogie's force taken by the flanging wheel.</p>",
        "<p>" + lift_html(c)
        + (f"The worst wheel L/V{' of the loaded wheels' if 'wheel_lift_vehicle' in c else ''}"
           f" is <b>{c['max_l_over_v']:.3f}</b>, "
           f"{100 * c['l_over_v_share_of_limit']:.0f} % of Nadal's limit "
           f"({c['nadal_limit']:.3f}), at vehicle {c['l_over_v_vehicle']} at "
           f"{c['l_over_v_time_s']:.1f} s, chainage {c['l_over_v_position_m']:.0f} m. "
           if c["max_l_over_v"] == c["max_l_over_v"] else "")
        + "The "
        f"largest leading-wheelset lateral force is "
        f"{c['max_wheelset_force_N'] / 1e3:.1f} kN, "
        f"{100 * c['wheelset_force_share_of_limit']:.0f} % of that vehicle's Prud'homme "
        f"limit ({c['prudhomme_limit_N'] / 1e3:.1f} kN), at vehicle "
        f"{c['wheelset_force_vehicle']} at {c['wheelset_force_time_s']:.1f} s."
        + (f" The largest coupler angle is {1e3 * c['max_coupler_angle_rad']:.1f} mrad "
           f"(coupler {c['coupler_angle_coupler']}, {c['coupler_angle_time_s']:.1f} s); the "
           f"lateral coupler components reach {c['max_outward_coupler_force_N'] / 1e3:.1f} kN "
           f"outwards (buff) and {c['max_inward_coupler_force_N'] / 1e3:.1f} kN inwards "
           "(draft)." if "max_coupler_angle_rad" in c else "")
        + (f" {c['couplers_at_stops']} couplers reach their angle stops."
           if c.get("couplers_at_stops") else "") + "</p>",
        "<h3>The vehicles closest to Nadal's limit</h3>",
        table_html(worst), csv_table(worst, Path(out), "curving_worst.csv")]
    if figure is not None and Path(figure).is_file():
        parts.append(figure_html(Path(figure), "Wheel L/V along the train over the run; the "
                                 "worst L/V and wheelset force per vehicle; the lateral "
                                 "coupler force of the three most angled couplers"))
    return "".join(parts)


def write_run_report(ds, out: Path, title: str) -> Path:
    """A one-page report of a long-train run, ``<out>/index.html``: the coupler-force
    peaks and, for a run with ``[curving]``, the curving-safety section with its figure.
    Returns the page's path."""
    from ltdsim.results.summary import coupler_summary, critical_rows

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table = critical_rows(coupler_summary(ds))
    peaks = pd.DataFrame({"coupler": table.index.values + 1,
                          "max tension [kN]": table.max_tension_N.values / 1e3,
                          "tension at [s]": table.t_max_tension_s.values,
                          "max compression [kN]": table.max_compression_N.values / 1e3,
                          "compression at [s]": table.t_max_compression_s.values})
    parts = [f"<h1>{html.escape(title)}</h1>",
             f"<p class='note'>ltdsim {html.escape(__version__)}; {ds.sizes['vehicle']} "
             f"vehicles, {float(ds.time.values[-1]):g} s simulated. Vehicle 1 is the lead; "
             "coupler k joins vehicles k and k + 1; forces + in tension.</p>",
             "<h2 id='couplers'>The most loaded couplers</h2>", table_html(peaks),
             csv_table(peaks, out, "couplers.csv")]
    if "wheel_l_over_v" in ds:
        from ltdsim.results.summary import curving_summary
        from ltdsim.viz.plotting import save_curving

        fig = save_curving(ds, out / "curving.png", summary=curving_summary(ds))
        parts.append(curving_section(ds, out, fig))
    index = out / "index.html"
    with atomic_path(index) as tmp:
        tmp.write_text(page_html(title, "".join(parts)))
    return index
