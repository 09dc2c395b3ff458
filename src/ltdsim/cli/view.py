"""``ltdsim view``: a run's saved result as one self-contained interactive HTML page
(ltdsim.viz.explorer), written next to the result or where asked, and opened in the
default browser.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.markup import escape

from ltdsim.errors import ScenarioError
from ltdsim.cli.common import check_output, err_console, fail, say

#: the page's file suffixes
PAGE_SUFFIXES = (".html", ".htm")


def view(
    result: Annotated[Path, typer.Argument(help="a result written by ltdsim run -o FILE.nc")],
    output: Annotated[Optional[Path], typer.Option(
        "--output", "-o", help="write the page here (.html; default: beside the result, "
                               "RESULT.html)")] = None,
    no_open: Annotated[bool, typer.Option(
        "--no-open", help="write the page only; do not open it in the browser")] = False,
) -> None:
    """Explore a run's result in the browser: coupler force and deflection heatmaps with
    time and coupler cursors, the force profile at the cursor, the envelope, a coupler's
    history and force-deflection loop, speed, the track and brake pressures. The page is
    one HTML file that works offline (docs/viewer.md)."""
    from ltdsim.results.io import check_result_file, load_result
    from ltdsim.viz.explorer import NEEDED, VIEW_VARIABLES, is_page

    page = output if output is not None else result.with_suffix(".html")
    option = "--output" if output is not None else "--output (by default RESULT.html)"
    try:
        check_result_file(result)
        check_output(page, option, PAGE_SUFFIXES, inputs=(result,))
        if page.is_file() and not is_page(page):
            raise ScenarioError(option, [("", f"{page} exists and is not a page of ltdsim "
                                              "view; ltdsim does not write over it: give "
                                              "another -o FILE.html, or remove it first")])
        ds = load_result(result, needs=NEEDED, keep=VIEW_VARIABLES,
                         purpose="the viewer's heatmaps, profile and envelope draw from it")
        if ds.sizes.get("coupler", 0) == 0:
            raise ScenarioError(str(result), [("", "a train of one vehicle: it has no "
                                                   "couplers for the viewer to show")])
    except ScenarioError as exc:
        fail(exc)
        return
    from ltdsim.viz.explorer import write_page

    try:
        path, data, notes = write_page(ds, page, str(result))
    except OSError as exc:
        err_console.print(f"[bold red]error (writing failed):[/] "
                          f"{escape(str(exc.filename or page))}: "
                          f"{escape(exc.strerror or str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(3) from None
    size = path.stat().st_size / 1e6
    say(f"page written to {path} ({size:.1f} MB; {data.bins:,} time bins of the "
        f"{len(data.t):,} samples, {data.couplers} couplers)")
    for note in notes:
        say(f"not shown: {note}")
    if not no_open:
        import webbrowser

        if not webbrowser.open(path.resolve().as_uri()):
            say(f"no browser could be opened here: open {path} in one")
