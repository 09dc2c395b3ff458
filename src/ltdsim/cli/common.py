"""What every command shares: the consoles, the options several commands take, reading a
scenario or a saved result, simulating with progress, refusing bad options before any
work (one line naming the option and its allowed range), and writing tables.

Names here are the commands' vocabulary; nothing here is a command.
"""

from __future__ import annotations

import contextlib

import os
import tomllib
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from ltdsim.errors import LtdsimError, ScenarioError, SimulationError
from ltdsim.progress import Display
from ltdsim.results.outputs import check_output_files  # noqa: F401 (the commands' name)

console = Console()
err_console = Console(stderr=True)


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


SET_HELP = ("override a scenario key, e.g. solver.t_end=10 (TOML value; repeat for more "
            "keys; indices count from 0 as in the file)")


def result_or_scenario(file: Path, case: Optional[str], run: bool = True,
                        overrides: Optional[list[str]] = None, quiet: bool = False):
    """``(dataset, scenario)`` from a saved result (.nc; its scenario from the attributes)
    or from a scenario file with ``--set`` overrides (simulated when ``run``, with a
    progress bar unless ``quiet``). A saved result is not simulated again, so ``--set``
    and a ``--case`` other than the result's are refused."""
    import json

    from ltdsim.results.io import load_result
    from ltdsim.scenario import Scenario, load_scenario

    if file.suffix == ".nc":
        if overrides:
            raise ScenarioError("--set", [("", f"{file} is a saved result, not simulated "
                                               "again; give the scenario file to change it")])
        ds = load_result(file)  # (a ScenarioError in one line on a bad file)
        saved = json.loads(ds.attrs["scenario_json"])
        held = ds.attrs.get("case") or None
        if case is not None and case != held:
            raise ScenarioError("--case", [("", f"{file} is a saved result of case "
                                                f"{held or '(none)'}; --case chooses a case of "
                                                "a scenario file")])
        return ds, Scenario.from_saved(saved, str(file))
    sc = load_scenario(file, case=case)
    if overrides:
        sc = sc.with_overrides(parse_set(overrides), source="--set")
    return (simulate_shown(sc, quiet, file, "--set" if overrides else None) if run else None), sc


def scenario_label(sc) -> str:
    """Scenario name and case as plain text, e.g. ``heavy-haul [emergency]``."""
    return sc.name + (f" [{sc.case}]" if sc.case else "")


#: how a command that simulates but has no ``--max-time`` of its own lets a long run go
LONG_RUN = ("run it with `ltdsim run FILE --max-time SECONDS --output RESULT.nc` and "
            "analyse the saved result")
#: how ``ltdsim run`` lets a long run go
MAX_TIME_ANYWAY = "give --max-time SECONDS (0: no limit)"
MaxTimeOpt = Annotated[Optional[float], typer.Option(
    "--max-time", help="refuse a run estimated to take longer than this, s of wall time "
                       "(default 3600; 0: no limit)")]


def simulate_shown(sc, quiet: bool = False, source=None, step_source=None,
                   max_time: float | None = None, anyway: str = LONG_RUN):
    """Simulate ``sc``: refuse a fixed step above the method's largest stable step
    (naming ``step_source``, the ``--set`` that asked for it, or else ``source``), a
    recording too large for the memory available and a run estimated to take longer
    than ``max_time`` seconds (default :data:`ltdsim.engine.run.TIME_LIMIT`; 0 for no
    limit; ``anyway`` says how to raise it), naming ``source``, the scenario file;
    print the estimate of a run over :data:`~ltdsim.engine.run.ANNOUNCE_TIME`; warn about
    a step near the largest stable one, compile or load its kernel ("compiling (first
    run only)"), then a progress bar of simulated seconds on stderr (plain lines in a
    log, with the time left). A curving pass that fails after the run is one warning
    line, and the run is returned without its indicators."""
    from ltdsim.engine.preflight import check, warning
    from ltdsim.engine.run import ANNOUNCE_TIME, TIME_LIMIT, check_memory, check_time
    import warnings

    from ltdsim.engine.warmup import scenario_kernels, warm_up
    from ltdsim.results.simulate import CURVING_FAILED, simulate

    where = None if source is None else str(source)
    lim = check(sc, step_source or where)
    check_memory(sc, source=where)
    limit = TIME_LIMIT if max_time is None else (max_time or None)
    est = check_time(sc, limit, step_source or where, anyway)
    near = warning(lim)
    if near:
        err_console.print(f"[yellow]warning:[/] {escape(near)}", soft_wrap=True)
    with Display(err_console, quiet=quiet) as show:
        if est.seconds > ANNOUNCE_TIME:
            show.info(f"estimate for {scenario_label(sc)}: {est.line()}")
        warm_up(scenario_kernels([sc]), show.compiling, parallel=True)
        update = show.bar(f"simulating {scenario_label(sc)}", sc.solver.n_steps * sc.solver.dt,
                          "s simulated", "{:.1f}")
        update(0.0)
        with warnings.catch_warnings():  # (printed below as one line of its own)
            warnings.filterwarnings("ignore", message=CURVING_FAILED, category=RuntimeWarning)
            ds = simulate(sc, progress=lambda done, total: update(done),
                          time_limit=None)
    if ds.attrs.get("curving_error"):
        err_console.print(f"[yellow]warning:[/] {escape(ds.attrs['curving_error'])}",
                          soft_wrap=True)
    return ds


