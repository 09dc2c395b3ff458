"""The study report's page: the ``Report`` that collects the side-by-side rows, the
take-away bullets and the sections' parts, and the page it assembles from them (the
comparison with the study and what to take away first)."""

from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

from ltdsim._version import __version__
from ltdsim.data import study_tables
from ltdsim.scenario import Scenario
from ltdsim.study.report.html import (
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

    def claim(self, claim: str, study: str, ours: str, agree: str, why: str) -> None:
        if not self.comparable:
            agree = "not comparable"
        self.rows.append({"the study's claim (where)": claim, "the study": study,
                          "ltdsim": ours, "agree?": verdict(agree), "why / note": why})

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
                "values come from the paper's tables; model readings are in "
                "docs/model.md and docs/paper-scenario.md.</p>"]
        if dev:
            head.append("<div class='banner'><b>This is not the study's run.</b> Its settings "
                        "differ from the scenario file's:<ul>" + "".join(
                            f"<li>{html.escape(d)}</li>" for d in dev) + "</ul>Numbers in the "
                        "study columns are not comparable with these; the side-by-side "
                        "verdicts read \"not comparable\".</div>")
        side = pd.DataFrame(self.rows)
        head += ["<h2 id='side-by-side'>ltdsim and the study, side by side</h2>",
                 "<p class='note'>One row per claim the study makes: its value, ltdsim's, "
                 "whether they agree, and the reason where they do not.</p>",
                 table_html(side) if len(side) else "",
                 csv_table(side.assign(**{"agree?": [r["agree?"].split(">")[1].split("<")[0]
                                                for r in self.rows]}), self.out,
                      "side_by_side.csv") if len(side) else "",
                 "<div class='take'><h2 id='take-away' style='border:0;margin-top:.3em'>What "
                 "to take away</h2><ul>" + "".join(f"<li>{t}</li>" for t in self.take)
                 + "</ul></div>"]
        return page_html("ltdsim study report", "".join(head) + "".join(self.parts),
                         viewport=True)
