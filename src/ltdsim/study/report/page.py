"""The study report's page: the ``Report`` that collects the side-by-side rows, the
take-away bullets and the sections' parts, and the page it assembles from them (the
comparison with the study and what to take away first)."""

from __future__ import annotations

import html
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd

from ltdsim._provenance import code_hash, source_commit
from ltdsim._version import __version__
from ltdsim.data import study_tables
from ltdsim.scenario import Scenario
from ltdsim.study.report.html import (
    contents,
    csv_table,
    page_html,
    table_html,
    verdict,
)


class Report:
    """Collects the page's parts, the side-by-side rows and the take-away bullets."""

    def __init__(self, out: Path, results: dict, scenario: Scenario, case: str):
        self.out, self.results, self.sc, self.case = out, results, scenario, case
        self.T = study_tables()
        self.comparable = not results.get("deviations")
        self.rows: list[dict] = []  # ltdsim and the study side by side
        self.take: list[str] = []  # what to take away
        self.parts: list[str] = []  # the sections after the summary
        self.causes: list[str] = []  # the summary's root causes (HTML), most telling first

    def claim(self, claim: str, study: str, ours: str, agree: str, why: str) -> None:
        if not self.comparable:
            agree = "not comparable"
        self.rows.append({"the study's claim (where)": claim, "the study": study,
                          "ltdsim": ours, "agree?": verdict(agree), "why / note": why,
                          "_agree": agree})

    def summary(self) -> str:
        """The half page that opens the report: how many of the study's claims this run
        reproduces and which, the root causes of the differences, which results rest on
        ltdsim's readings, and how far the peaks move when the step is halved."""
        if not self.rows:
            return ""
        count = {v: [r["the study's claim (where)"].split(" (")[0] for r in self.rows
                     if r["_agree"] == v] for v in ("yes", "partly", "no", "not comparable")}
        n = len(self.rows)
        out = ["<h2 id='summary'>Summary</h2>"]
        if count["not comparable"]:
            out.append(f"<p><b>Not the study's run</b> (settings changed, see the banner): "
                       f"none of the study's {n} claims can be judged here.</p>")
        else:
            out.append(
                f"<p><b>Of the study's {n} claims checked, ltdsim reproduces "
                f"{len(count['yes'])}, {len(count['partly'])} in part and "
                f"{len(count['no'])} not</b> (the <a href='#side-by-side'>side-by-side "
                "table</a> has each with both values and why).</p><ul>" + "".join(
                    f"<li><b>{label}:</b> {html.escape('; '.join(names))}.</li>"
                    for label, names in (("Reproduced", count["yes"]),
                                         ("In part", count["partly"]),
                                         ("Not reproduced", count["no"])) if names)
                + "</ul>")
        if self.causes:
            out.append("<p><b>Why they differ, the root causes:</b></p><ol>" + "".join(
                f"<li>{c}</li>" for c in self.causes) + "</ol>")
        out.append("<p><b>What rests on ltdsim's readings</b> (the study is silent or its "
                   "printed equations read more than one way; each reading and what its "
                   "alternative gives is under <a href='#readings'>Model readings</a>): "
                   "the coupler law's fade and its draft and buff branches, one gear per "
                   "coupling, the slack-centred start, the reconstructed speed profile, "
                   "the dynamic-brake-only stop and the speed controller's output as the "
                   "locomotive's acceleration. Every coupler force, acceleration, speed "
                   "error and frequency of ltdsim's below depends on them; the study's "
                   "values are its own.</p>")
        half = (self.results.get("base", {}).get("alternatives") or {}).get("half_step")
        if half:
            import numpy as np

            moves = [np.max(np.abs(np.array(half["half"][k]) - np.array(half["base"][k])))
                     for k in ("max_tension_N", "max_compression_N")]
            top = max(max(half["base"]["max_tension_N"]), max(half["base"]["max_compression_N"]))
            out.append(f"<p class='note'><b>Accuracy:</b> with the step halved to "
                       f"{half['dt_s']:g} s every coupler's largest tension and compression "
                       f"moves by at most {max(moves) / 1e3:.2g} kN "
                       f"({100 * max(moves) / top:.2g} % of the largest), so peaks are "
                       "quoted to 1 kN (<a href='#methods'>Methods</a>).</p>")
        return "".join(out)

    def page(self, scenario_path: Path) -> str:
        s = self.sc.solver
        dev = self.results.get("deviations") or []
        head = [f"<h1>Longitudinal train dynamics with a nonlinear friction draft gear: the "
                f"study reproduced by ltdsim {html.escape(__version__)}</h1>",
                f"<p class='note'>Scenario {html.escape(str(scenario_path))}, base case "
                f"{html.escape(self.case)}; solver {s.method} at dt = {s.dt:g} s, "
                f"{s.n_steps * s.dt:g} s simulated per case. Couplers and vehicles are "
                "numbered from the front as the study numbers them: vehicle 1 is the "
                "locomotive, coupler 1 joins vehicles 1 and 2. Forces + in tension. Study "
                "values come from the paper's tables. Made by "
                f"<code>{html.escape(command_line())}</code>, ltdsim "
                f"{html.escape(__version__)} (commit {html.escape(source_commit())}, code "
                f"{code_hash()}), {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC.</p>"]
        if dev:
            head.append("<div class='banner'><b>This is not the study's run.</b> Its settings "
                        "differ from the scenario file's:<ul>" + "".join(
                            f"<li>{html.escape(d)}</li>" for d in dev) + "</ul>Numbers in the "
                        "study columns are not comparable with these; the side-by-side "
                        "verdicts read \"not comparable\".</div>")
        side = pd.DataFrame([{k: v for k, v in r.items() if k != "_agree"}
                             for r in self.rows])
        first = [self.summary(),
                 "<div class='take'><h2 id='take-away' style='border:0;margin-top:.3em'>What "
                 "to take away from this run</h2><ul>" + "".join(
                     f"<li>{t}</li>" for t in self.take) + "</ul></div>",
                 "<h2 id='side-by-side'>ltdsim and the study, side by side</h2>",
                 "<p class='note'>One row per claim the study makes: its value, ltdsim's, "
                 "whether they agree, and the reason where they do not.</p>",
                 table_html(side) if len(side) else "",
                 csv_table(side.assign(**{"agree?": [r["_agree"] for r in self.rows]}),
                           self.out, "side_by_side.csv") if len(side) else ""]
        body = "".join(first) + "".join(self.parts)
        return page_html("ltdsim study report", "".join(head) + contents(body) + body,
                         viewport=True)


def command_line() -> str:
    """The command that is making the page, as typed (``ltdsim ...``), or the Python
    call's program and arguments."""
    import shlex
    import sys

    prog = Path(sys.argv[0]).name if sys.argv else "python"
    if prog == "ltdsim":
        return shlex.join(["ltdsim", *sys.argv[1:]])
    return "ltdsim.study.run_study() from " + shlex.join([prog, *sys.argv[1:]])
