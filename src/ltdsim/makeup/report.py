"""The page of a make-up study (``<out>/index.html``): its population's largest forces,
their distribution and exceedance probabilities, where and when they occur, the worst
make-ups and what they share, the couplers' fatigue damage, and the limits used, with
the figures as PNG files (embedded in the page) and every table as CSV beside it.
Built with the study report's page helpers (:mod:`ltdsim.study.report.html`).
"""

from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

from ltdsim._version import __version__
from ltdsim.makeup import results as mr
from ltdsim.makeup.draws import features
from ltdsim.makeup.run import Plan
from ltdsim.results.io import atomic_path
from ltdsim.study.report.html import csv_table, figure_html, page_html, table_html

#: the page's headers of the tables' columns (the CSV files keep the columns' names)
HEADERS = {
    "manoeuvre": "manoeuvre", "force": "force", "runs": "runs [-]", "mean_kN": "mean [kN]",
    **{f"p{q}_kN": f"P{q} [kN]" for q in mr.PERCENTILES}, "max_kN": "largest [kN]",
    "runs_with_limits": "runs with limits [-]", "runs_exceeding": "runs exceeding [-]",
    "probability": "probability of exceeding [-]",
    "largest_utilisation": "largest force / limit [-]",
    "makeup": "make-up", "max_lcf_kN": "largest LCF [kN]", "lcf_coupler": "coupler [-]",
    "lcf_position_m": "from the front [m]", "lcf_time_s": "at [s]",
    "lcf_between": "between", "max_ltf_kN": "largest LTF [kN]", "ltf_coupler": "coupler [-]",
    "ltf_position_m": "from the front [m]", "ltf_time_s": "at [s]", "ltf_between": "between",
    "empties": "empties [-]", "empty_share": "empty share [-]",
    "empties_ahead_of_loads": "empties ahead of loads [-]",
    "longest_empty_run": "longest run of empties [wagons]",
    "empties_ahead_of_remote": "empties right ahead of a remote consist [wagons]", "wagons": "wagons, front to rear",
    "feature": "feature", "worst_mean": "mean, worst make-ups", "others_mean": "mean, others",
    "spearman_with_force": "Spearman rank correlation with the force [-]",
    "coupler": "coupler [-]", "median_damage": "median damage per run [-]",
    "max_damage": "largest damage per run [-]", "median_position_m": "from the front [m]",
}


def _shown(df: pd.DataFrame) -> pd.DataFrame:
    out = df.rename(columns={c: HEADERS.get(c, c) for c in df.columns})
    for c in out.columns:
        if c.startswith("ci") and ("_low" in c or "_high" in c):
            level, side = c[2:].split("_")
            out = out.rename(columns={c: f"{side} end of the {level} % interval [-]"})
    return out


#: the files the page may write in its folder (beside ``cases/``)
PAGE_FILES = ("index.html", "runs.csv", "makeups.csv", "percentiles.csv", "exceedance.csv",
              "worst_lcf.csv", "worst_ltf.csv", "shared.csv", "fatigue.csv",
              "distribution.png", "exceedance.png", "where.png", "features.png",
              "fatigue.png")


def written_files(out: Path) -> list[Path]:
    """The files of :data:`PAGE_FILES` present in ``out``."""
    return [Path(out) / n for n in PAGE_FILES if (Path(out) / n).is_file()]


