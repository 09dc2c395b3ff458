"""``ltdsim sweep``: many cases, local processes or a Dask cluster, resumable; the
summary table and the best case's phase figures.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.markup import escape

from ltdsim.errors import ScenarioError
from ltdsim.progress import Display
from ltdsim.cli.analyse import PHASES_FILES
from ltdsim.cli.common import (
    MAX_TIME_ANYWAY, case_counter, check_folder, check_number, check_scheduler,
    check_workers, console, err_console, executor_errors, fail, parse_set, plain_table, say, simulate_shown,
    write_csv,
)
from ltdsim.results.outputs import check_outputs, record_outputs

#: the tables a sweep writes in its folder once every case has run
SWEEP_FILES = ("summary.csv", "phase_norms.csv")
#: the phase figures of the best case, ``<case id>_<name>`` in ``figures/``
PHASE_FIGURES = tuple(n for n in PHASES_FILES if n.endswith(".png"))


def figure_names(folder: Path, case_ids) -> list[str]:
    """The names in ``folder`` that a sweep of the cases ``case_ids`` may write there (the
    phase figures of whichever case turns out best): the names to check before the
    sweep, found by listing the folder once rather than by looking up every case's."""
    try:
        present = [e.name for e in os.scandir(folder)]
    except (FileNotFoundError, NotADirectoryError):
        return []
    if not present:
        return []
    ids = set(case_ids)
    return sorted(name for name in present for fig in PHASE_FIGURES
                  if name.endswith(f"_{fig}") and name[:-len(fig) - 1] in ids)


