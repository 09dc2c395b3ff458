"""Command line: ``ltdsim run FILE [--case NAME] [-o OUT.nc] [--plot FIG.png]``.

The CLI only parses arguments, shows progress and prints tables; every number comes
from the library.
"""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from ltdsim.errors import LtdsimError, ScenarioError, SimulationError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="ltdsim: longitudinal train dynamics simulation and analysis.")
console = Console()
err_console = Console(stderr=True)


@app.callback()
def _main() -> None:
    """ltdsim: longitudinal train dynamics simulation and analysis."""


def parse_set(items: list[str]) -> dict:
    """Turn ``["solver.t_end=10", "couplers.default.model=\"linear\""]`` into overrides.

    The value is read as a TOML value (numbers, strings in quotes, arrays); a bare word
    that is not valid TOML is taken as a string.
    """
    out = {}
    for item in items:
        if "=" not in item:
            raise ScenarioError("--set", [(item, "expected KEY=VALUE")])
        key, raw = item.split("=", 1)
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw
        out[key.strip()] = value
    return out


def _fail(exc: LtdsimError) -> None:
    kind = "invalid input" if isinstance(exc, ScenarioError) else "simulation failed"
    err_console.print(f"[bold red]error ({kind}):[/] {exc}", highlight=False, soft_wrap=True)
    raise typer.Exit(2 if isinstance(exc, ScenarioError) else 3)


@app.command()
def run(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML)")],
    case: Annotated[Optional[str], typer.Option("--case", "-c", help="named case to apply")] = None,
    output: Annotated[Optional[Path], typer.Option("--output", "-o",
                                                   help="write the result as netCDF")] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", "-p",
                                                 help="write an overview figure (PNG/SVG/PDF)")] = None,
    set_: Annotated[Optional[list[str]], typer.Option("--set", "-s",
                                                      help="override, e.g. solver.t_end=10")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")] = False,
) -> None:
    """Simulate one scenario (optionally one named case) and summarise coupler forces."""
    from ltdsim.io import save_result
    from ltdsim.scenario import load_scenario
    from ltdsim.simulate import simulate
    from ltdsim.summary import coupler_summary, run_summary

    try:
        sc = load_scenario(file, case=case)
        if set_:
            sc = sc.with_overrides(parse_set(set_), source="--set")
        label = f"{sc.name}" + (f" [{sc.case}]" if sc.case else "")
        with Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                      TextColumn("{task.completed:.1f}/{task.total:.1f} s simulated"),
                      TimeElapsedColumn(), TimeRemainingColumn(), console=err_console,
                      disable=quiet, transient=False) as prog:
            task = prog.add_task(f"simulating {label}", total=sc.solver.n_steps * sc.solver.dt)
            ds = simulate(sc, progress=lambda done, total: prog.update(task, completed=done))
    except (ScenarioError, SimulationError) as exc:
        _fail(exc)
        return

    table = Table(title=f"Coupler forces: {label}")
    for col in ("coupler", "max tension [kN]", "at [s]", "max compression [kN]", "at [s]"):
        table.add_column(col, justify="right")
    for j, row in coupler_summary(ds).iterrows():
        table.add_row(str(j), f"{row.max_tension_N / 1e3:.1f}", f"{row.t_max_tension_s:.2f}",
                      f"{row.max_compression_N / 1e3:.1f}", f"{row.t_max_compression_s:.2f}")
    console.print(table)
    s = run_summary(ds)
    tracking = (f"RMS speed error {s['rms_speed_error_m_s']:.4f} m/s "
                f"(max {s['max_speed_error_m_s']:.3f}); "
                if s["rms_speed_error_m_s"] == s["rms_speed_error_m_s"] else "")
    console.print(
        f"{tracking}max |acceleration| {s['max_abs_acceleration_m_s2']:.3f} m/s^2; "
        f"peak traction {s['max_traction_N'] / 1e3:.1f} kN; "
        f"samples over adhesion {s['samples_over_adhesion']}; "
        f"{s['simulated_s']:.1f} s simulated in {s['wall_time_s']:.2f} s wall"
        + (f" (+{s['compile_time_s']:.1f} s compiling, once)" if s["compile_time_s"] > 0.5 else ""))
    if output is not None:
        save_result(ds, output)
        console.print(f"result written to {output}")
    if plot is not None:
        from ltdsim.plotting import save_overview

        save_overview(ds, plot)
        console.print(f"figure written to {plot}")


def main() -> None:  # pragma: no cover - console entry
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
