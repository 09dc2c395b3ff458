"""The report's frequency analysis: the simulated train's modes (study Fig. 8) and the
coupler-force spectra per phase (Tables 6-7, Fig. 9).
"""

from __future__ import annotations

import html

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


# Fig. 8
def modal(rep: Report) -> None:
    modal = rep.results["modal"]
    bands = rep.T["figure8_modal_bands"]
    # the study's "low" is its k1 case (the buff branch), its "high" k2 + k3 (draft)
    study = {"buff": bands["low_stiffness_k1_Hz"],
             "draft": bands["high_stiffness_k2_plus_k3_Hz"]}
    label = {"buff": "k1", "draft": "k2 + k3"}
    name = {"buff": "buff (compression), the study's \"low\"",
            "draft": "draft (tension), the study's \"high\""}
    gears = modal.get("gears", 1)
    rows = []
    for branch in ("buff", "draft"):
        m = modal.get(branch, {})
        if "free" not in m:
            continue
        f, h = np.array(m["free"]), np.array(m["held"])
        rows.append({"branch": f"{name[branch]}: {label[branch]} of case {rep.case}",
                     "coupling stiffness [MN/m]": m["coupling_stiffness_N_m"] / 1e6,
                     "lowest [Hz]": f[1], "highest [Hz]": f[-1],
                     "locomotive held: lowest [Hz]": h[0], "held: highest [Hz]": h[-1],
                     "study Fig. 8: lowest [Hz]": study[branch][0],
                     "study: highest [Hz]": study[branch][1]})
    for branch, pick in (("buff", "the softest k1"), ("draft", "the stiffest k2 + k3")):
        w = modal.get(f"widest_{branch}")
        if w:
            rows.append({"branch": f"{name[branch]}: {pick} of all cases",
                         "coupling stiffness [MN/m]": w["coupling_stiffness_N_m"] / 1e6,
                         "lowest [Hz]": w["band_hz"][0], "highest [Hz]": w["band_hz"][1],
                         "locomotive held: lowest [Hz]": float("nan"),
                         "held: highest [Hz]": float("nan"),
                         "study Fig. 8: lowest [Hz]": study[branch][0],
                         "study: highest [Hz]": study[branch][1]})
    if not rows:
        return
    tm = pd.DataFrame(rows)
    note = ("<p class='note'>The train linearised with every coupling on one branch of "
            "its law, at the stiffness the simulation uses (" +
            ("one gear per coupling: the simplified coupler's law is the coupling's, as "
             "the study's Eq. 10 writes it" if gears == 1 else
             f"{gears} gears in series per coupling") +
            "; <a href='#readings'>ltdsim's readings</a>). \"Free\": the train on its "
            "own (one rigid-body mode at 0 Hz, not listed); \"held\": the locomotive's "
            "speed held by the controller.")
    lo, hi = modal.get("buff", {}), modal.get("draft", {})
    if "free" in lo and "free" in hi and \
            hi["coupling_stiffness_N_m"] < lo["coupling_stiffness_N_m"]:
        note += (f" In case {html.escape(rep.case)} k2 + k3 is below k1, so the draft "
                 "branch (the study's \"high\") gives the lower frequencies.")
    rep.parts += ["<h2 id='fig8'>Fig. 8: natural frequencies and mode shapes</h2>",
                   note + "</p>", table_html(tm), csv_table(tm, rep.out, "modal_bands.csv")]
    fig = rep.out / "fig8_modes.png"
    if fig.is_file():
        rep.parts.append(figure_html(
            fig, f"Fig. 8: mode shapes of the free train, case {rep.case}, on both "
            "branches (solid buff, dashed draft). See that the shapes coincide: every "
            "coupling has the same stiffness, so a branch changes only the frequencies, "
            "by the square root of the stiffness ratio; mode n has n - 1 nodes along "
            "the train"))
    for branch in ("draft", "buff"):
        m = modal.get(branch, {})
        if "free" not in m:
            continue
        allf = np.array(m["held"] + m["free"][1:])
        rep.take.append(f"Frequency band to keep clear on the {branch} branch: "
                         f"{allf.min():.2f}-{allf.max():.2f} Hz in case "
                         f"{html.escape(rep.case)} (the simulated train's longitudinal "
                         "modes with every coupling in " +
                         ("tension" if branch == "draft" else "compression") +
                         ", free or held; excitation there rings the couplers); the "
                         f"study's Fig. 8 gives {study[branch][0]}-{study[branch][1]} Hz "
                         f"for {label[branch]}.")
    for branch in ("buff", "draft"):
        w = modal.get(f"widest_{branch}")
        if not w:
            continue
        (a, b), (sa, sb) = w["band_hz"], study[branch]
        ok = abs(a / sa - 1) <= 0.1 and abs(b / sb - 1) <= 0.1
        why = (f"{label[branch]} = {w['coupling_stiffness_N_m'] / 1e6:.2f} MN/m per "
               f"coupling, the {'softest' if branch == 'buff' else 'stiffest'} of the "
               "cases; the study does not say which case its Fig. 8 shows")
        if not ok:
            r = (sb / b) ** 2
            why += (f"; {sb} Hz needs couplings {r:.1f} times stiffer" if r > 1 else
                    f"; {sb} Hz needs couplings {1 / r:.1f} times softer")
        rep.claim(f"Modal band on the {branch} branch, {label[branch]} (§5.2, Fig. 8)",
                   f"{sa}-{sb} Hz", f"{a:.2f}-{b:.2f} Hz", "yes" if ok else "no", why)


