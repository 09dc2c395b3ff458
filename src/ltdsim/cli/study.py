"""``ltdsim study``: the whole study reproduced as one report, resumable stage by stage.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from ltdsim.errors import ScenarioError, SimulationError
from ltdsim.progress import Display
from ltdsim.cli.common import (
    check_folder, check_workers, err_console, fail, parse_set, say,
)


def study(
    file: Annotated[Path, typer.Argument(help="scenario file with the cases (TOML)")] = Path(
        "scenarios/paper.toml"),
    output: Annotated[Path, typer.Option("--output", "-o", help="report folder")] = Path("report"),
    case: Annotated[str, typer.Option(help="base case for phases, spectra, modes")] = "LHHL",
    set_: Annotated[Optional[list[str]], typer.Option("--set", "-s",
                                                      help="override for every case")] = None,
    reduction: Annotated[bool, typer.Option(help="run the model reduction")] = True,
    workers: Annotated[Optional[int], typer.Option(help="local processes")] = None,
    force: Annotated[bool, typer.Option(help="replace a report made with other settings "
                                             "in the output folder")] = False,
) -> None:
    """Reproduce the whole study as one report (index.html, CSV tables, netCDF).

    A folder holding a report made with other settings (overrides, base case, reduction)
    is left alone unless --force is given; a run whose settings depart from the scenario
    file's says so in a banner at the top of its report."""
    from ltdsim.study.stages import run_study

    try:
        check_workers(workers)
        for folder in (output, output / "cache", output / "sweep", output / "sweep" / "cases"):
            check_folder(folder)
        overrides = parse_set(set_) if set_ else None
        with Display(err_console) as show:
            index = run_study(file, output, case=case, overrides=overrides, reduction=reduction,
                              workers=workers, force=force, progress=show.stage,
                              on_compile=show.compiling, notice=show.note)
            show.done(f"report written to {index}")
    except (ScenarioError, SimulationError) as exc:
        fail(exc)
        return
    except KeyboardInterrupt:
        err_console.print("[yellow]interrupted: finished stages and cases are kept; run the "
                          "same command again to resume[/]")
        raise typer.Exit(130) from None
    say(f"report written to {index}")
