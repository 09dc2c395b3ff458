"""The report's phase norms (study Table 5, Fig. 5-7): the critical couplers, the other
norms, Newton's check of the accelerations and the traction against adhesion.
"""

from __future__ import annotations

import html

import numpy as np
import pandas as pd

from ltdsim.physics.drive.traction import adhesion_limit
from ltdsim.study.report.html import (
    csv_table,
    figure_html,
    kn,
    number_or,
    numbers_text,
    table_html,
)
from ltdsim.study.report.page import Report


# Table 5, Fig. 5-7
def phases(rep: Report) -> None:
    base = rep.results["base"]
    phases, norms = base["phases"], base["norms"]
    t5s = rep.T["table5_phase_norms_LHHL"]
    study_case = rep.case == "LHHL"
    n_study = 1e5  # the study's samples per 10 s phase at 10 kHz
    rows = []
    for k, ph in enumerate(phases):
        rms, peak = norms["coupler_force_rms"][k], norms["coupler_force_infnorm"][k]
        for j in range(len(rms)):
            row = {"phase": ph, "coupler [1 = behind the locomotive]": j + 1,
                   "ltdsim RMS [kN]": kn(rms[j]), "study RMS [kN]": float("nan"),
                   "ltdsim peak |force| [kN]": kn(peak[j]),
                   "study peak |force| [kN]": float("nan")}
            if study_case and ph in t5s["coupler_force_2norm_N"] \
                    and j < len(t5s["coupler_force_2norm_N"][ph]):
                row["study RMS [kN]"] = kn(t5s["coupler_force_2norm_N"][ph][j]
                                            / np.sqrt(n_study))
                row["study peak |force| [kN]"] = kn(t5s["coupler_force_infnorm_N"][ph][j])
            row["peak ratio ltdsim / study [-]"] = (row["ltdsim peak |force| [kN]"]
                                                    / row["study peak |force| [kN]"])
            rows.append(row)
    t5 = pd.DataFrame(rows)
    rep.parts += [
        f"<h2 id='table5'>Table 5: coupler forces per phase, case {html.escape(rep.case)}"
        "</h2>",
        "<p class='note'>RMS = 2-norm / √samples, which compares across sampling rates "
        "(the study samples at 10 kHz, ltdsim records at 1 kHz); peak = the infinity "
        "norm, the largest |force| in the phase.</p>",
        table_html(t5), csv_table(t5, rep.out, "table5_phase_norms.csv")]
    cs = pd.DataFrame(base["couplers"])
    if len(cs):
        jt, jc = cs.max_tension_N.idxmax(), cs.max_compression_N.idxmax()
        acc = np.asarray(base["max_abs_acceleration_m_s2"])
        rep.take.append(
            f"Largest coupler forces in case {html.escape(rep.case)}: "
            f"{kn(cs.max_tension_N[jt]):.0f} kN tension (coupler {jt + 1} at "
            f"{cs.t_max_tension_s[jt]:.1f} s) and {kn(cs.max_compression_N[jc]):.0f} kN "
            f"compression (coupler {jc + 1} at {cs.t_max_compression_s[jc]:.1f} s); "
            f"wagons reach {acc[1:].max() if acc.size > 1 else acc.max():.1f} m/s².")
    _critical(rep, phases, base)
    _other_norms(rep, phases, norms, t5s if study_case else None, n_study)
    _traction(rep, base)
    rep.parts += [
        figure_html(rep.out / "fig5_relative_motion.png",
                    "Fig. 5: position (left) and velocity (right, a map of vehicle against "
                    "time) of each vehicle relative to the locomotive, per phase. See the "
                    "slack run out down the train in the first seconds and run in at "
                    "the deceleration (diagonal bands: a wave travelling along the "
                    "train), and the cruise phases' small ringing"),
        figure_html(rep.out / "fig6_forces.png",
                    "Fig. 6: locomotive force and coupler forces per phase. See coupler 1 "
                    "carry the most and the forces ring after each change of traction"),
        figure_html(rep.out / "fig7_traction_curve.png",
                    "Fig. 7: locomotive force against speed under the traction curve, each "
                    "panel's speed axis spanning its phase. See the force stay under the "
                    "study's adhesion limit (dotted) but far above the adhesion of the "
                    "locomotive's own weight (red) while accelerating and braking")]
    if study_case:
        _newton_check(rep, phases, norms, t5s, n_study)