def fail(exc: LtdsimError) -> None:
    kind = ("invalid input" if isinstance(exc, ScenarioError) else
            "simulation failed" if isinstance(exc, SimulationError) else "run failed")
    # the message is plain text: "[brake]" or "[emergency]" must not be read as markup
    err_console.print(f"[bold red]error ({kind}):[/] {escape(str(exc))}", highlight=False,
                      soft_wrap=True)
    raise typer.Exit(2 if isinstance(exc, ScenarioError) else 3)


@contextlib.contextmanager
def executor_errors(scheduler: str | None, kept: str):
    """Around a sweep executor's run: a Dask scheduler that does not take the work is one
    line naming ``--scheduler``; an interrupt keeps the finished ``kept`` ("cases",
    "runs") and says how to resume (exit 130)."""
    try:
        yield
    except (OSError, TimeoutError) as exc:
        if not scheduler:
            raise
        fail(LtdsimError(f"--scheduler: the Dask scheduler at {scheduler} did not "
                         f"take the work: {exc}"))
    except KeyboardInterrupt:
        err_console.print(f"[yellow]interrupted: finished {kept} are kept; run the same "
                          "command again to resume[/]")
        raise typer.Exit(130) from None


def say(text: str) -> None:
    """Print a line of plain text (no markup: names and paths may hold brackets)."""
    console.print(text, markup=False, highlight=False, soft_wrap=True)


def check_number(option: str, value, lo=None, hi=None, *, lo_open: bool = False,
                  unit: str = "", whole: bool = False, also: str = "",
                  reason: str = "") -> None:
    """Refuse, before any work, a numeric option outside its range (or not finite):
    ``--series: must be a whole number from 1 to 10 (got 0)``. ``lo_open`` excludes
    ``lo``; ``also`` names an extra allowed value (``-1 (all cores)``); ``reason`` says
    after the value what sets the range."""
    import math

    ok = isinstance(value, (int, float)) and math.isfinite(value)
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value <= hi
    if ok:
        return
    u = f" {unit}" if unit else ""
    kind = "a whole number" if whole else "a number"

    def num(x):
        return str(int(x)) if whole else f"{x:g}"

    if lo is not None and hi is not None:
        rng = (f"in ({num(lo)}, {num(hi)}]{u}" if lo_open else
               f"from {num(lo)} to {num(hi)}{u}" if whole else f"in [{num(lo)}, {num(hi)}]{u}")
    elif lo is not None:
        rng = f"greater than {num(lo)}{u}" if lo_open else f"at least {num(lo)}{u}"
    else:
        rng = f"at most {num(hi)}{u}"
    extra = f", or {also}" if also else ""
    why = f": {reason}" if reason else ""
    got = (str(int(value)) if whole and isinstance(value, int) else f"{value:g}")
    raise ScenarioError(option, [("", f"must be {kind} {rng}{extra} (got {got}){why}")])


def check_workers(workers: Optional[int], option: str = "--workers") -> None:
    """Local worker processes: at least 1 (none given: one per core)."""
    if workers is not None:
        check_number(option, workers, 1, 1024, whole=True)


