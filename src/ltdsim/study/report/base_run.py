"""The report's base run: is it violent, and whose is it (the study's model or ltdsim's
reconstruction), this run beside the reading ltdsim used before; and the model
readings the run rests on, each with what the alternative gives.
"""

from __future__ import annotations

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
        ("largest reference acceleration step [m/s²]", now["reference_corner_m_s2"],
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
                      for k, run in enumerate(("this run", "earlier reading",
                                               "the study"))])
    travel = 1e3 * float(np.min(now["travel_m"]))
    beyond = now["couplers_beyond_travel"]
    held = now["held_mode_hz"]
    rep.parts += [
        "<h2 id='base-run'>The base run: is it violent, and whose is it?</h2>",
        "<p>Earlier versions of ltdsim showed this train's speed controller hunting by "
        f"about ±{kn(old['traction_swing_N']):.0f} kN every "
        f"{old['traction_period_s']:.1f} s at constant speed, wagons accelerating at up "
        f"to {old['max_wagon_acceleration_m_s2']:.0f} m/s² and gears stretching "
        f"{1e3 * max(old['max_gear_deflection_m']):.0f} mm. That came from ltdsim's "
        "reconstruction, not from the study: the wagons' lowest mode against a "
        f"locomotive held still ({held:.2f} Hz) was rung by the sharp corners of the "
        "reconstructed speed reference (the demanded acceleration jumped by "
        f"{old['reference_corner_m_s2']:.1f} m/s²) and hardly damped by a controller "
        "whose output was taken as the whole train's acceleration (the lowest "
        f"closed-loop mode then keeps {damping('train'):.1f} % damping). The study calls "
        "the output “the desired acceleration of the locomotive” (§5); read so, the "
        f"same gains damp that mode at {damping('locomotive'):.0f} %, and with the "
        "reference's corners rounded at constant jerk the cruise is quiet "
        f"(±{kn(now['traction_swing_N']):.0f} kN). The 30 readings tried, over all 16 "
        "cases, are in docs/paper-scenario.md.</p>",
        "<p><b>What stays violent is the study's own model.</b> Its couplers are nearly "
        "undamped and too soft for its traction: under the pull that accelerates the "
        f"train its gears stretch up to {1e3 * max(now['max_gear_deflection_m']):.0f} mm "
        f"beyond their slack, where a real friction gear closes solid at about "
        f"{travel:.0f} mm"
        + (f" (couplers {numbers_text(beyond)} go beyond it)" if beyond else "")
        + ", and the slack run-ins at the start and at the deceleration shake the wagons "
        f"at up to {now['max_wagon_acceleration_m_s2']:.1f} m/s² (vehicle "
        f"{now['max_wagon_acceleration_vehicle']}). The study publishes no gear travel; "
        "with an 83 mm travel and solid closure (couplers.*.travel) the front gears "
        "would ride solid, so the scenario keeps none, and <code>ltdsim run</code> warns "
        "when a gear goes beyond 83 mm.</p>",
        table_html(t), csv_table(t, rep.out, "base_run.csv"),
        figure_html(Path(dg["figure"]), "The base run's mechanism: the acceleration the "
                    "speed reference demands, the locomotive force and the first "
                    "coupler's gear deflection, this run and the earlier reading")]
    if beyond:
        rep.take.append(
            f"Gears stretch up to {1e3 * max(now['max_gear_deflection_m']):.0f} mm beyond "
            f"their slack (couplers {numbers_text(beyond)} beyond a real gear's "
            f"{travel:.0f} mm travel): the study's couplers are too soft for its "
            "traction.")


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
    items.append("<b>Start</b>: couplings " + {
        "neutral": "centred in their slack", "stretched": "stretched to the end of "
        "their slack", "bunched": "bunched"}[rep.sc.initial.couplers] +
        " (the study does not say); <b>speed profile</b>: reconstructed from the "
        "study's phase times (docs/paper-scenario.md); <b>stopping</b>: the "
        "locomotive's dynamic brake only (the study gives no air-brake parameters).")
    rep.parts += ["<h2 id='readings'>Model readings this run rests on</h2>",
                   "<p class='note'>Where the study is silent or its printed equations "
                   "can be read more than one way, ltdsim chooses; these are its "
                   "choices, not the study's statements (docs/model.md).</p><ul>" +
                   "".join(f"<li>{i}</li>" for i in items) + "</ul>"]