def _critical(rep: Report, phases, base) -> None:
    t5s = rep.T["table5_phase_norms_LHHL"]
    study_case = rep.case == "LHHL"

    def top(records):
        return {r["phase"]: r["coupler"] + 1 for r in records if r["rank"] == 1}

    peak, rms = top(base["ranking_peak"]), top(base["ranking_rms"])
    rows, agree, total = [], 0, 0
    for ph in phases:
        row = {"phase": ph, "ltdsim, by peak [coupler]": peak.get(ph),
               "study, by peak [coupler]": float("nan"),
               "ltdsim, by RMS [coupler]": rms.get(ph),
               "study, by RMS [coupler]": float("nan")}
        if study_case and ph in t5s["coupler_force_infnorm_N"]:
            row["study, by peak [coupler]"] = int(np.argmax(
                t5s["coupler_force_infnorm_N"][ph])) + 1
            row["study, by RMS [coupler]"] = int(np.argmax(
                t5s["coupler_force_2norm_N"][ph])) + 1
            for m in ("peak", "RMS"):
                total += 1
                agree += row[f"ltdsim, by {m} [coupler]"] == row[f"study, by {m} [coupler]"]
        rows.append(row)
    tc = pd.DataFrame(rows)
    rep.parts += [
        "<h3>Critical couplers</h3>",
        "<p class='note'>A coupler is <i>critical</i> in a phase when it carries the "
        "largest force there. Two measures, both shown everywhere: by <b>peak</b> (the "
        "largest |force|, what breaks a coupler) and by <b>RMS</b> (the sustained load, "
        "what tires it). The study reads both from its Table 5.</p>",
        table_html(tc), csv_table(tc, rep.out, "critical_couplers.csv")]
    ours = sorted(set(peak.values()) | set(rms.values()))
    study_set = sorted(set(tc["study, by peak [coupler]"].dropna().astype(int))
                       | set(tc["study, by RMS [coupler]"].dropna().astype(int)))
    rep.take.append("Critical couplers (largest force in a phase, by peak or by RMS): "
                     f"<b>{numbers_text(ours)}</b>; by peak " + ", ".join(
                         f"{ph.replace('_', ' ')} {c}" for ph, c in peak.items())
                     + "; by RMS " + ", ".join(
                         f"{ph.replace('_', ' ')} {c}" for ph, c in rms.items())
                     + (f" (the study: {numbers_text(study_set)}; "
                        + _mass_behind(rep, sorted(set(ours) | set(study_set))) + ")."
                        if study_set else "."))
    if total:
        rep.claim("Couplers 1, 8 and 9 are critical (§5.1, Table 5)",
                   f"{numbers_text(study_set)} (largest by peak or RMS in a phase)",
                   f"{numbers_text(ours)}",
                   "yes" if agree == total else ("partly" if agree else "no"),
                   f"{agree} of {total} phase-and-measure choices agree (table under "
                   "Table 5); " + _mass_behind(rep, study_set))


def _mass_behind(rep: Report, couplers) -> str:
    """Newton's reason why the front couplers carry the sustained load: the mass each
    coupler pulls (t)."""
    m = np.array([v.mass for v in rep.sc.vehicles])
    behind = {c: m[c:].sum() / 1e3 for c in couplers if 1 <= c < m.size}
    return ("a coupler's steady pull is set by the mass behind it: " + ", ".join(
        f"{w:.0f} t behind coupler {c}" for c, w in sorted(behind.items())))


