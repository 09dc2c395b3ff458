"""The study report: one self-contained HTML page, every table also as CSV.

The page opens with ltdsim and the study side by side (one row per claim the study
makes, with both values, whether they agree and why not), then what to take away from
ltdsim's own results, then the study's Tables 1-7 and Figures 3-9 with the study's values
beside ltdsim's. Couplers and vehicles are numbered from 1 as the study numbers them:
vehicle 1 is the locomotive at the front, coupler ``j`` joins vehicles ``j`` and ``j + 1``.

``page`` holds the ``Report`` that collects the parts and assembles the page; each
section is a module (``base_run`` with the model readings, ``fitting``, ``phases``,
``frequency``, ``engineer``: envelopes, the cases' heatmaps, the track, gear travel) of functions that add their part to it; ``html`` the building blocks;
``run_page`` the one-page report of a single run (``ltdsim run --report``). It reads
the stage results the study computed and never simulates; it may import the layers below
the study (results, analysis, viz, scenario), nothing imports it but ``study.stages``
and the CLI.
"""

from __future__ import annotations

from pathlib import Path

from ltdsim.results.io import atomic_path
from ltdsim.scenario import Scenario
from ltdsim.study.report import base_run, engineer, fitting, frequency, phases
from ltdsim.study.report.page import Report
from ltdsim.study.report.run_page import (
    curving_section,
    worst_vehicles,
    write_run_report,
)

__all__ = ["write_report", "write_run_report", "curving_section", "worst_vehicles"]


def write_report(out: Path, results: dict, scenario: Scenario, case: str,
                 scenario_path: Path) -> Path:
    """Write ``<out>/index.html`` and the CSV tables from the study's stage results; the
    sections in the page's order."""
    rep = Report(Path(out), results, scenario, case)
    base_run.readings(rep)
    base_run.methods(rep)
    base_run.base_run(rep)
    fitting.reduction(rep)
    fitting.speed_error(rep)
    fitting.identification(rep)
    phases.phases(rep)
    frequency.modal(rep)
    frequency.spectra(rep)
    engineer.outputs(rep)
    index = Path(out) / "index.html"
    with atomic_path(index) as tmp:
        tmp.write_text(rep.page(scenario_path))
    return index
