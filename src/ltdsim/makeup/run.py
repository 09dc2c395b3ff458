"""A make-up study as a sweep: one case per make-up and manoeuvre (``m0001-emergency``),
its overrides the make-up's train and the manoeuvre's commands, run by the sweep's
executor (:func:`ltdsim.sweep.core.run_sweep`: local processes or a Dask scheduler,
each finished case written atomically and kept; a stopped study resumes with the same
command and runs only the cases not finished).

Each case record carries, besides the sweep's summary, every coupler's largest tension
and compression over every step with their times (the sweep's ``peaks`` analysis) and
its fatigue damage (``fatigue``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ltdsim.makeup.draws import Makeup, draw_population, makeup_overrides
from ltdsim.makeup.manoeuvres import manoeuvre_overrides
from ltdsim.makeup.study import Study, load_study
from ltdsim.sweep import core as sw

#: the analyses each case record carries (part of each case's fingerprint)
EXTRAS = ("peaks", "fatigue")


@dataclass
class Plan:
    """A loaded study, its population and the sweep that runs it."""

    study: Study
    population: list[Makeup]
    sweep: sw.Sweep

    def case_id(self, makeup: Makeup, manoeuvre: str) -> str:
        return f"{makeup.id}-{manoeuvre}"


def plan(path: str | Path, progress: sw.Checked | None = None) -> Plan:
    """Load study file ``path``, draw its population and check every case (the
    scenario each make-up and manoeuvre makes, its step's stability, its estimates).
    Raises ScenarioError naming the file (or the case) and the key."""
    study = load_study(path)
    return plan_of(study, progress)


def plan_of(study: Study, progress: sw.Checked | None = None) -> Plan:
    """The :class:`Plan` of a loaded ``study``."""
    population = draw_population(study)
    mans = study.spec.manoeuvres
    per = [manoeuvre_overrides(study.base, m) for m in mans]
    n = len(population) * len(mans)

    def make(i: int) -> sw.Case:
        mk, k = divmod(i, len(mans))
        m = population[mk]
        return sw.Case(f"{m.id}-{mans[k].name}", {**makeup_overrides(study, m), **per[k]})

    cases = sw.LazyCases(n, make)
    spec = sw.validated(sw.Sweep(study.base, cases, study.source), progress)
    return Plan(study, population, spec)


def run_plan(p: Plan, out: str | Path, *, scheduler: str | None = None,
             workers: int | None = None, retry_failed: bool = False,
             progress: Callable[[int, int, str], None] | None = None,
             on_compile: Callable[[float, bool], None] | None = None,
             notice: Callable[[str], None] | None = None):
    """Run the cases of ``p`` not finished yet into ``out/cases`` (see
    :func:`ltdsim.sweep.core.run_sweep` for the arguments); returns the sweep's summary
    table."""
    return sw.run_sweep(p.sweep, out, scheduler=scheduler, workers=workers,
                        retry_failed=retry_failed, extras=EXTRAS, progress=progress,
                        on_compile=on_compile, notice=notice)