def _other_norms(rep: Report, phases, norms, t5s, n_study) -> None:
    rows = []
    for k, ph in enumerate(phases):
        acc = np.asarray(norms["acceleration_infnorm"][k])
        row = {"phase": ph,
               "ltdsim largest wagon |acceleration| [m/s²]": float(acc[1:].max())
               if acc.size > 1 else float("nan"),
               "study [m/s²]": float("nan"),
               "ltdsim locomotive force RMS [kN]": kn(norms["traction_force_rms"][k]),
               "study RMS [kN]": float("nan"),
               "ltdsim locomotive force peak [kN]": kn(norms["traction_force_infnorm"][k]),
               "study peak [kN]": float("nan"),
               "ltdsim speed error RMS [m/s]": norms["speed_error_rms"][k],
               "study speed error RMS [m/s]": float("nan")}
        if t5s is not None and ph in t5s["wagon_acceleration_infnorm_m_s2"]:
            row["study [m/s²]"] = max(t5s["wagon_acceleration_infnorm_m_s2"][ph])
            row["study RMS [kN]"] = kn(t5s["locomotive_force_2norm_N"][ph] / np.sqrt(n_study))
            row["study peak [kN]"] = kn(t5s["locomotive_force_infnorm_N"][ph])
            row["study speed error RMS [m/s]"] = (t5s["speed_error_2norm_m_s"][ph]
                                                  / np.sqrt(n_study))
        rows.append(row)
    t = pd.DataFrame(rows)
    rep.parts += ["<h3>Wagon accelerations, locomotive force and speed error per "
                   "phase</h3>", table_html(t), csv_table(t, rep.out, "table5_other_norms.csv")]


def _newton_check(rep: Report, phases, norms, t5s, n_study) -> None:
    """The study's coupler 1 against what its own locomotive force and wagon
    accelerations require by Newton's law (acceleration phase)."""
    ph = "acceleration"
    if ph not in phases or ph not in t5s["coupler_force_infnorm_N"]:
        return
    k = phases.index(ph)
    masses = [v.mass for v in rep.sc.vehicles]
    behind = sum(masses[1:])
    share = behind / sum(masses)
    study_peak = kn(t5s["coupler_force_infnorm_N"][ph][0])
    study_acc = min(t5s["wagon_acceleration_infnorm_m_s2"][ph])
    need_peak = behind * study_acc / 1e3
    study_rms = kn(t5s["coupler_force_2norm_N"][ph][0] / np.sqrt(n_study))
    loco_rms = kn(t5s["locomotive_force_2norm_N"][ph] / np.sqrt(n_study))
    ours = kn(norms["coupler_force_infnorm"][k][0])
    rep.causes.append(
        f"<b>The study's coupler forces contradict its own accelerations.</b> Its "
        f"{len(masses) - 1} wagons ({behind / 1e3:.0f} t) all reach {study_acc:.2f} m/s² or "
        f"more while accelerating, which takes {need_peak:.0f} kN through coupler 1, yet its "
        f"Table 5 gives coupler 1 a peak of {study_peak:.0f} kN and an RMS of "
        f"{study_rms:.0f} kN under a locomotive force of {loco_rms:.0f} kN RMS. No model "
        "obeying Newton's law reproduces both; ltdsim's coupler 1 peaks at "
        f"{ours:.0f} kN (<a href='#table5'>Table 5</a>).")
    rep.claim("Coupler 1 in the acceleration phase (Table 5)",
               f"peak {study_peak:.0f} kN, RMS {study_rms:.0f} kN",
               f"peak {ours:.0f} kN, RMS {kn(norms['coupler_force_rms'][k][0]):.0f} kN",
               "no",
               f"the study's own numbers break Newton's law: its {len(masses) - 1} wagons "
               f"({behind / 1e3:.0f} t) all reach {study_acc:.2f} m/s² or more, which takes "
               f"{need_peak:.0f} kN through coupler 1 when they accelerate together, and "
               f"its locomotive force of {loco_rms:.0f} kN RMS puts about "
               f"{share * loco_rms:.0f} kN RMS through coupler 1 ({share:.0%}, the "
               f"wagons' share of the mass), not {study_rms:.0f} kN")