def write_report(p: Plan, out: str | Path, title: str | None = None) -> Path:
    """Write the study's tables (CSV), figures (PNG) and page into ``out``; returns the
    page's path."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    spec = p.study.spec
    runs = mr.run_table(p, out)
    pct = mr.percentile_table(runs)
    exc = mr.exceedance_table(runs, spec.confidence)
    worst = {k: mr.worst_table(p, runs, k) for k in mr.FORCES}
    shared = mr.shared_table(runs, "lcf")
    fat = mr.fatigue_table(p, out)
    makeups = pd.DataFrame([{"makeup": m.id, **features(m), "remote_after": " ".join(
        str(r) for r in m.remote_after), "wagons": m.label()} for m in p.population])
    ok = mr._finished(runs)
    title = title or f"Make-up study {spec.name}"
    n_man = len(spec.manoeuvres)
    parts = [f"<h1>{html.escape(title)}</h1>",
             f"<p class='note'>ltdsim {html.escape(__version__)}; study file "
             f"{html.escape(p.study.source)}, base scenario {html.escape(spec.scenario)}"
             + (f" (case {html.escape(spec.case)})" if spec.case else "") +
             f"; {len(p.population)} make-ups of {p.study.wagons} wagons drawn with seed "
             f"{spec.seed}, each run through {n_man} manoeuvre{'s' if n_man > 1 else ''} "
             f"({html.escape(', '.join(m.name for m in spec.manoeuvres))}): {len(runs)} "
             f"runs, {len(ok)} finished. LCF is the longitudinal compressive force, LTF the "
             "tensile force; a run's largest is over every coupler and every step. "
             "Couplers are counted from 1 (coupler 1 behind the lead vehicle), positions "
             "in m from the front of the train, times in s from the start of the run. "
             "Limits: see the last section.</p>"]
    if len(ok) < len(runs):
        bad = runs[runs.status != "ok"]
        parts.append(f"<div class='banner'><b>{len(bad)} run(s) did not finish</b> "
                     "(status and error in runs.csv); the tables below are over the "
                     "finished runs only.</div>")
    parts += ["<h2 id='population'>The population's largest forces</h2>",
              "<p class='note'>Per manoeuvre, the distribution of each run's largest force "
              "(numpy's linear percentiles: with fewer than 100 runs P99 is close to the "
              "largest run).</p>",
              table_html(_shown(pct)) if len(pct) else "<p>No run finished.</p>",
              csv_table(pct, out, "percentiles.csv"),
              f"<p class='note'>How many runs exceeded a limit at one coupler or more "
              f"(each coupler against the lower limit of the two vehicles it joins), the "
              f"probability estimated from them and its exact (Clopper-Pearson) "
              f"{spec.confidence * 100:g} % confidence interval from the number of runs.</p>",
              table_html(_shown(exc)) if len(exc) else "",
              csv_table(exc, out, "exceedance.csv")]
    if len(ok):
        from ltdsim.makeup import figures

        fig = figures.distribution(p, ok, out / "distribution.png")
        parts.append(figure_html(fig, "Histograms of each run's largest LCF and LTF, per "
                                      "manoeuvre; dashed: the limits of the wagon types."))
        fig = figures.exceedance(p, ok, out / "exceedance.png")
        parts.append(figure_html(fig, f"Probability that a run's largest force exceeds F, "
                                      f"with its {spec.confidence * 100:g} % "
                                      "Clopper-Pearson band."))
        parts += ["<h2 id='where'>Where and when</h2>"]
        fig = figures.where(ok, out / "where.png")
        parts.append(figure_html(fig, "Each run's largest LCF and LTF against the distance "
                                      "of its coupler from the front of the train."))
        parts += ["<h2 id='worst'>The worst make-ups and what they share</h2>",
                  f"<p class='note'>Per manoeuvre, the {mr.WORST_SHARE:.0%} of its runs "
                  "(at least one) with the largest LCF, worst first. <i>Empties ahead of "
                  "loads</i> is the share of (empty, loaded) pairs of wagons in which the "
                  "empty stands ahead: 1 when every empty is ahead of every load, 0 when "
                  "behind them all; <i>empties right ahead of a remote consist</i> the run "
                  "of empties a remote consist pushes on first.</p>",
                  table_html(_shown(worst["lcf"])), csv_table(worst["lcf"], out, "worst_lcf.csv"),
                  "<p class='note'>The same by the largest LTF.</p>",
                  table_html(_shown(worst["ltf"])), csv_table(worst["ltf"], out, "worst_ltf.csv"),
                  "<p class='note'>What the worst make-ups by LCF share: each feature's mean "
                  "over them and over the others, and its rank correlation with the largest "
                  "LCF over all runs of the manoeuvre.</p>",
                  table_html(_shown(shared)), csv_table(shared, out, "shared.csv")]
        fig = figures.features_figure(ok, out / "features.png")
        parts.append(figure_html(fig, "Each run's largest LCF against what its make-up is "
                                      "made of."))
    parts.append("<h2 id='fatigue'>Fatigue damage per coupler</h2>")
    if fat.empty:
        parts.append("<p class='note'>No coupler of the base scenario has a fatigue curve "
                     "(couplers.default.fatigue): no damage counted.</p>")
    else:
        parts.append("<p class='note'>Miner's damage of each coupler's rainflow cycles in "
                     "one run (ltdsim.results.fatigue, docs/fatigue.md), its median and "
                     "largest over the make-ups; the couplers with the largest damage "
                     "first.</p>")
        top = fat.sort_values(["max_damage", "coupler"], ascending=[False, True]).head(15)
        parts += [table_html(_shown(top)), csv_table(fat, out, "fatigue.csv")]
        if (fat.max_damage > 0).any():
            from ltdsim.makeup import figures

            fig = figures.fatigue_figure(fat, out / "fatigue.png")
            parts.append(figure_html(fig, "Median and largest damage per run of each "
                                          "coupler over the make-ups."))
    parts += ["<h2 id='limits'>Limits</h2>", _limits_html(p)]
    parts += ["<h2 id='tables'>Every run and every make-up</h2>",
              csv_table(runs, out, "runs.csv"), csv_table(makeups, out, "makeups.csv")]
    index = out / "index.html"
    with atomic_path(index) as tmp:
        tmp.write_text(page_html(title, "".join(parts), viewport=True))
    return index


def _limits_html(p: Plan) -> str:
    """The limits of each wagon type, kN, with the source each gives."""
    from ltdsim.data import load_preset

    rows = []
    for t in p.study.spec.types:
        for state in ("loaded", "empty"):
            lcf, ltf = p.study.limits[(t.name, state)]
            lim = getattr(t, state).limits or t.limits
            src = ""
            if isinstance(lim, str):
                s = load_preset("limits", lim).get("sources", {})
                src = f"{lim}: LCF {s.get('lcf', '')}; LTF {s.get('ltf', '')}"
            elif lim is not None:
                src = "given in the study file"
            if p.study.spec.limits is not None:
                src += ("; " if src else "") + "the study file's [limits] where none above"
            rows.append({"wagon": f"{t.name} {state}", "LCF limit [kN]": lcf / 1e3,
                         "LTF limit [kN]": ltf / 1e3, "source": src or "none: not judged"})
    return table_html(pd.DataFrame(rows)) + (
        "<p class='note'>A coupler is judged against the lower limit of the two vehicles "
        "it joins; a coupler between two locomotives against the study file's [limits] "
        "(not judged without).</p>")

