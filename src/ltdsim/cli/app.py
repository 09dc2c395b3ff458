"""The ``ltdsim`` application: the commands of each group (``run``, ``view``, ``gear``,
``curve``, ``analyse``, ``sweep``, ``makeup``, ``study``, ``brake-test``) gathered into one
typer app, in the order ``ltdsim --help`` lists them, and the ``--version`` flag.

Usage: ``ltdsim COMMAND ...`` (the console entry) or ``python -m ltdsim.cli.app COMMAND``.
"""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from ltdsim.cli import analyse, braketest, curve, gear, makeup, run, study, sweep, view
from ltdsim.cli.common import console

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="ltdsim: longitudinal train dynamics simulation and analysis.")


def package_version() -> str:
    """The installed package's version (its metadata), else ``ltdsim.__version__``."""
    from importlib import metadata

    try:
        return metadata.version("ltdsim")
    except metadata.PackageNotFoundError:
        from ltdsim._version import __version__

        return __version__


def _print_version(value: bool) -> None:
    if value:
        console.print(f"ltdsim {package_version()}", markup=False, highlight=False)
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="print the version of ltdsim and exit")] = False,
) -> None:
    """ltdsim: longitudinal train dynamics simulation and analysis."""


app.command()(run.run)
app.command()(view.view)
app.add_typer(gear.gear_app, name="gear")
app.command("curve-limit")(curve.curve_limit_cmd)
app.command()(gear.reduce)
app.command()(sweep.sweep)
app.command()(makeup.makeup)
app.command()(analyse.phases)
app.command()(analyse.modal)
app.command()(analyse.spectrum)
app.command()(analyse.sysid)
app.command()(study.study)
app.command("brake-test")(braketest.brake_test)


def main() -> None:  # pragma: no cover - console entry
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
