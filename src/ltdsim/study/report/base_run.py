"""The report's base run: is it violent, and whose is it (the study's model or ltdsim's
reconstruction), this run beside the reading ltdsim used before; and the model
readings the run rests on, each with what the alternative gives.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim.study.report.html import (
    csv_table,
    figure_html,
    kn,
    numbers_text,
    table_html,
)
from ltdsim.study.report.page import Report


# the base run (above the study's tables)
def base_run(rep: Report) -> None:
    """Is the base run violent, and whose is it (the study's model or ltdsim's
    reconstruction): this run beside the reading ltdsim used before."""
    dg = rep.results["base"].get("diagnosis")
    if not dg:
        return
    now, old = dg["now"], dg["earlier"]
    loop = dg["closed_loop"]
    t5s = rep.T["table5_phase_norms_LHHL"]
    study_case = rep.case == "LHHL"
    acc_study = max(max(v) for v in t5s["wagon_acceleration_infnorm_m_s2"].values())
    t2s = rep.T["table2_pid_and_rms_error"].get(rep.case, {})

    def damping(which):
        m = loop.get(which)
        return 100.0 * m["damping_ratio"] if m else float("nan")

    nan = float("nan")
    rows = [
        ("RMS speed error over the run [m/s]", now["speed_error_rms_m_s"],
         old["speed_error_rms_m_s"], t2s.get("rms_speed_error_m_s", nan)),
        ("locomotive force swing at cruise, ± [kN]", kn(now["traction_swing_N"]),
         kn(old["traction_swing_N"]), nan),
        ("swing period [s]", now["traction_period_s"], old["traction_period_s"], nan),
        ("lowest closed-loop mode: damping ratio [%]",
         damping(dg["acceleration_of"]),
         damping("train" if dg["acceleration_of"] == "locomotive" else "locomotive"), nan),
        ("largest step of the reference's acceleration [m/s²]", now["reference_corner_m_s2"],
         old["reference_corner_m_s2"], nan),
        ("largest wagon |acceleration| [m/s²]", now["max_wagon_acceleration_m_s2"],
         old["max_wagon_acceleration_m_s2"], acc_study if study_case else nan),
        ("largest gear deflection beyond the slack [mm]",
         1e3 * max(now["max_gear_deflection_m"]), 1e3 * max(old["max_gear_deflection_m"]),
         nan),
        ("coupler 1 peak while accelerating [kN]",
         kn(dg["coupler1_peak_acceleration_N"]["now"]),
         kn(dg["coupler1_peak_acceleration_N"]["earlier"]),
         kn(t5s["coupler_force_infnorm_N"]["acceleration"][0]) if study_case else nan)]
    t = pd.DataFrame([{"run": run, **{q: r[k] for q, *r in rows}}
                      for k, run in enumerate(("this run (ltdsim's reading)",
                                               "the alternative reading", "the study"))])
    travel = 1e3 * float(np.min(now["travel_m"]))
    beyond = now["couplers_beyond_travel"]
    held = now["held_mode_hz"]
    rep.parts += [
        "<h2 id='base-run'>The base run: how violent is it, and why?</h2>",
        "<p>The study calls its controller's output “the desired acceleration of the "
        "locomotive” (§5); ltdsim reads it so, and rounds the reconstructed speed "
        "reference's corners at constant jerk (<a href='#readings'>readings</a>). "
        f"With these readings the cruise is quiet: the locomotive force swings by "
        f"±{kn(now['traction_swing_N']):.0f} kN, and the wagons' lowest mode against a "
        f"locomotive held by the controller ({held:.2f} Hz) keeps "
        f"{damping('locomotive'):.0f} % damping. <b>The alternative reading</b> (the "
        "output taken as the whole train's acceleration, the reference's corners sharp, "
        f"its acceleration jumping by {old['reference_corner_m_s2']:.1f} m/s²) leaves that "
        f"mode {damping('train'):.1f} % damping: the controller then hunts by "
        f"±{kn(old['traction_swing_N']):.0f} kN every {old['traction_period_s']:.1f} s at "
        f"constant speed, wagons accelerate at up to "
        f"{old['max_wagon_acceleration_m_s2']:.0f} m/s² and gears stretch "
        f"{1e3 * max(old['max_gear_deflection_m']):.0f} mm (the table's second row).</p>",
        "<p><b>What stays violent under either reading:</b> with ltdsim's reading of "
        "Eq. 9 (a spring and the viscous term b, no friction hysteresis: "
        "<a href='#readings'>readings</a>) the couplers are nearly undamped, and they are "
        "soft for the traction the study asks: under the pull that accelerates the "
        f"train its gears stretch up to {1e3 * max(now['max_gear_deflection_m']):.0f} mm "
        f"beyond their slack (per gear: the coupling's deflection beyond the slack over "
        f"its {rep.sc.coupler(0).gears} gear{'s' if rep.sc.coupler(0).gears > 1 else ''} "
        "in series, as the modal analysis takes the coupling; "
        "<a href='#gear-travel'>gear travel</a>), where a real friction gear closes solid "
        f"at about {travel:.0f} mm"
        + (f" (couplers {numbers_text(beyond)} go beyond it)" if beyond else "")
        + ", and the slack run-ins at the start and at the deceleration shake the wagons "
        f"at up to {now['max_wagon_acceleration_m_s2']:.1f} m/s² (vehicle "
        f"{now['max_wagon_acceleration_vehicle']}). Much of the pull is the traction's "
        "premise (<a href='#adhesion'>adhesion</a>). The study publishes no gear travel; "
        "with an 83 mm travel and solid closure the front gears would ride solid, so the "
        "scenario keeps none, and the run warns when a gear goes beyond 83 mm.</p>",
        table_html(t), csv_table(t, rep.out, "base_run.csv"),
        figure_html(Path(dg["figure"]), "The base run's mechanism, ltdsim's reading against "
                    "the alternative: the acceleration the speed reference demands, the "
                    "locomotive force and coupler 1's gear deflection. See how the "
                    "alternative's force keeps swinging at constant speed while this "
                    "run's settles")]
    if beyond:
        rep.take.append(
            f"Gears stretch up to {1e3 * max(now['max_gear_deflection_m']):.0f} mm beyond "
            f"their slack (couplers {numbers_text(beyond)} beyond a real gear's "
            f"{travel:.0f} mm travel): under ltdsim's reading of Eq. 9 the study's "
            "couplers are too soft for its traction.")


# readings
def readings(rep: Report) -> None:
    """The model readings this run rests on (ltdsim's, where the study is silent or
    its printed equations are ambiguous), each with what the alternative gives."""
    c = rep.sc.coupler(0)
    items = []
    if c.model == "simplified":
        items.append(
            "<b>Eq. 9's nonlinear stiffness fades with the gear's " +
            ("deflection</b>, <code>k2 e exp(-e/v)</code> with v = "
             f"{c.v_c:g} m, the equation as printed: a spring (energy it takes in "
             "it gives back) plus the damper b, so the coupler cannot create energy. "
             "The alternative, a fade with the deflection <i>rate</i> "
             "(<code>exp(-|de/dt|/v)</code>, v in m/s; key "
             "<code>couplers.default.fade = \"rate\"</code>), returns up to "
             "k2 e&sup2;/2 per cycle when a gear loads fast and unloads slowly: over "
             "this run several couplers then put out more energy than they absorb."
             if c.fade == "deflection" else
             "rate</b> (<code>exp(-|de/dt|/v)</code>, v = "
             f"{c.v_c:g} m/s; <code>fade = \"rate\"</code>, not the default): a law "
             "that can return more energy than it takes (up to k2 e&sup2;/2 per cycle "
             "loaded fast and unloaded slowly); the default, as printed, fades with "
             "the deflection and is passive."))
        items.append("<b>Draft and buff branches.</b> Eq. 9's two branches are read "
                     "as tension (k3, k2) and compression (k1), not as loading and "
                     "unloading: read the other way, every case with k1 &gt; k2 + k3 "
                     "(8 of the 16) would return more energy than it takes each "
                     "cycle.")
    modal = rep.results.get("modal", {})
    tops = [modal[b]["free"][-1] for b in ("buff", "draft") if "free" in modal.get(b, {})]
    top = (f" The simulated train's highest mode is {max(tops):.2f} Hz; two gears in "
           f"series would bring it to {max(tops) / np.sqrt(2):.2f} Hz, below the "
           "3.3 Hz line the study finds in its spectra (§5.2)." if tops else "")
    items.append("<b>One coupling, " + (
        "one gear.</b> The law describes the whole coupling, as the study's Eq. 10 "
        "writes one Eq. 9 per coupling." + top + " With two gears in series "
        "(<code>gears = 2</code>, a gear in each wagon end) every coupling would be "
        "half as stiff and every mode 1/&radic;2 as high." if c.gears == 1 else
        f"{c.gears} gears in series.</b> Each gear carries the coupling's force and "
        "takes half its deflection beyond the slack; the study's Eq. 10 writes one "
        "law per coupling (<code>gears = 1</code>).") +
        " The same coupling is used in the simulation, the modal analysis and the "
        "gear-travel check.")
    alt = rep.results.get("base", {}).get("alternatives") or {}
    cs = pd.DataFrame(rep.results.get("base", {}).get("couplers") or [])
    st = alt.get("stretched_start")
    start = ("<b>Start</b>: couplings " + {
        "neutral": "centred in their slack", "stretched": "stretched to the end of "
        "their slack", "bunched": "bunched"}[rep.sc.initial.couplers] +
        " (the study does not say).")
    if st and len(cs):
        acc = np.asarray(rep.results["base"]["max_abs_acceleration_m_s2"])
        start += (" Started stretched instead, the largest tension is "
                  f"{kn(max(st['max_tension_N'])):.0f} kN (this run "
                  f"{kn(cs.max_tension_N.max()):.0f} kN), the largest compression "
                  f"{kn(max(st['max_compression_N'])):.0f} kN "
                  f"({kn(cs.max_compression_N.max()):.0f} kN) and wagons reach "
                  f"{st['max_wagon_acceleration_m_s2']:.1f} m/s² "
                  f"({acc[1:].max() if acc.size > 1 else acc.max():.1f} m/s²).")
    items.append(start)
    items.append("<b>Speed controller</b>: its output is the locomotive's desired "
                 "acceleration, times the locomotive's mass (the study's words, §5); "
                 "the alternative, the whole train's" + (
                     ", is in <a href='#base-run'>the base run</a>'s table."
                     if rep.results.get("base", {}).get("diagnosis") else
                     ", makes the controller hunt at cruise (the full run's report shows "
                     "it; this run has no cruise to judge)."))
    items.append("<b>Speed profile</b>: the study publishes only its phase times; ltdsim "
                 "reconstructs the reference from them, its corners rounded at constant "
                 "jerk. Every speed error and every force while the speed changes rests "
                 "on it; docs/paper-scenario.md tabulates 30 variants: rounding the start "
                 "over 15 s instead of 10 s alone lowers coupler 1's peak in the first "
                 "10 s from 819 kN to 581 kN.")
    items.append("<b>Stopping</b>: the locomotive's dynamic brake only, through the "
                 "traction curve (the study gives no air-brake parameters); with wagon "
                 "brakes the deceleration's compressions would be lower.")
    names = ("fade", "branches", "gears", "start", "controller", "profile", "stop")
    rep.parts += ["<h2 id='readings'>Model readings this run rests on</h2>",
                   "<p class='note'>Where the study is silent or its printed equations "
                   "can be read more than one way, ltdsim chooses; these are its "
                   "choices, not the study's statements, each with what the "
                   "alternative gives (docs/model.md).</p><ul>" +
                   "".join(f"<li id='reading-{n}'>{i}</li>" for n, i in
                           zip(names[-len(items):] if len(items) < len(names) else names,
                               items)) + "</ul>"]


# methods, accuracy and provenance
def methods(rep: Report) -> None:
    """How the numbers were made: the solver and its step with the peaks' spread at half
    the step, the vehicles' resistance, the phases' windows and the page's making."""
    sc = rep.sc
    s = sc.solver
    alt = rep.results.get("base", {}).get("alternatives") or {}
    rows = []
    for k, v in enumerate(sc.vehicles):
        rows.append({"vehicle [1 = locomotive]": k + 1, "name": v.name,
                     "mass [t]": v.mass / 1e3,
                     "static mass [t]": (v.static_mass or v.mass) / 1e3,
                     "Davis a [kN]": v.davis.a / 1e3, "b [N s/m]": v.davis.b,
                     "c [N s²/m²]": v.davis.c,
                     "resistance at 20 m/s [kN]": (v.davis.a + 20.0 * v.davis.b
                                                   + 400.0 * v.davis.c) / 1e3})
    tv = pd.DataFrame(rows)
    parts = ["<h2 id='methods'>Methods, accuracy and provenance</h2>",
             f"<p><b>Integration.</b> {html.escape(s.method)} with a fixed step of "
             f"{s.dt:g} s, recorded every {s.output_interval:g} s; the peaks are tracked "
             "at every step, not only at the records. Spectra use the records of each "
             "10 s phase with the straight-line trend removed (0.1 Hz resolution); the "
             "modal analysis linearises the train on one branch of the coupler law at "
             "the stiffness the simulation uses.</p>"]
    half = alt.get("half_step")
    if half:
        b = np.array(half["base"]["max_tension_N"] + half["base"]["max_compression_N"])
        h = np.array(half["half"]["max_tension_N"] + half["half"]["max_compression_N"])
        d = np.abs(h - b)
        parts.append(f"<p><b>Accuracy.</b> The base case again at half the step "
                     f"({half['dt_s']:g} s): every coupler's largest tension and "
                     f"compression moves by at most {d.max() / 1e3:.2g} kN "
                     f"({100 * d.max() / max(b.max(), 1.0):.2g} % of the largest); the "
                     "peaks are quoted with that spread (to 1 kN). The 16 cases are "
                     "not re-run at half the step.</p>")
    parts += ["<p><b>Resistance per vehicle</b> (Davis <i>a + b v + c v²</i>, the "
              "study's Appendix I for every vehicle):</p>", table_html(tv),
              csv_table(tv, rep.out, "vehicles.csv")]
    rep.parts += parts