def check_scheduler(address: Optional[str], timeout: float = 3.0) -> None:
    """Refuse, before any work and within ``timeout`` seconds, a Dask scheduler address
    that is malformed or where nothing answers."""
    import socket
    from urllib.parse import urlsplit

    if address is None:
        return
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:  # a port that is not a number
        host = port = None
    if parts.scheme not in ("tcp", "tls") or not host or port is None:
        raise ScenarioError("--scheduler", [("", f"not a scheduler address: {address!r}; "
                                                  "give tcp://HOST:PORT (e.g. "
                                                  "tcp://10.0.0.5:8786)")])
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        why = "no answer" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        raise ScenarioError("--scheduler", [("", f"cannot reach a Dask scheduler at "
                                                  f"{address} ({why} within {timeout:g} s); "
                                                  "start it or check the address")]) from None
    # something listens there: is it a Dask scheduler? (a proxy or another service
    # answers with bytes a Dask client cannot read, or nothing at all: a Dask client's
    # own handshake waits for an answer without end, so the whole exchange is bounded
    # here)
    kind = _dask_identity(address, timeout)
    if kind != "Scheduler":
        why = (f"it gives no Dask answer within {timeout:g} s" if kind is TimeoutError
               else "what answers there does not speak Dask's protocol" if kind is None
               else f"it is a Dask {kind}")
        raise ScenarioError("--scheduler", [("", f"{address} is not a Dask scheduler "
                                                  f"({why}); give the scheduler's address, "
                                                  "tcp://HOST:PORT (e.g. "
                                                  "tcp://10.0.0.5:8786)")])