# Tables 6-7, Fig. 9
def spectra(rep: Report) -> None:
    base = rep.results["base"]
    sp = pd.DataFrame(base["spectra"])
    if sp.empty:
        return
    t7s, t6s = rep.T["table7_spectral_max_rms_N"], rep.T["table6_spectral_peaks"]
    study_case = rep.case == "LHHL"
    rows6, rows7 = [], []
    for r in sp.itertuples():
        num = r.coupler + 1
        s7 = t7s.get(r.phase, {}).get(str(num)) if study_case else None
        rows7.append({"phase": r.phase, "coupler [-]": num,
                      "ltdsim largest line [kN]": kn(r.max_N), "at [Hz]": r.f_at_max_hz,
                      "ltdsim spectrum RMS 0-10 Hz [kN]": kn(r.spectrum_rms_N),
                      "study max [kN]": kn(s7[0]) if s7 else float("nan"),
                      "study RMS [kN]": kn(s7[1]) if s7 else float("nan"),
                      "ltdsim RMS of the 0-10 Hz content [kN]": kn(r.band_rms_N)})
        rows6.append({"phase": r.phase, "coupler [-]": num,
                      "branch engaged": getattr(r, "branches", ""),
                      "ltdsim main peaks": r.peaks,
                      "study (Table 6)": t6s.get(r.phase, {}).get(str(num), "")
                      if study_case else ""})
    t6, t7 = pd.DataFrame(rows6), pd.DataFrame(rows7)
    t7["max ratio ltdsim / study [-]"] = t7["ltdsim largest line [kN]"] / t7["study max [kN]"]
    shown7 = t7.drop(columns=["ltdsim RMS of the 0-10 Hz content [kN]"])
    rep.parts += [
        "<h2 id='table6'>Table 6: main spectral peaks per phase</h2>",
        "<p class='note'>Amplitude spectra of the coupler force over each 10 s phase, "
        "its straight-line trend removed first (0.1 Hz lines). Each peak from 0.2 Hz "
        "(twice the resolution: a line nearer 0 Hz is the window's trend, not a mode) is "
        "matched to the nearest natural frequency of the train, locomotive held by the "
        "speed controller, linearised on the branch the coupler is on in that phase "
        "(draft: k2 + k3; buff: k1; both when it spends at least a fifth of the phase "
        "in each), each coupling as the simulation has it.</p>",
        table_html(t6), csv_table(t6, rep.out, "table6_spectral_peaks.csv"),
        "<h2 id='table7'>Table 7: spectral maxima and RMS per phase</h2>",
        "<p class='note'>Largest line = the largest single sinusoid's amplitude; spectrum "
        "RMS = the RMS of the spectrum's lines between 0 and 10 Hz, which never exceeds "
        "the largest line and is how the study's \"average (RMS between 0-10 Hz)\" reads. "
        "The CSV also has the RMS of the whole 0-10 Hz content (Parseval), which grows "
        "with the number of lines.</p>",
        table_html(shown7), csv_table(t7, rep.out, "table7_spectra.csv"),
        figure_html(rep.out / "spectra_per_phase.png",
                    "Fig. 9a: coupler force spectra per phase, log scale, with the train's "
                    "modal bands shaded. See whether the content falls steeply above the "
                    "bands' top (the forces then ring in the train's own modes); lines "
                    "below twice the resolution (grey) are the windows' trend"),
        figure_html(rep.out / "spectrogram.png",
                    "Fig. 9b: time-frequency map over the whole run, the study's phases "
                    "dashed. See which lines ring after the start and the deceleration, "
                    "and how many seconds they take to die away")]
    share = base.get("spectral_share_below_4hz", {})
    values = [v for ph in share.values() for v in ph.values()]
    if values:
        low = min(values)
        rep.take.append(f"At least {low:.0%} of the coupler forces' fluctuation up to "
                         "10 Hz lies below 4 Hz (couplers " + numbers_text(
                             sorted({int(c) + 1 for ph in share.values() for c in ph}))
                         + ", every phase), as the study finds (0-4 Hz).")
        rep.claim("The coupler forces' spectral content lies within 0-4 Hz (§5.2)",
                   "0-4 Hz", f"at least {low:.0%} of the 0-10 Hz content below 4 Hz",
                   "yes" if low >= 0.9 else "partly",
                   "share of the squared amplitudes, couplers 1, 8, 9 (the study's), "
                   "every phase")
    one = t7[(t7["coupler [-]"] == 1) & (t7.phase == "acceleration")]
    if study_case and len(one) and np.isfinite(one["study max [kN]"].iloc[0]):
        r = one.iloc[0]
        rep.claim("Spectral maximum of coupler 1 while accelerating (Table 7)",
                   f"{r['study max [kN]']:.1f} kN", f"{r['ltdsim largest line [kN]']:.1f} kN",
                   "no", f"{r['max ratio ltdsim / study [-]']:.0f} times the study's: the "
                   "spectra scale with the forces, which differ as in Table 5 (and the "
                   "study does not state its amplitude scaling)"
                   + (f"; ltdsim's largest line, at {r['at [Hz]']:.1f} Hz, is the force's "
                      "rise over the window as the train picks up speed"
                      if r["at [Hz]"] <= 0.15 else ""))