def _traction(rep: Report, base) -> None:
    tc = pd.DataFrame(base["traction_check"]).rename(columns={
        "phase": "phase",
        "max_traction_over_adhesion": "largest |traction| / the scenario's adhesion limit [-]",
        "max_demand_over_adhesion": "largest demand / that limit [-]",
        "samples_demand_over_adhesion": "samples with demand above it [-]",
        "first_time_over_s": "first time demand above it [s]",
        "max_traction_over_own_adhesion":
            "largest |traction| / the locomotive's own adhesion limit [-]",
        "own_weight_adhesion_coefficient":
            "adhesion coefficient that asks of the locomotive's weight [-]"})
    col = "first time demand above it [s]"
    tc[col] = [number_or(v, "never") for v in tc[col]]
    t = rep.sc.traction
    own_mass = sum(v.static_mass or v.mass for v in rep.sc.vehicles if v.powered)
    g = rep.sc.track.gravity
    # the study's Curtius-Kniffler coefficient at standstill (Eq. 15)
    mu0 = float(adhesion_limit(0.0, 1.0, 1.0))
    rep.parts += ["<h3 id='adhesion'>Traction against the adhesion limit</h3>",
                   "<p class='note'>The demand is the force the speed controller asks "
                   "for; the traction curve (adhesion, force and power limits) lets "
                   "through at most the limit, so a demand above adhesion marks a "
                   "wheel-slip risk, not slip itself. The scenario's adhesion rests on "
                   f"{t.adhesion_mass / 1e3:.1f} t; the locomotive's own weight is "
                   f"{own_mass / 1e3:.1f} t (the last two columns).</p>",
                   table_html(tc), csv_table(tc, rep.out, "traction_check.csv")]
    whole = tc[tc.phase == "whole run"].iloc[0]
    ratio = whole["largest |traction| / the scenario's adhesion limit [-]"]
    own_ratio = whole["largest |traction| / the locomotive's own adhesion limit [-]"]
    mu = whole["adhesion coefficient that asks of the locomotive's weight [-]"]
    over = int(whole["samples with demand above it [-]"])
    premise = abs(own_mass / t.adhesion_mass - 1.0) > 0.02 and own_ratio > 1.0
    if not premise:
        rep.take.append(f"Traction stayed at or below {ratio:.0%} of the adhesion limit; "
                        f"the demand exceeded it in {over} samples (wheel-slip risk).")
        rep.claim("Traction stays under the adhesion curve in every phase (§5.1, Fig. 7)",
                  "never above", f"at most {ratio:.0%} of the limit",
                  "yes" if ratio <= 1.0 + 1e-9 else "no",
                  f"the demand exceeded adhesion in {over} samples (limited by the curve)")
        return
    limit0 = own_mass * g * mu0
    top = float(np.max(np.abs(t.max_force)))
    alt = (base.get("alternatives") or {}).get("own_adhesion")
    explain = ""
    if alt:
        k = alt["phases"].index("acceleration") if "acceleration" in alt["phases"] else 0
        explain = (f" Limited by the locomotive's own adhesion, the same run pulls "
                   f"{kn(alt['coupler1_peak_N'][k]):.0f} kN through coupler 1 in the "
                   f"{alt['phases'][k]} phase (this run "
                   f"{kn(base['norms']['coupler_force_infnorm'][k][0]):.0f} kN) and its "
                   f"largest traction is {kn(alt['max_traction_N']):.0f} kN, but the train "
                   "no longer follows the speed reference (RMS speed error "
                   f"{alt['rms_speed_error_m_s']:.1f} m/s): the study's traction, and with "
                   "it most of ltdsim's coupler forces, needs about five locomotives' "
                   "adhesion.")
    text = (f"<b>The study's traction is not possible for its locomotive.</b> The study "
            f"takes the adhesion on the whole train's static mass ({t.adhesion_mass / 1e3:.0f}"
            f" t, {kn(t.adhesion_mass * g * mu0):.0f} kN at standstill); on the "
            f"{own_mass / 1e3:.1f} t locomotive's own weight the limit is "
            f"{kn(limit0):.0f} kN, while its force limit is {kn(top):.0f} kN and this run "
            f"asks up to {own_ratio:.1f} times the limit, an adhesion coefficient of "
            f"{mu:.2f} (the study's own curve gives {mu0:.2f} at standstill).{explain} "
            "<a href='#adhesion'>Traction against adhesion</a>, Fig. 7.")
    rep.causes.insert(0, text)
    rep.take.append(f"Traction stayed under the study's adhesion limit ({ratio:.0%} of it) "
                    f"but reached {own_ratio:.1f} times the adhesion of the locomotive's "
                    f"own {own_mass / 1e3:.1f} t (coefficient {mu:.2f}): a real locomotive "
                    "would slip.")
    rep.claim("Traction stays under the adhesion curve in every phase (§5.1, Fig. 7)",
              "never above", f"at most {ratio:.0%} of the study's limit; "
              f"{own_ratio:.1f} times the locomotive's own", "no",
              f"the study's limit rests on the whole train's {t.adhesion_mass / 1e3:.0f} t; "
              f"on the locomotive's {own_mass / 1e3:.1f} t the force asked means an "
              f"adhesion coefficient of {mu:.2f}: the premise is impossible")