def _dask_identity(address: str, timeout: float):
    """The ``type`` a Dask server at ``address`` gives for itself ("Scheduler",
    "Worker", "Nanny"); None when what answers there does not speak Dask's protocol,
    TimeoutError when it gives no answer within ``timeout`` seconds (all of it: connect,
    handshake, reply)."""
    import asyncio

    from distributed.comm import connect
    from distributed.security import Security

    async def ask():
        comm = await connect(address, timeout=timeout,
                             **Security().get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = asyncio.run(asyncio.wait_for(ask(), timeout))
    except TimeoutError:
        return TimeoutError
    except Exception:  # noqa: BLE001 - whatever the far end sent, or its silence
        return None
    kind = reply.get("type") if isinstance(reply, dict) else None
    return kind if isinstance(kind, str) else None


#: result files ``-o/--output`` writes (netCDF-4, readable by MATLAB, Python, Julia, R)
RESULT_SUFFIXES = (".nc",)


def image_suffixes() -> tuple[str, ...]:
    """Figure formats matplotlib can write here (``.png``, ``.svg``, ``.pdf``, ...)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    return tuple(f".{k}" for k in sorted(FigureCanvasAgg.get_supported_filetypes()))


def check_output(path: Optional[Path], option: str, suffixes, inputs=()) -> None:
    """Refuse, before any work, an output file that is one of the ``inputs``, an existing
    folder, a file whose suffix is not one of ``suffixes`` (what ltdsim writes under that
    option), or a file in a folder ltdsim cannot write into (or make)."""
    if path is None:
        return
    from ltdsim.results.io import same_file

    for given in inputs:
        if given is not None and same_file(path, given):
            raise ScenarioError(option, [("", f"{path} is an input of this command; ltdsim "
                                              "never writes over its input: choose another "
                                              "path")])
    if path.is_dir():
        raise ScenarioError(option, [("", f"{path} is a folder; give a file name")])
    if path.suffix.lower() not in suffixes:
        what = f"suffix {path.suffix!r}" if path.suffix else "a file name without a suffix"
        kinds = {".nc": ".nc (netCDF-4)"}
        raise ScenarioError(option, [("", f"cannot write {what} ({path}); accepted: "
                                          f"{', '.join(kinds.get(x, x) for x in suffixes)}")])
    check_writable(path.parent, option)


def check_new(path: Optional[Path], option: str) -> None:
    """Refuse, before any work, an output file that already exists (a scenario, a preset,
    someone's notes): ltdsim writes such a file only where there is none."""
    if path is not None and path.is_file():
        raise ScenarioError(option, [("", f"{path} exists; ltdsim does not write over an "
                                          "existing file: choose a new name, or remove it "
                                          "first")])


def check_folder(path: Path, option: str = "--output") -> None:
    """Refuse, before any work, an output folder that exists as a file or that cannot be
    written (or made)."""
    if path.exists() and not path.is_dir():
        raise ScenarioError(option, [("", f"{path} is a file, not a folder; give a folder "
                                          "for the tables and figures")])
    check_writable(path, option)


def check_writable(folder: Path, option: str) -> None:
    """Refuse, before any work, a ``folder`` ltdsim could not write into: create and
    remove a file in it (or, when it does not exist yet, in the nearest folder above it
    that does, where it would be made)."""
    import tempfile

    there = Path(os.path.abspath(folder))
    while not there.exists() and there != there.parent:
        there = there.parent
    if not there.is_dir():
        raise ScenarioError(option, [("", f"cannot make the folder {folder}: {there} is a "
                                          "file; choose another path")])
    try:
        fd, probe = tempfile.mkstemp(prefix=".ltdsim-write-test-", dir=there)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ScenarioError(option, [("", f"cannot write in {there} "
                                          f"({exc.strerror or type(exc).__name__}); choose a "
                                          "folder you can write to")]) from None


def write_csv(frame, path: Path, index: bool = False) -> None:
    """Write a table as CSV, atomically, with at most 6 significant figures."""
    from ltdsim.results.io import atomic_path

    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=index, float_format="%.6g")


#: the CLI's header of coupler and vehicle numbers (people count from 1)
COUPLER_COL = "coupler (1 = behind the lead)"
VEHICLE_COL = "vehicle (1 = lead)"


def plain_table(title: str, columns, justify: str = "right") -> Table:
    """A rich table whose title, column headers and cells stay plain text: rich would
    read "[kN]", "[m/s]" or a case name like "[emergency]" as markup and drop it. The
    first column of two-column (quantity, value) tables is left-aligned."""
    table = _PlainTable(title=Text(title))
    for k, col in enumerate(columns):
        align = "left" if len(columns) == 2 and k == 0 else justify
        table.add_column(Text(col), justify=align)
    return table


class _PlainTable(Table):
    def add_row(self, *cells, **kw) -> None:
        super().add_row(*(Text(c) if isinstance(c, str) else c for c in cells), **kw)


CaseOpt = Annotated[Optional[str], typer.Option(
    "--case", "-c", help="named case of the scenario file (its cases.NAME table) to apply")]
SetOpt = Annotated[Optional[list[str]], typer.Option("--set", "-s", help=SET_HELP)]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")]

PresetOpt = Annotated[Optional[str], typer.Option("--preset", help="gear parameter set")]
ScenarioOpt = Annotated[Optional[Path], typer.Option("--scenario", help="take a coupler "
                                                                         "from this file")]
CouplerOpt = Annotated[int, typer.Option("--coupler", help="coupler number in --scenario, "
                                                           "1 = behind the lead (1 to n-1)")]


def gear_params(preset: Optional[str], scenario: Optional[Path], coupler: int):
    """The coupler parameters of ``--preset NAME`` or of coupler ``coupler`` (1 = behind
    the lead) of the ``--scenario`` file: exactly one of the two."""
    from pydantic import ValidationError

    from ltdsim.scenario import CouplerParams, gear_presets, load_scenario
    from ltdsim.scenario.messages import _problems

    if (preset is None) == (scenario is None):
        raise ScenarioError("gear", [("", "give either --preset NAME or --scenario FILE "
                                          f"(presets: {', '.join(gear_presets())})")])
    if preset is not None:
        try:
            return CouplerParams(preset=preset)
        except ValidationError as exc:
            raise ScenarioError("--preset", _problems(exc)) from None
    sc = load_scenario(scenario)
    if not 1 <= coupler <= sc.n_couplers:
        raise ScenarioError("--coupler", [("", f"coupler {coupler} is out of range 1-"
                                               f"{sc.n_couplers} for {scenario} (1 = behind "
                                               "the lead)")])
    return sc.coupler(coupler - 1)


def case_counter(show: Display, description: str):
    """``progress(done, total)`` that starts a bar of ``show`` at its first call."""
    bar = {}

    def progress(done: int, total: int) -> None:
        if "update" not in bar:
            bar["update"] = show.bar(description, total, "cases")
        bar["update"](done)
    return progress
