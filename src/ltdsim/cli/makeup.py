"""``ltdsim makeup STUDY.toml``: a population of random train make-ups through standard
manoeuvres on local processes or a Dask cluster, resumable; its page of the largest
compressive and tensile forces, their distribution against the limits and the worst
make-ups (docs/makeup.md).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.markup import escape

from ltdsim.errors import ScenarioError
from ltdsim.progress import Display
from ltdsim.cli.common import (
    MAX_TIME_ANYWAY, case_counter, check_folder, check_number, check_scheduler,
    check_workers, err_console, executor_errors, fail, say,
)


def estimate_line(p, scheduler: Optional[str], workers: Optional[int]) -> str:
    """The study's estimate before it runs: its runs, their wall time on one core and on
    the local processes (:func:`ltdsim.engine.run.estimate` of each run), the longest."""
    from ltdsim.engine.run import duration

    spec = p.sweep
    n = len(spec.cases)
    cores = max(1, min(workers if workers and workers > 0 else os.cpu_count() or 1, n))
    line = (f"estimate: {n:,} runs ({len(p.population):,} make-ups x "
            f"{len(p.study.spec.manoeuvres)} manoeuvres), about {duration(spec.seconds)} on "
            "one core")
    if not scheduler:
        line += f" (about {duration(spec.seconds / cores)} on {cores} local processes)"
    if spec.slowest is not None:
        est, slow = spec.slowest
        line += f"; the longest, run {slow}, about {duration(est.seconds)}"
    return line


def makeup(
    file: Annotated[Path, typer.Argument(help="make-up study file (TOML, docs/makeup.md)")],
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/makeup"),
    scheduler: Annotated[Optional[str], typer.Option(help="Dask scheduler, tcp://HOST:PORT")
                         ] = None,
    workers: Annotated[Optional[int], typer.Option(help="local processes (default: all cores)")
                       ] = None,
    retry_failed: Annotated[bool, typer.Option(help="run failed runs again")] = False,
    estimate_only: Annotated[bool, typer.Option("--estimate-only",
                                                help="check the study, print its estimate "
                                                     "and stop")] = False,
    max_time: Annotated[Optional[float], typer.Option(
        "--max-time", help="refuse a study with a run estimated to take longer than this, "
                           "s of wall time (default 3600; 0: no limit)")] = None,
) -> None:
    """Run a make-up study; resumable (finished runs are kept), local or on Dask."""
    from ltdsim.engine.run import TIME_LIMIT
    from ltdsim.makeup.report import PAGE_FILES, write_report, written_files
    from ltdsim.results.outputs import check_outputs, record_outputs
    from ltdsim.makeup.run import plan, run_plan
    from ltdsim.sweep import core as sw

    try:
        check_workers(workers)
        if max_time is not None:
            check_number("--max-time", max_time, lo=0.0, unit="s", reason="0 means no limit")
        for folder in (output, output / "cases"):
            check_folder(folder)
        # the page's files: a folder or someone else's file there is refused now, not
        # after the runs (a study's own earlier page is written again: it resumes)
        check_outputs(output, PAGE_FILES, "makeup")
        with Display(err_console) as show:
            p = plan(file, progress=case_counter(show, "checking the runs"))
        check_scheduler(scheduler)
        if not scheduler:
            sw.check_sweep_memory(p.sweep, str(file), workers)
        sw.check_sweep_time(p.sweep, str(file), TIME_LIMIT if max_time is None else
                            (max_time or None), MAX_TIME_ANYWAY)
    except ScenarioError as exc:
        fail(exc)
        return
    err_console.print(escape(estimate_line(p, scheduler, workers)), highlight=False,
                      soft_wrap=True)
    if estimate_only:
        return
    with Display(err_console) as show:
        update = show.bar("make-up runs", len(p.sweep.cases), "runs")
        with executor_errors(scheduler, "runs"):
            run_plan(p, output, scheduler=scheduler, workers=workers,
                     retry_failed=retry_failed, progress=lambda d, n, c: update(d),
                     on_compile=show.compiling, notice=show.note)
    index = write_report(p, output)
    record_outputs(output, written_files(output))
    _summary(output)
    say(f"page written to {index}")


def _summary(output: Path) -> None:
    """The percentiles and exceedance tables, printed."""
    import pandas as pd

    from ltdsim.cli.common import console, plain_table

    pct = pd.read_csv(output / "percentiles.csv") if (output / "percentiles.csv").is_file() \
        else pd.DataFrame()
    exc = pd.read_csv(output / "exceedance.csv") if (output / "exceedance.csv").is_file() \
        else pd.DataFrame()
    if pct.empty:
        say("no run finished")
        return
    # narrow enough for an 80-column terminal: the probability and its interval share a
    # column, the manoeuvre's name is never cut
    table = plain_table("largest force of a run (P: share of the runs judged over the limit, "
                        "95 % interval)", ("manoeuvre", "force", "runs", "P50 [kN]",
                                           "P95 [kN]", "max [kN]", "over limit", "P [-]"))
    table.columns[0].no_wrap = True
    table.columns[0].justify = "left"
    table.columns[-1].no_wrap = True
    lo = next((c for c in exc.columns if c.endswith("_low")), None)
    hi = next((c for c in exc.columns if c.endswith("_high")), None)
    for r, e in zip(pct.itertuples(), exc.itertuples()):
        judged = int(e.runs_with_limits)
        table.add_row(r.manoeuvre, r.force, str(r.runs), f"{r.p50_kN:.0f}", f"{r.p95_kN:.0f}",
                      f"{r.max_kN:.0f}", f"{int(e.runs_exceeding)}/{judged}",
                      f"{e.probability:.2f} ({getattr(e, lo):.2f}-{getattr(e, hi):.2f})"
                      if judged else "no limits")
    console.print(table)
