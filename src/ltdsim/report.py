"""The study report: one self-contained HTML page, every table also as CSV."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim import __version__
from ltdsim.data import study_tables
from ltdsim.io import atomic_path
from ltdsim.scenario import Scenario

CSS = """
body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;
color:#222;line-height:1.45}
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;font-size:.85em;margin:.8em 0}
td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}th{background:#f2f2f2}
figure{margin:1em 0}img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.85em;color:#555}.note{color:#555;font-size:.9em}
.take{background:#f6f9ff;border-left:4px solid #4a78c2;padding:.6em 1em}
"""


def _csv(df, out: Path, name: str) -> str:
    with atomic_path(out / name) as tmp:
        df.to_csv(tmp, index=False)
    return f'<p class="note">CSV: <a href="{name}">{name}</a></p>'


def _or(value, text):
    """A number, or ``text`` where the metric does not exist (NaN or infinite)."""
    return value if np.isfinite(value) else text


def _diff(a, b):
    return (np.asarray(a, float) - np.asarray(b, float)) if b is not None else np.nan


def write_report(out: Path, results: dict, scenario: Scenario, case: str,
                 scenario_path: Path) -> Path:
    from ltdsim.study import figure_html, table_html

    T = study_tables()
    parts = [f"<h1>Longitudinal train dynamics with a nonlinear friction draft gear: the "
             f"study reproduced by ltdsim {html.escape(__version__)}</h1>",
             f"<p class='note'>Scenario {html.escape(str(scenario_path))}, base case "
             f"{html.escape(case)}; solver {scenario.solver.method} at dt = "
             f"{scenario.solver.dt:g} s, {scenario.solver.n_steps * scenario.solver.dt:g} s "
             f"simulated per case. Study values from the paper's tables (study columns); "
             f"differences are ltdsim minus study. Model readings: docs/model.md, "
             f"docs/draftgear.md; comparisons explained in docs/sweep.md and "
             f"docs/analysis.md.</p>"]
    take = []

    # Table 1 and Fig. 3
    red = results.get("reduction")
    if red:
        simp = T["table1"]["simplified_model"]
        keys = [("damping", "b_N_s_m"), ("k1", "k1_N_m"), ("k2", "k2_N_m"), ("k3", "k3_N_m"),
                ("v_c", "v_c")]
        t1 = pd.DataFrame([{"parameter": k, "fitted to low gear": red["low"][k],
                            "study low": simp[s][0], "fitted to high gear": red["high"][k],
                            "study high": simp[s][1]} for k, s in keys])
        t1.loc[len(t1)] = ["fit %", red["low"]["fit_percent"], np.nan,
                           red["high"]["fit_percent"], np.nan]
        parts += ["<h2>Table 1: simplified coupler fitted to the friction gear</h2>",
                  table_html(t1), _csv(t1, out, "table1_reduction.csv"),
                  "<p class='note'>The friction gears' geometry is ltdsim's choice (the study "
                  "does not publish it), so the fitted stiffnesses follow those gears, not the "
                  "study's unpublished ones (docs/draftgear.md).</p>",
                  figure_html(out / "fig3_reduction_low.png", "Fig. 3a: low parameter set"),
                  figure_html(out / "fig3_reduction_high.png", "Fig. 3b: high parameter set")]

    # Tables 2-4 from the sweep
    sweep = results["sweep"]
    rows2, rows3, rows4 = [], [], []
    for name, rec in sweep.items():
        if rec.get("status") != "ok":
            rows2.append({"case": name, "status": rec.get("status"), "error": rec.get("error")})
            continue
        sc = scenario.cases.get(name, {})
        t2 = T["table2_pid_and_rms_error"].get(name, {})
        rms = rec["summary"]["rms_speed_error_m_s"]
        rows2.append({"case": name, "kp": sc.get("driver.pid.kp"), "kd": sc.get("driver.pid.kd"),
                      "ki": sc.get("driver.pid.ki"), "RMS speed error m/s": rms,
                      "study": t2.get("rms_speed_error_m_s"),
                      "difference": _diff(rms, t2.get("rms_speed_error_m_s"))})
        sid = rec.get("sysid")
        if sid:
            t3 = T["table3_system_identification"].get(name, {})
            rows3.append({"case": name, "FPE": sid["fpe"], "MSE": sid["mse"],
                          "fit % (10 ms, simulation)": sid["fit_percent"],
                          "one-step prediction fit % (record dt)":
                              sid["prediction_fit_percent_record_dt"],
                          "study fit %": t3.get("fit_percent"), "evaluations": sid["evaluations"],
                          "cost": sid["cost"], "norm of step": sid["norm_of_step"],
                          "first-order optimality": sid["first_order_optimality"]})
            st = sid["step"]
            t4 = T["table4_step_response"].get(name, {})
            rows4.append({"case": name, "rise s": _or(st["RiseTime"], "no rise"),
                          "study rise s": t4.get("rise_time_s"),
                          "settling s": _or(st["SettlingTime"], "not settled"),
                          "study settling s": t4.get("settling_time_s"),
                          "overshoot %": st["Overshoot"], "study overshoot %":
                              t4.get("overshoot_percent"),
                          "overshoot difference": _or(float(_diff(st["Overshoot"], t4.get(
                              "overshoot_percent"))), "n/a"),
                          "peak": st["Peak"], "study peak": t4.get("peak"),
                          "peak time s": st["PeakTime"], "settling min": st["SettlingMin"],
                          "settling max": st["SettlingMax"],
                          "ramp error": _or(sid["ramp_error"], "unbounded (DC gain not 1)")})
    t2 = pd.DataFrame(rows2)
    parts += ["<h2>Table 2: PID gains and RMS speed error per case</h2>", table_html(t2),
              _csv(t2, out, "table2_speed_error.csv"),
              "<p class='note'>The reference speed profile is a reconstruction "
              "(docs/paper-scenario.md); its 0.8 m/s² start saturates traction briefly, which "
              "the study's unpublished profile may not.</p>",
              figure_html(out / "fig4_speed_tracking.png",
                          f"Fig. 4: speed tracking, error, traction and coupler forces ({case})")]
    ok = t2[t2.get("RMS speed error m/s", pd.Series(dtype=float)).notna()] if len(t2) else t2
    if len(ok) and "RMS speed error m/s" in ok:
        best = ok.loc[ok["RMS speed error m/s"].astype(float).idxmin(), "case"]
        take.append(f"Best speed tracking: case <b>{html.escape(str(best))}</b> (lowest RMS "
                    "speed error).")
    if rows3:
        t3 = pd.DataFrame(rows3)
        parts += ["<h2>Table 3: transfer-function identification (locomotive force to first "
                  "wagon acceleration, 4 poles, 3 zeros)</h2>", table_html(t3),
                  _csv(t3, out, "table3_identification.csv"),
                  "<p class='note'>The study's ~99 % matches the one-step-ahead prediction fit; "
                  "judged by simulation from the force alone a 4th-order linear model explains "
                  "far less of this nonlinear train (docs/analysis.md).</p>"]
        t4 = pd.DataFrame(rows4)
        parts += ["<h2>Table 4: step and ramp response of the identified models</h2>",
                  table_html(t4), _csv(t4, out, "table4_step_response.csv"),
                  "<p class='note'>ltdsim identifies at 10 ms; the study's models (Ts = 1e-4 s) "
                  "settle within a few samples, so its times in seconds are not comparable; its "
                  "overshoot and peak are reproduced from its own Appendix II models within 1.6 "
                  "points (docs/analysis.md). The identified step response of acceleration to "
                  "force has a tiny final value (about 1/mass), which inflates the overshoot "
                  "percentage of some models.</p>"]
        from ltdsim.response import rank_responses

        metrics = {r["case"]: {"Overshoot": r["overshoot %"], "SettlingTime": r["settling s"],
                               "RiseTime": r["rise s"]} for r in rows4
                   if all(isinstance(r[k], float) and np.isfinite(r[k])
                          for k in ("overshoot %", "settling s", "rise s"))}
        if metrics:
            take.append(f"Fastest response with least overshoot (identified models): case "
                        f"<b>{html.escape(rank_responses(metrics)[0])}</b>.")

    # Table 5, Fig. 5-7
    base = results["base"]
    phases = base["phases"]
    norms = base["norms"]
    t5 = []
    t5_study = T["table5_phase_norms_LHHL"]
    for k, ph in enumerate(phases):
        rms = norms["coupler_force_rms"][k]
        inf = norms["coupler_force_infnorm"][k]
        for j in range(len(rms)):
            row = {"phase": ph, "coupler": j, "RMS kN": rms[j] / 1e3, "inf-norm kN": inf[j] / 1e3}
            if case == "LHHL" and ph in t5_study["coupler_force_2norm_N"]:
                row["study RMS kN"] = t5_study["coupler_force_2norm_N"][ph][j] / np.sqrt(1e5) / 1e3
                row["study inf-norm kN"] = t5_study["coupler_force_infnorm_N"][ph][j] / 1e3
                row["RMS ratio ltdsim/study"] = row["RMS kN"] / row["study RMS kN"]
            t5.append(row)
    t5 = pd.DataFrame(t5)
    parts += [f"<h2>Table 5: coupler force norms per phase ({html.escape(case)})</h2>",
              table_html(t5), _csv(t5, out, "table5_phase_norms.csv"),
              "<p class='note'>RMS = 2-norm / sqrt(samples), comparable across sampling rates "
              "(the study samples at 10 kHz). The study's coupler forces are about a tenth of "
              "what its own locomotive force must put through the first coupler "
              "(docs/sweep.md).</p>"]
    ranking = pd.DataFrame(base["ranking"])
    top = ranking[ranking["rank"] == 1]
    take.append("Critical coupler per phase (largest RMS force): " + ", ".join(
        f"{html.escape(str(r.phase))}: coupler {r.coupler}" for r in top.itertuples()) + ".")
    tc = pd.DataFrame(base["traction_check"])
    tc["first_time_over_s"] = [_or(v, "never") for v in tc["first_time_over_s"]]
    parts += ["<h3>Traction-curve check</h3>", table_html(tc), _csv(tc, out, "traction_check.csv"),
              figure_html(out / "fig5_relative_motion.png",
                          "Fig. 5: position and velocity of each vehicle relative to the lead"),
              figure_html(out / "fig6_forces.png", "Fig. 6: traction and coupler forces per phase"),
              figure_html(out / "fig7_traction_curve.png",
                          "Fig. 7: traction against speed under the traction curve")]
    over = int(tc.loc[tc.phase == "whole run", "samples_demand_over_adhesion"].iloc[0])
    take.append(f"Traction never exceeded adhesion; the demand exceeded it in {over} samples "
                "(wheel-slip risk).")

    # Modal (Fig. 8)
    modal = results["modal"]
    mrows = []
    bands = T["figure8_modal_bands"]
    for which, study_band in (("low", bands["low_stiffness_k1_Hz"]),
                              ("high", bands["high_stiffness_k2_plus_k3_Hz"])):
        m = modal.get(which, {})
        if "free" in m:
            f = np.array(m["free"])
            h = np.array(m["held"])
            mrows.append({"stiffness": which, "free train, Hz": f"{f[1]:.2f}-{f[-1]:.2f}",
                          "lead held, Hz": f"{h[0]:.2f}-{h[-1]:.2f}",
                          "study Fig. 8, Hz": f"{study_band[0]}-{study_band[1]}"})
    if mrows:
        tm = pd.DataFrame(mrows)
        parts += ["<h2>Fig. 8: natural frequencies and mode shapes</h2>", table_html(tm),
                  _csv(tm, out, "modal_bands.csv")]
        parts += [figure_html(p, f"Fig. 8: mode shapes, {p.stem.split('_')[-1]} stiffness")
                  for p in (out / "fig8_modes_low.png", out / "fig8_modes_high.png") if p.is_file()]
        allf = np.concatenate([np.array(modal[w]["held"] + modal[w]["free"][1:])
                               for w in ("low", "high") if "free" in modal.get(w, {})])
        take.append(f"Frequency band to keep clear: {allf.min():.2f}-{allf.max():.2f} Hz (the "
                    "train's longitudinal modes; excitation there, e.g. from traction control, "
                    "rings the couplers).")

    # Tables 6-7, Fig. 9
    sp = pd.DataFrame(base["spectra"])
    if len(sp):
        t7s = T["table7_spectral_max_rms_N"]
        t6s = T["table6_spectral_peaks"]

        def study7(r, k):
            v = t7s.get(r.phase, {}).get(str(r.coupler + 1))
            return v[k] / 1e3 if v else np.nan

        sp["max kN"] = sp.pop("max_N") / 1e3
        sp["band RMS kN"] = sp.pop("band_rms_N") / 1e3
        sp["study max kN"] = [study7(r, 0) for r in sp.itertuples()]
        sp["study RMS kN"] = [study7(r, 1) for r in sp.itertuples()]
        sp["max ratio ltdsim/study"] = sp["max kN"] / sp["study max kN"]
        sp["study peaks (Table 6)"] = [t6s.get(r.phase, {}).get(str(r.coupler + 1), "")
                                       for r in sp.itertuples()]
        sp = sp.fillna("")
        parts += ["<h2>Tables 6-7: coupler force spectra per phase (0-10 Hz)</h2>",
                  table_html(sp), _csv(sp, out, "tables6_7_spectra.csv"),
                  "<p class='note'>Peaks are matched to the nearest natural frequency of the "
                  "train with the lead held by the speed controller. Coupler indices count "
                  "from 0 (the study's coupler 1 is ltdsim's 0). The magnitudes differ from "
                  "the study's by the same factor as Table 5 and an unstated spectrum "
                  "scaling; the peak frequencies are the comparable part (docs/sweep.md).</p>",
                  figure_html(out / "spectra_per_phase.png", "Fig. 9a: spectra per phase"),
                  figure_html(out / "spectrogram.png", "Fig. 9b: time-frequency map")]

    page = (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>ltdsim study report</title><style>{CSS}</style></head><body>"
            + "".join(parts[:2])
            + "<div class='take'><b>What to take away</b><ul>"
            + "".join(f"<li>{t}</li>" for t in take) + "</ul></div>"
            + "".join(parts[2:]) + "</body></html>")
    index = out / "index.html"
    with atomic_path(index) as tmp:
        tmp.write_text(page)
    return index