def _shown(value) -> str:
    """A swept value in the printed table: a number to 6 significant figures."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return "" if value is None else str(value)
    return f"{value:.6g}"


def sweep(
    file: Annotated[Path, typer.Argument(help="scenario file (its named cases) or sweep file")],
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/sweep"),
    set_: Annotated[Optional[list[str]], typer.Option(
        "--set", "-s", help="override for every case, after the case's own keys, e.g. "
                            "solver.t_end=10 (repeat for more keys)")] = None,
    scheduler: Annotated[Optional[str], typer.Option(help="Dask scheduler, tcp://HOST:PORT")
                         ] = None,
    workers: Annotated[Optional[int], typer.Option(help="local processes (default: all cores)")
                       ] = None,
    keep_results: Annotated[bool, typer.Option(help="also write each case's time series")] = False,
    retry_failed: Annotated[bool, typer.Option(help="run failed cases again")] = False,
    best_by: Annotated[str, typer.Option(help="rms_speed_error | max_tension | "
                                              "max_compression | max_acceleration")
                       ] = "rms_speed_error",
    figures: Annotated[bool, typer.Option(help="phase figures (study Fig. 5-7) of the best "
                                               "case")] = True,
    max_time: Annotated[Optional[float], typer.Option(
        "--max-time", help="refuse a sweep with a case estimated to take longer than this, "
                           "s of wall time (default 3600; 0: no limit)")] = None,
) -> None:
    """Run many cases; resumable (finished cases are kept), local or on Dask."""
    from ltdsim.engine.run import ANNOUNCE_TIME, TIME_LIMIT, duration
    from ltdsim.sweep import core as sw

    if best_by not in sw.CRITERIA:
        fail(ScenarioError("--best-by", [("best-by", f"one of {', '.join(sw.CRITERIA)}")]))
        return
    try:
        check_workers(workers)
        if max_time is not None:
            check_number("--max-time", max_time, lo=0.0, unit="s", reason="0 means no limit")
        for folder in (output, output / "cases") + ((output / "figures",) if figures else ()):
            check_folder(folder)
        # the tables written once every case has run: a folder or someone else's file
        # there is refused now, not after the cases (an earlier sweep's own tables, as
        # recorded, are written again: a sweep resumes into its folder)
        check_outputs(output, SWEEP_FILES, "sweep")
        with Display(err_console) as show:
            checking = case_counter(show, "checking the cases")
            spec = sw.load_sweep(file, progress=checking)
            if set_:
                spec = sw.with_overrides(spec, parse_set(set_), progress=checking)
        if figures:  # (which case's figures is known only at the end: any case's)
            check_outputs(output / "figures",
                          figure_names(output / "figures", (c.id for c in spec.cases)),
                          "sweep")
        check_scheduler(scheduler)
        if not scheduler:  # (a cluster's workers check their own memory)
            sw.check_sweep_memory(spec, str(file), workers)
        sw.check_sweep_time(spec, str(file), TIME_LIMIT if max_time is None else
                            (max_time or None), MAX_TIME_ANYWAY)
    except ScenarioError as exc:
        fail(exc)
        return
    if spec.seconds > ANNOUNCE_TIME and spec.slowest is not None:
        cores = max(1, min(workers if workers and workers > 0 else os.cpu_count() or 1,
                           len(spec.cases)))
        est, slow = spec.slowest
        say_err = (f"estimate: {len(spec.cases):,} cases, about {duration(spec.seconds)} on "
                   f"one core" + ("" if scheduler else
                                  f" (about {duration(spec.seconds / cores)} on {cores} "
                                  f"local processes)") +
                   f"; the longest, case {slow}, about {duration(est.seconds)}")
        err_console.print(escape(say_err), highlight=False, soft_wrap=True)
    with Display(err_console) as show:
        update = show.bar("sweep", len(spec.cases), "cases")
        with executor_errors(scheduler, "cases"):
            summary = sw.run_sweep(spec, output, scheduler=scheduler, workers=workers,
                                   keep_results=keep_results, retry_failed=retry_failed,
                                   progress=lambda d, n, c: update(d),
                                   on_compile=show.compiling, notice=show.note)
    write_csv(summary, output / "summary.csv", index=True)
    written = [output / "summary.csv"]
    norms = sw.phase_norm_table(output, spec)
    if not norms.empty:
        write_csv(norms.rename(columns={"number": "coupler or vehicle (1 = lead end)"}),
             output / "phase_norms.csv")
        written.append(output / "phase_norms.csv")
    record_outputs(output, written)
    swept = [sw.swept_column(k) for k in spec.swept]
    table = plain_table(f"Sweep {file} ({len(spec.cases)} cases)",
                   ("case", *swept, "status", "RMS speed error [m/s]", "max tension [kN]",
                    "max compression [kN]", "max |a| [m/s^2]"))
    for case, row in summary.iterrows():
        values = [_shown(row[c]) for c in swept]
        if row.status == "ok":
            table.add_row(case, *values, "ok", f"{row.rms_speed_error_m_s:.4f}",
                          f"{row.max_tension_N / 1e3:.0f}", f"{row.max_compression_N / 1e3:.0f}",
                          f"{row.max_abs_acceleration_m_s2:.2f}")
        else:
            table.add_row(case, *values, str(row.status), str(row.get("error") or "")[:60],
                          "", "", "")
    console.print(table)
    best = sw.best_case(summary, best_by)
    if best is None and (summary.status == "ok").any():
        say(f"no case has a value for {best_by} (no speed controller?); "
             "choose another with --best-by")
    if best is not None:
        console.print(f"best case by {best_by}: [bold]{escape(best)}[/]")
        if figures:
            from ltdsim.viz.analysis import phase_figures

            sc = spec.scenario(next(c for c in spec.cases if c.id == best))
            files = phase_figures(simulate_shown(sc, max_time=max_time), output / "figures", sc,
                                  prefix=f"{best}_")
            record_outputs(output / "figures", files)
            say(f"phase figures of {best} in {output / 'figures'} ({len(files)})")
    failed = summary[summary.status != "ok"]
    if len(failed):
        console.print(f"[yellow]{len(failed)} case(s) did not finish; see "
                      f"{escape(str(output))}/cases[/]")
    say(f"summary written to {output / 'summary.csv'}")
