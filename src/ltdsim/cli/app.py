"""Command line: ``ltdsim run FILE [--case NAME] [-o OUT.nc] [--plot FIG.png]``.

The CLI only parses arguments, shows progress and prints tables; every number comes
from the library.
"""

from __future__ import annotations

import os
import sys
import tomllib
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from ltdsim.errors import LtdsimError, ScenarioError, SimulationError
from ltdsim.progress import Display

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="ltdsim: longitudinal train dynamics simulation and analysis.")
console = Console()
err_console = Console(stderr=True)


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


def _result_or_scenario(file: Path, case: Optional[str], run: bool = True,
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
    return (_simulate(sc, quiet, file, "--set" if overrides else None) if run else None), sc


def _label(sc) -> str:
    """Scenario name and case as plain text, e.g. ``heavy-haul [emergency]``."""
    return sc.name + (f" [{sc.case}]" if sc.case else "")


def _simulate(sc, quiet: bool = False, source=None, step_source=None):
    """Simulate ``sc``: refuse a fixed step above the method's largest stable step
    (naming ``step_source``, the ``--set`` that asked for it, or else ``source``) and a
    recording too large for the memory available (naming ``source``, the scenario file),
    warn about a step near the largest stable one, compile or load its kernel
    ("compiling (first run only)"), then a progress bar of simulated seconds on stderr
    (plain lines in a log)."""
    from ltdsim.engine.preflight import check, warning
    from ltdsim.engine.run import check_memory
    from ltdsim.engine.warmup import scenario_kernels, warm_up
    from ltdsim.results.simulate import simulate

    lim = check(sc, step_source or (None if source is None else str(source)))
    check_memory(sc, source=None if source is None else str(source))
    near = warning(lim)
    if near:
        err_console.print(f"[yellow]warning:[/] {escape(near)}", soft_wrap=True)
    with Display(err_console, quiet=quiet) as show:
        warm_up(scenario_kernels([sc]), show.compiling)
        update = show.bar(f"simulating {_label(sc)}", sc.solver.n_steps * sc.solver.dt,
                          "s simulated", "{:.1f}")
        update(0.0)
        return simulate(sc, progress=lambda done, total: update(done))


def _fail(exc: LtdsimError) -> None:
    kind = ("invalid input" if isinstance(exc, ScenarioError) else
            "simulation failed" if isinstance(exc, SimulationError) else "run failed")
    # the message is plain text: "[brake]" or "[emergency]" must not be read as markup
    err_console.print(f"[bold red]error ({kind}):[/] {escape(str(exc))}", highlight=False,
                      soft_wrap=True)
    raise typer.Exit(2 if isinstance(exc, ScenarioError) else 3)


def _say(text: str) -> None:
    """Print a line of plain text (no markup: names and paths may hold brackets)."""
    console.print(text, markup=False, highlight=False, soft_wrap=True)


def _check_number(option: str, value, lo=None, hi=None, *, lo_open: bool = False,
                  unit: str = "", whole: bool = False, also: str = "") -> None:
    """Refuse, before any work, a numeric option outside its range (or not finite):
    ``--series: must be a whole number from 1 to 10 (got 0)``. ``lo_open`` excludes
    ``lo``; ``also`` names an extra allowed value (``-1 (all cores)``)."""
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
    raise ScenarioError(option, [("", f"must be {kind} {rng}{extra} (got {value:g})")])


def _check_workers(workers: Optional[int], option: str = "--workers") -> None:
    """Local worker processes: at least 1 (none given: one per core)."""
    if workers is not None:
        _check_number(option, workers, 1, 1024, whole=True)


def _check_scheduler(address: Optional[str], timeout: float = 3.0) -> None:
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
    # answers with bytes a Dask client cannot read)
    from distributed import Client

    try:
        Client(address, timeout=timeout).close()
    except Exception as exc:  # noqa: BLE001 - whatever the far end sent
        why = (" ".join(str(exc).split())[:100] if isinstance(exc, (OSError, TimeoutError))
               else "what answers there does not speak Dask's protocol")
        raise ScenarioError("--scheduler", [("", f"no Dask scheduler answers at {address} "
                                                  f"({why}); start it or check the "
                                                  "address")]) from None


#: result files ``-o/--output`` writes (netCDF-4, readable by MATLAB, Python, Julia, R)
RESULT_SUFFIXES = (".nc",)


def image_suffixes() -> tuple[str, ...]:
    """Figure formats matplotlib can write here (``.png``, ``.svg``, ``.pdf``, ...)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    return tuple(f".{k}" for k in sorted(FigureCanvasAgg.get_supported_filetypes()))


def _check_output(path: Optional[Path], option: str, suffixes, inputs=()) -> None:
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
    _check_writable(path.parent, option)


def _check_folder(path: Path, option: str = "--output") -> None:
    """Refuse, before any work, an output folder that exists as a file or that cannot be
    written (or made)."""
    if path.exists() and not path.is_dir():
        raise ScenarioError(option, [("", f"{path} is a file, not a folder; give a folder "
                                          "for the tables and figures")])
    _check_writable(path, option)


def _check_writable(folder: Path, option: str) -> None:
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


def _csv(frame, path: Path, index: bool = False) -> None:
    """Write a table as CSV, atomically, with at most 6 significant figures."""
    from ltdsim.results.io import atomic_path

    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=index, float_format="%.6g")


#: the CLI's header of coupler and vehicle numbers (people count from 1)
COUPLER_COL = "coupler (1 = behind the lead)"
VEHICLE_COL = "vehicle (1 = lead)"


def _table(title: str, columns, justify: str = "right") -> Table:
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


@app.command()
def run(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML)")],
    case: Annotated[Optional[str], typer.Option("--case", "-c", help="named case to apply")] = None,
    output: Annotated[Optional[Path], typer.Option(
        "--output", "-o", help="write the result as netCDF-4 (a .nc file)")] = None,
    plot: Annotated[Optional[Path], typer.Option(
        "--plot", "-p", help="write an overview figure (.png, .svg, .pdf, ...)")] = None,
    set_: Annotated[Optional[list[str]], typer.Option("--set", "-s", help=SET_HELP)] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")] = False,
    report: Annotated[Optional[Path], typer.Option(
        "--report", help="write a one-page HTML report of the run (coupler peaks and, when the "
                         "scenario has a curving table, the curving-safety section) into "
                         "this folder")] = None,
) -> None:
    """Simulate one scenario (optionally one named case) and summarise coupler forces."""
    from ltdsim.results.io import save_result
    from ltdsim.scenario import load_scenario
    from ltdsim.results.summary import coupler_summary, critical_rows, run_summary, travel_warning

    try:
        _check_output(output, "--output", RESULT_SUFFIXES, inputs=(file,))
        if plot is not None:  # (matplotlib only when a figure is asked for)
            _check_output(plot, "--plot", image_suffixes(), inputs=(file,))
        if report is not None:
            _check_folder(report, "--report")
        sc = load_scenario(file, case=case)
        if set_:
            sc = sc.with_overrides(parse_set(set_), source="--set")
        if sc.solver.record is not None and (plot is not None or report is not None):
            raise ScenarioError(str(file), [(
                "solver.record", f"{'--plot' if plot is not None else '--report'} draws "
                "from the whole recording; leave solver.record out (it records only "
                f"{', '.join(sc.solver.record) or 'the train signals'})")])
        brake_plot = brake_figure_path(plot) if plot is not None and _fluid(sc) else None
        if brake_plot is not None:
            _check_output(brake_plot, "--plot (the brake-pressure figure beside it)",
                          image_suffixes(), inputs=(file,))
        curving_plot = (curving_figure_path(plot) if plot is not None
                        and sc.curving is not None else None)
        if curving_plot is not None:
            _check_output(curving_plot, "--plot (the curving figure beside it)",
                          image_suffixes(), inputs=(file,))
        label = _label(sc)  # plain text: _table keeps it so
        ds = _simulate(sc, quiet, file, "--set" if set_ else None)
    except (ScenarioError, SimulationError) as exc:
        _fail(exc)
        return

    summary = coupler_summary(ds)
    shown = critical_rows(summary)
    title = f"Coupler forces: {label}"
    if len(shown) < len(summary):
        title += f" (the {len(shown)} most loaded of {len(summary)} couplers)"
    table = _table(title, (COUPLER_COL, "max tension [kN]", "at [s]", "max compression [kN]",
                           "at [s]"))
    for j, row in shown.iterrows():
        table.add_row(str(j + 1), *_peak(row.max_tension_N, row.t_max_tension_s),
                      *_peak(row.max_compression_N, row.t_max_compression_s))
    console.print(table)
    s = run_summary(ds)
    tracking = (f"RMS speed error {_speed(s['rms_speed_error_m_s'], 4)}, "
                f"max {_speed(s['max_speed_error_m_s'], 3)}; "
                if s["rms_speed_error_m_s"] == s["rms_speed_error_m_s"] else "")
    console.print(
        f"{tracking}"
        + (f"max |acceleration| {s['max_abs_acceleration_m_s2']:.3f} m/s^2; "
           if s["max_abs_acceleration_m_s2"] == s["max_abs_acceleration_m_s2"] else "")
        + f"peak traction {s['max_traction_N'] / 1e3:.1f} kN; "
        f"samples over adhesion {s['samples_over_adhesion']}; "
        + (f"peak air brake {s['max_air_brake_N'] / 1e3:.0f} kN; " if s["max_air_brake_N"] else "")
        + (f"bs23 {ds.attrs['steps']:,} steps ({ds.attrs['rejected_steps']:,} rejected); "
           if sc.solver.adaptive else "")
        + f"{s['simulated_s']:.1f} s simulated in {s['wall_time_s']:.2f} s wall"
        + (f" (+{s['compile_time_s']:.1f} s compiling, once)" if s["compile_time_s"] > 0.5 else ""))
    _print_motion(ds)
    _print_energy(ds, sc)
    brake = _print_fluid_brake(ds)
    curving = _print_curving(ds)
    warning = travel_warning(ds, sc)
    if warning:
        err_console.print(f"[yellow]warning:[/] {escape(warning)}")
    try:  # (checked before the run; a disk that fills up meanwhile still fails here)
        if output is not None:
            save_result(ds, output)
            _say(f"result written to {output}")
        if plot is not None:
            from ltdsim.viz.plotting import save_overview

            save_overview(ds, plot)
            _say(f"figure written to {plot}")
        if brake_plot is not None and "brake_pipe_pressure" in ds:
            from ltdsim.viz.plotting import save_brake_pressures

            save_brake_pressures(ds, brake_plot, summary=brake)
            _say(f"brake-pressure figure written to {brake_plot}")
        if curving_plot is not None and curving is not None:
            from ltdsim.viz.plotting import save_curving

            save_curving(ds, curving_plot, summary=curving)
            _say(f"curving figure written to {curving_plot}")
        if report is not None:
            from ltdsim.study.report import write_run_report

            page = write_run_report(ds, report, f"ltdsim run: {label}")
            _say(f"report written to {page}")
    except OSError as exc:
        err_console.print(f"[bold red]error (writing failed):[/] "
                          f"{escape(str(exc.filename or output or plot))}: "
                          f"{escape(exc.strerror or str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(3) from None


def _speed(v: float, digits: int = 1) -> str:
    """A speed in m/s with km/h beside it (a speed that rounds to zero printed as 0, not
    as -0)."""
    v = v if round(v, digits) != 0.0 else 0.0
    return f"{v:.{digits}f} m/s ({3.6 * v:.{digits}f} km/h)"


def _peak(force: float, time: float) -> tuple[str, str]:
    """A peak force (kN) and its time (s), or dashes where there was none (0 N: a coupler
    never in compression, or never in tension)."""
    if not force > 0.0:
        return "-", "-"
    return f"{force / 1e3:.1f}", f"{time:.2f}"


def _print_motion(ds) -> None:
    """The lead vehicle's top and final speed and, for a run that brakes to a stop, the
    stopping distance and time (ltdsim.results.summary.stopping)."""
    from ltdsim.results.summary import speeds, stopping

    if "velocity" not in ds:  # not recorded (solver.record)
        return
    v = speeds(ds)
    _say(f"lead vehicle: top speed {_speed(v['max_speed_m_s'])}, final speed "
         f"{_speed(v['final_speed_m_s'])}")
    stop = stopping(ds)
    if stop is not None:
        _say(f"stopped in {stop['stopping_distance_m']:.1f} m and {stop['stopping_time_s']:.1f} s "
             f"from {_speed(stop['speed_m_s'])}, counted from the brake application at "
             f"{stop['brake_time_s']:.2f} s (the first brake command or dynamic-brake demand "
             "after the last traction demand; lead vehicle)")


def _print_energy(ds, sc) -> None:
    """The energy balance of a run with ``solver.energy = true`` (ltdsim.results.summary
    .energy_summary): each term in MJ and kWh, the closure error, and per km and gross
    tonne-km for a run that moved."""
    from ltdsim.results.summary import KWH, energy_summary

    e = energy_summary(ds, sc)
    if e is None:
        return
    table = _table("Energy balance (work since the start; + in: traction; + out: the rest)",
                   ("term", "energy [MJ]", "energy [kWh]"))
    rows = [("traction at the rail, motoring (in)", e["traction_energy"]),
            ("dynamic brake at the rail (out: regenerable)", e["dynamic_brake_energy"]),
            ("air brakes (out)", e["air_brake_energy"]),
            ("Davis running resistance (out)", e["davis_energy"]),
            ("grade: potential energy gained (out)", e["grade_energy"]),
            ("curve resistance (out)", e["curve_energy"]),
            ("couplers: dissipated by their gears (out)", e["gear_dissipated"]),
            ("couplers: stored at the end (out)", e["gear_stored"]),
            ("kinetic energy gained (out)", e["kinetic_change"])]
    def amount(value: float, unit: float) -> str:
        # 4 significant figures, grouped thousands, no digits below a millionth of the
        # throughput (round-off)
        if abs(value) <= 1e-9 * max(e["throughput"], 1.0):
            return "0"
        x = value / unit
        return f"{x:,.0f}" if abs(x) >= 1e4 else f"{x:.4g}"

    for name, value in rows:
        table.add_row(name, *(("-", "-") if value != value else
                              (amount(value, 1e6), amount(value, KWH))))
    console.print(table)
    share = e["balance_error_share"]
    _say(f"energy balance closes to {e['largest_balance_error']:.3g} J at worst"
         + (f" ({share:.2g} of the traction throughput, {e['throughput'] / 1e6:.4g} MJ)"
            if share == share else ""))
    if e["traction_kwh_per_km"] == e["traction_kwh_per_km"]:
        def kwh(x: float) -> str:
            x /= KWH
            return f"{x:,.0f}" if abs(x) >= 1e3 else f"{x:.4g}"

        _say(f"traction at the rail: {kwh(e['traction_energy'])} kWh over "
             f"{abs(e['distance_m']) / 1e3:.3g} km, {e['traction_kwh_per_km']:.3g} kWh/km, "
             f"{e['traction_wh_per_gross_tonne_km']:.3g} Wh per gross tonne-km "
             f"({e['gross_tonnes']:,.0f} t); dynamic braking took back "
             f"{kwh(e['dynamic_brake_energy'])} kWh at the rail (what regeneration can "
             "recover before the drive's losses)")


def _fluid(sc) -> bool:
    """Whether the scenario brakes with the fluid air brake (``brake.model = "fluid"``)."""
    return getattr(sc.brake, "model", "lumped") == "fluid"


def curving_figure_path(plot: Path) -> Path:
    """Where ``ltdsim run --plot FIG`` writes the curving figure of a run with
    ``[curving]``: beside FIG, ``<stem>-curving<suffix>``."""
    return plot.with_name(f"{plot.stem}-curving{plot.suffix}")


def _print_curving(ds) -> dict | None:
    """The worst wheel L/V, wheelset force and coupler angle of a run with [curving]."""
    from ltdsim.results.summary import curving_summary

    c = curving_summary(ds)
    if c is None:
        return None
    _say(f"curving: worst wheel L/V {c['max_l_over_v']:.3f} ({100 * c['l_over_v_share_of_limit']:.0f} % "
         f"of Nadal's {c['nadal_limit']:.3f}) at vehicle {c['l_over_v_vehicle']}, "
         f"{c['l_over_v_time_s']:.1f} s, chainage {c['l_over_v_position_m']:.0f} m; "
         f"largest wheelset lateral force {c['max_wheelset_force_N'] / 1e3:.1f} kN "
         f"({100 * c['wheelset_force_share_of_limit']:.0f} % of Prud'homme's "
         f"{c['prudhomme_limit_N'] / 1e3:.1f} kN) at vehicle {c['wheelset_force_vehicle']}, "
         f"{c['wheelset_force_time_s']:.1f} s")
    if "max_coupler_angle_rad" in c:
        _say(f"curving: largest coupler angle {1e3 * c['max_coupler_angle_rad']:.1f} mrad at coupler "
             f"{c['coupler_angle_coupler']}, {c['coupler_angle_time_s']:.1f} s; lateral coupler "
             f"components up to {c['max_inward_coupler_force_N'] / 1e3:.1f} kN inward (draft), "
             f"{c['max_outward_coupler_force_N'] / 1e3:.1f} kN outward (buff)"
             + (f"; {c['couplers_at_stops']} couplers reach their angle stops"
                if "couplers_at_stops" in c else ""))
    return c


def brake_figure_path(plot: Path) -> Path:
    """Where ``ltdsim run --plot FIG`` writes the brake-pressure figure of a fluid-brake
    run: beside FIG, ``<stem>-brake<suffix>``."""
    return plot.with_name(f"{plot.stem}-brake{plot.suffix}")


def _print_fluid_brake(ds) -> dict | None:
    """For a fluid-brake run, the first application's propagation along the train and the
    rear cylinder's 95 % time (ltdsim.results.summary.fluid_brake_summary); returns the summary
    (None for another run)."""
    from ltdsim.results.summary import VENTED, fluid_brake_summary

    b = fluid_brake_summary(ds)
    if b is None:
        return None
    src = ", ".join(str(c + 1) for c in b["sources"])
    plural = "s" if len(b["sources"]) > 1 else ""
    line = (f"fluid brake: application at {b['command_time_s']:.2f} s from vehicle{plural} "
            f"{src} (pipe there down {b['control_pipe_drop_Pa'] / 1e5:.2f} bar by "
            f"{b['end_time_s']:.1f} s); ")
    drop = f"{b['threshold_Pa'] / 1e5:.1f} bar"
    if b["propagation_time_s"] == b["propagation_time_s"]:
        line += (f"propagation {b['end_to_end_speed_m_s']:.0f} m/s end to end (the pipe's "
                 f"{drop} drop {b['propagation_time_s']:.2f} s after the command at vehicle "
                 f"{b['farthest_vehicle'] + 1}, {b['farthest_distance_m']:.0f} m away)")
        if b["propagation_speed_m_s"] == b["propagation_speed_m_s"]:
            line += (f", {b['propagation_speed_m_s']:.0f} m/s along the train (slope over "
                     f"{b['vehicles_reached']} vehicles)")
        line += "; "
    else:
        line += f"the {drop} drop did not reach vehicle {b['farthest_vehicle'] + 1}; "
    if b["vent_time_s"] == b["vent_time_s"]:
        line += (f"vent front {b['vent_front_speed_m_s']:.0f} m/s end to end (pipe below "
                 f"{VENTED / 1e5:.0f} bar at vehicle {b['farthest_vehicle'] + 1} after {b['vent_time_s']:.2f} s); ")
    if b["last_cylinder_95_s"] == b["last_cylinder_95_s"]:
        line += (f"rear cylinder (vehicle {b['last_vehicle'] + 1}) at 95 % of "
                 f"{b['last_cylinder_final_Pa'] / 1e5:.2f} bar {b['last_cylinder_95_s']:.1f} s "
                 "after the command")
        if not b["last_cylinder_settled"]:
            line += " (still filling at the end: a lower bound)"
        if b["slowest_cylinder_95_s"] > b["last_cylinder_95_s"] + 0.05:
            line += (f", slowest vehicle {b['slowest_vehicle'] + 1} at "
                     f"{b['slowest_cylinder_95_s']:.1f} s")
    elif b["last_vehicle"] >= 0:
        line += f"rear cylinder (vehicle {b['last_vehicle'] + 1}) did not apply"
    _say(line.rstrip("; "))
    return b


gear_app = typer.Typer(no_args_is_help=True, help="A single draft gear: loops and impacts.")
app.add_typer(gear_app, name="gear")


def _gear_params(preset: Optional[str], scenario: Optional[Path], coupler: int):
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


PresetOpt = Annotated[Optional[str], typer.Option("--preset", help="gear parameter set")]
ScenarioOpt = Annotated[Optional[Path], typer.Option("--scenario", help="take a coupler "
                                                                         "from this file")]
CouplerOpt = Annotated[int, typer.Option("--coupler", help="coupler number in --scenario, "
                                                           "1 = behind the lead (1 to n-1)")]


@gear_app.command("loop")
def gear_loop(
    preset: PresetOpt = None, scenario: ScenarioOpt = None, coupler: CouplerOpt = 1,
    amplitude: Annotated[float, typer.Option(help="peak gear deflection beyond slack, m")] = 0.08,
    period: Annotated[float, typer.Option(help="period of one cycle, s")] = 10.0,
    cycles: Annotated[int, typer.Option(help="number of cycles")] = 2,
    buff: Annotated[bool, typer.Option(help="compress (buff) instead of stretching")] = False,
    plot: Annotated[Path, typer.Option("--plot", "-p", help="figure file (.png, .svg, "
                                                            ".pdf, ...)")] = Path(
        "results/gear-loop.png"),
) -> None:
    """Cycle one gear through a prescribed deflection and plot its force-deflection loop."""
    import numpy as np

    from ltdsim.analysis.gears import drive_deflection, loop_energy

    try:
        _check_output(plot, "--plot", image_suffixes(), inputs=(scenario,))
        _check_number("--amplitude", amplitude, 0.0, 1.0, lo_open=True, unit="m")
        _check_number("--period", period, 0.1, 3600.0, unit="s")
        _check_number("--cycles", cycles, 1, 100, whole=True)
        params = _gear_params(preset, scenario, coupler)
    except ScenarioError as exc:
        _fail(exc)
        return
    t = np.linspace(0.0, cycles * period, int(cycles * period / 1e-3) + 1)
    sign = -1.0 if buff else 1.0
    d = sign * (0.5 * params.slack + amplitude * 0.5 * (1 - np.cos(2 * np.pi * t / period)))
    ds = drive_deflection(params, t, d)
    energy = loop_energy(ds) / cycles
    console.print(f"{params.model} gear: peak force {abs(ds.force).max().item() / 1e3:.1f} kN, "
                  f"energy absorbed per cycle {energy / 1e3:.2f} kJ")
    from ltdsim.viz.plotting import save_gear_loop

    save_gear_loop(ds, plot, title=f"{preset or scenario} ({params.model})")
    _say(f"figure written to {plot}")


@gear_app.command("impact")
def gear_impact(
    preset: PresetOpt = None, scenario: ScenarioOpt = None, coupler: CouplerOpt = 1,
    speeds: Annotated[str, typer.Option(help="impact speeds, m/s, comma separated")] = "0.5,1,1.5,2,2.5,3",
    mass: Annotated[float, typer.Option(help="mass of each wagon, kg")] = 90000.0,
    csv: Annotated[Optional[Path], typer.Option(help="write the table as CSV")] = None,
) -> None:
    """Run a wagon into a standing wagon at several speeds: peak force, travel, energy."""
    import pandas as pd

    from ltdsim.analysis.gears import impact

    try:
        _check_output(csv, "--csv", (".csv",), inputs=(scenario,))
        _check_number("--mass", mass, 0.0, 1e6, lo_open=True, unit="kg")
        params = _gear_params(preset, scenario, coupler)
        values = [float(v) for v in speeds.split(",") if v.strip()]
        if not values:
            raise ValueError
        for v in values:
            _check_number("--speeds", v, 0.0, 30.0, lo_open=True, unit="m/s")
    except ScenarioError as exc:
        _fail(exc)
        return
    except ValueError:
        _fail(ScenarioError("--speeds", [("", f"not a list of numbers: {speeds!r}")]))
        return
    rows = []
    table = _table(f"Impact of two {mass / 1e3:.0f} t wagons ({params.model} gear)",
                   ("speed [m/s]", "speed [km/h]", "peak force [kN]", "max deflection [mm]",
                    "energy absorbed [kJ]", "share of relative KE"))
    for v in values:
        r = impact(params, v, mass_moving=mass, mass_standing=mass)
        rel_ke = 0.25 * mass * v * v  # kinetic energy of the relative motion, J
        rows.append({k: r[k] for k in ("speed_m_s", "peak_force_N", "max_deflection_m",
                                       "energy_absorbed_J")})
        table.add_row(f"{v:g}", f"{3.6 * v:.1f}", f"{r['peak_force_N'] / 1e3:.0f}",
                      f"{r['max_deflection_m'] * 1e3:.1f}", f"{r['energy_absorbed_J'] / 1e3:.2f}",
                      f"{r['energy_absorbed_J'] / rel_ke:.0%}")
    console.print(table)
    if csv is not None:
        _csv(pd.DataFrame(rows), csv)
        _say(f"table written to {csv}")


@gear_app.command("ratings")
def gear_ratings(
    travel: Annotated[float, typer.Option(help="rated travel, m")],
    force: Annotated[float, typer.Option(help="force at rated travel (impedance), N")],
    capacity: Annotated[float, typer.Option(help="energy to close to rated travel, J")],
    absorptivity: Annotated[float, typer.Option(help="share of the capacity absorbed, 0-1")],
    preload: Annotated[float, typer.Option(help="force at zero deflection, N")] = 0.0,
    series: Annotated[int, typer.Option(help="identical gears in series in the connection "
                                             "(2: one in each wagon end)")] = 1,
    slack: Annotated[float, typer.Option(help="coupling free play to write, m")] = 0.0,
    toml: Annotated[Optional[Path], typer.Option(help="write the gear as TOML coupler keys")
                    ] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", "-p", help="loop figure")] = None,
) -> None:
    """A table gear from its catalogue ratings (travel, force, capacity, absorptivity),
    checked by closing and releasing it slowly on the rig."""
    import numpy as np

    from ltdsim.analysis.gears import drive_deflection, loop_energy, table_from_ratings, table_toml
    from ltdsim.scenario import CouplerParams

    try:
        _check_output(toml, "--toml", (".toml",))
        _check_output(plot, "--plot", image_suffixes())
        _check_number("--slack", slack, 0.0, 1.0, unit="m")
    except ScenarioError as exc:
        _fail(exc)
        return
    try:
        gear = table_from_ratings(travel, force, capacity, absorptivity, preload=preload,
                                  series=series)
    except ValueError as exc:
        key, _, why = str(exc).partition(" ")
        _fail(ScenarioError("ratings", [(f"--{key}", why)]))
        return
    params = CouplerParams(**{k: v for k, v in gear.items() if k != "exponent"})
    t = np.linspace(0.0, 20.0, 20001)
    # one slow closing and release of the whole connection (its gears in series)
    d = series * gear["travel"] * 0.5 * (1 - np.cos(2 * np.pi * t / 20.0))
    ds = drive_deflection(params, t, d, dt=1e-3)
    half = len(t) // 2 + 1
    closing = ds.isel(time=slice(0, half))
    taken, absorbed = loop_energy(closing), loop_energy(ds)
    table = _table("Table gear from ratings (rig: one slow closing and release)",
                   ("quantity", "asked", "gear on the rig"))
    table.add_row("force at travel [kN]", f"{force / 1e3:.1f}",
                  f"{float(ds.force.max()) / 1e3:.1f}")
    table.add_row("travel [mm]", f"{series * travel * 1e3:.1f}",
                  f"{float(ds.deflection.max()) * 1e3:.1f}")
    table.add_row("capacity [kJ]", f"{series * capacity / 1e3:.2f}",
                  f"{taken / 1e3:.2f}")
    table.add_row("absorptivity [%]", f"{absorptivity:.1%}",
                  f"{absorbed / taken:.1%}")
    table.add_row("loading exponent n [-]", "", f"{gear['exponent']:.3f}")
    table.add_row("k_locked [N/m]", "", f"{gear['k_locked']:.4g}")
    console.print(table)
    if plot is not None:
        from ltdsim.viz.plotting import save_gear_loop

        save_gear_loop(ds, plot, title="table gear from ratings")
        _say(f"figure written to {plot}")
    if toml is not None:
        from ltdsim.results.io import atomic_path

        note = (f"table gear from ratings: travel {travel:g} m, force {force:g} N, "
                f"capacity {capacity:g} J, absorptivity {absorptivity:g}, preload {preload:g} N, "
                f"{series} in series"
                f"\nloading exponent n = {gear['exponent']:.4f} "
                "(ltdsim.analysis.gears.table_from_ratings)")
        with atomic_path(toml) as tmp:
            tmp.write_text(table_toml(gear, slack=slack, comment=note))
        _say(f"gear written to {toml}")


@app.command("curve-limit")
def curve_limit_cmd(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) holding the vehicles")],
    coupler: Annotated[int, typer.Option(help="coupler number: coupler k joins vehicles k "
                                              "and k + 1 (1 = behind the lead)")],
    radius: Annotated[float, typer.Option(help="curve radius, m (20 to 1e6)")],
    cant: Annotated[float, typer.Option(help="cant of the outer rail, m (0 to 0.2)")] = 0.0,
    speed: Annotated[float, typer.Option(help="train speed, m/s (0 to 100)")] = 0.0,
    case: Annotated[Optional[str], typer.Option("--case", "-c", help="named case to apply")] = None,
) -> None:
    """The largest steady buff force the two vehicles at a coupler can carry on a curve
    before the worse wheel's L/V reaches Nadal's limit (and, beside it, before a leading
    wheelset reaches Prud'homme's limit): "how hard can we push here". Limits and the
    wheelset share come from the scenario's curving table (its defaults without one)."""
    import math

    from ltdsim.results.safety import curve_limit
    from ltdsim.physics.curving import cant_deficiency
    from ltdsim.scenario import Curving, load_scenario

    try:
        _check_number("--radius", radius, 20.0, 1e6, unit="m")
        _check_number("--cant", cant, 0.0, 0.2, unit="m")
        _check_number("--speed", speed, 0.0, 100.0, unit="m/s")
        sc = load_scenario(file, case=case)
        n = len(sc.vehicles)
        if n < 2:
            raise ScenarioError("--coupler", [("", f"{file} has one vehicle and no coupler")])
        _check_number("--coupler", coupler, 1, n - 1, whole=True)
        front, rear = sc.vehicles[coupler - 1], sc.vehicles[coupler]
        for k, v in ((coupler, front), (coupler + 1, rear)):
            problem = v.geometry_problem()
            if problem:
                raise ScenarioError(str(file), [(f"vehicles.{k - 1}", problem)])
    except ScenarioError as exc:
        _fail(exc)
        return
    cfg = sc.curving or Curving()
    res = curve_limit(front, rear, radius, cant, speed, cfg.flange_angle, cfg.flange_friction,
                      cfg.leading_share, sc.track.rail_spacing, sc.track.gravity,
                      cfg.prudhomme_alpha)

    def kn(f):
        return "not reached below 50 MN" if math.isinf(f) else f"{f / 1e3:.0f}"

    hd = float(cant_deficiency(speed, 1.0 / radius, cant, sc.track.rail_spacing,
                               sc.track.gravity))
    table = _table(f"Curve limit at coupler {coupler}: vehicle {coupler} "
                   f"({front.name}) - vehicle {coupler + 1} ({rear.name})",
                   ("quantity", "value"))
    table.add_row("radius [m]", f"{radius:g}")
    table.add_row("cant [mm]", f"{cant * 1e3:.0f}")
    table.add_row("speed [m/s]", f"{speed:.1f} ({speed * 3.6:.1f} km/h)")
    table.add_row("cant deficiency [mm] (- excess)", f"{hd * 1e3:.0f}")
    table.add_row("Nadal L/V limit [-]", f"{res.limit:.3f} ({cfg.flange_angle:g} deg, "
                                          f"mu {cfg.flange_friction:g})")
    table.add_row("L/V with no coupler force [-]", f"{res.l_over_v_at_zero:.3f}")
    table.add_row("max steady buff force, L/V [kN]", kn(res.buff_force))
    table.add_row("governing vehicle", f"{coupler if res.governing == 'front' else coupler + 1}"
                                       f" ({res.governing} of the pair)")
    table.add_row("Prud'homme limit, front / rear [kN]",
                  f"{res.prudhomme[0] / 1e3:.1f} / {res.prudhomme[1] / 1e3:.1f} "
                  f"(alpha {cfg.prudhomme_alpha:g})")
    table.add_row("max steady buff force, Prud'homme [kN]", kn(res.buff_force_prudhomme))
    console.print(table)
    _say("quasi-static, kinematic coupler angles from the vehicle geometry (docs/curving.md); "
         "the same buff force in the couplers on either side of the pair")


@app.command()
def reduce(
    preset: PresetOpt = None, scenario: ScenarioOpt = None, coupler: CouplerOpt = 1,
    rig: Annotated[str, typer.Option(help="deflection (both gears follow the same motion) "
                                          "or force (a mass pushed by the study's forces)")
                   ] = "deflection",
    mass: Annotated[float, typer.Option(help="rig mass of the force rig, kg")] = 8.1e5,
    dt: Annotated[float, typer.Option(help="rig step, s")] = 5e-4,
    fade: Annotated[str, typer.Option(help="what the fitted k2 fades with: deflection (v_c "
                                           "in m, the default law) or rate (v_c in m/s)")
                    ] = "deflection",
    workers: Annotated[int, typer.Option(help="parallel processes (-1: all cores)")] = -1,
    maxiter: Annotated[int, typer.Option(help="generations at most")] = 1000,
    seed: Annotated[int, typer.Option(help="random seed")] = 0,
    plot: Annotated[Path, typer.Option("--plot", "-p", help="figure file (.png, .svg, "
                                                            ".pdf, ...)")] = Path(
        "results/reduction.png"),
    toml: Annotated[Optional[Path], typer.Option(help="write the fitted coupler as TOML")] = None,
) -> None:
    """Fit the simplified coupler to a detailed gear under the study's chain of sines."""
    from ltdsim.analysis.reduction import Search, reduce_gear

    try:
        _check_output(plot, "--plot", image_suffixes(), inputs=(scenario,))
        _check_output(toml, "--toml", (".toml",), inputs=(scenario,))
        _check_number("--mass", mass, 0.0, 1e8, lo_open=True, unit="kg")
        _check_number("--dt", dt, 0.0, 1e-2, lo_open=True, unit="s")
        if workers != -1:
            _check_number("--workers", workers, 1, 1024, whole=True, also="-1 (all cores)")
        _check_number("--maxiter", maxiter, 1, 1_000_000, whole=True)
        _check_number("--seed", seed, 0, 2**32 - 1, whole=True)
        target = _gear_params(preset, scenario, coupler)
        if rig not in ("deflection", "force"):
            raise ScenarioError("--rig", [("rig", f"must be deflection or force, got {rig!r}")])
        if fade not in ("deflection", "rate"):
            raise ScenarioError("--fade", [("fade", f"must be deflection or rate, got "
                                                    f"{fade!r}")])
    except ScenarioError as exc:
        _fail(exc)
        return
    with Progress(TextColumn("[bold]fitting"), BarColumn(), TextColumn("generation {task.completed}"),
                  TextColumn("cost {task.fields[cost]:.3e} N^2"), TimeElapsedColumn(),
                  console=err_console) as prog:
        task = prog.add_task("fit", total=maxiter, cost=float("nan"))
        result = reduce_gear(target, rig=rig, mass=mass, dt=dt, workers=workers,
                             search=Search(maxiter=maxiter, seed=seed), fade=fade,
                             progress=lambda g, n, c: prog.update(task, completed=g, cost=c))
    table = _table(f"Simplified coupler fitted to {preset or scenario}", ("parameter", "value"))
    units = {"damping": "N s/m", "k1": "N/m", "k2": "N/m", "k3": "N/m",
             "v_c": "m/s" if fade == "rate" else "m"}
    for k, v in result.parameters.items():
        table.add_row(f"{k} [{units[k]}]", f"{v:.6g}")
    table.add_row("fit [%]", f"{result.fit_percent:.2f}")
    table.add_row("evaluations", str(result.evaluations))
    console.print(table)
    from ltdsim.viz.plotting import save_reduction

    save_reduction(result, plot, title=f"{preset or scenario}: detailed vs simplified")
    _say(f"figure written to {plot}")
    if toml is not None:
        from ltdsim.results.io import atomic_path

        with atomic_path(toml) as tmp:
            tmp.write_text(result.toml(target.slack))
        _say(f"fitted coupler written to {toml}")


CaseOpt = Annotated[Optional[str], typer.Option(
    "--case", "-c", help="named case of the scenario file (its cases.NAME table) to apply")]
SetOpt = Annotated[Optional[list[str]], typer.Option("--set", "-s", help=SET_HELP)]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")]


@app.command()
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
) -> None:
    """Run many cases; resumable (finished cases are kept), local or on Dask."""
    from ltdsim.sweep import core as sw

    if best_by not in sw.CRITERIA:
        _fail(ScenarioError("--best-by", [("best-by", f"one of {', '.join(sw.CRITERIA)}")]))
        return
    try:
        _check_workers(workers)
        for folder in (output, output / "cases") + ((output / "figures",) if figures else ()):
            _check_folder(folder)
        with Display(err_console) as show:
            checking = _counter(show, "checking the cases")
            spec = sw.load_sweep(file, progress=checking)
            if set_:
                spec = sw.with_overrides(spec, parse_set(set_), progress=checking)
        _check_scheduler(scheduler)
        if not scheduler:  # (a cluster's workers check their own memory)
            sw.check_sweep_memory(spec, str(file), workers)
    except ScenarioError as exc:
        _fail(exc)
        return
    with Display(err_console) as show:
        update = show.bar("sweep", len(spec.cases), "cases")
        try:
            summary = sw.run_sweep(spec, output, scheduler=scheduler, workers=workers,
                                   keep_results=keep_results, retry_failed=retry_failed,
                                   progress=lambda d, n, c: update(d),
                                   on_compile=show.compiling, notice=show.note)
        except (OSError, TimeoutError) as exc:
            if not scheduler:
                raise
            _fail(LtdsimError(f"--scheduler: the Dask scheduler at {scheduler} did not "
                              f"take the work: {exc}"))
            return
        except KeyboardInterrupt:
            err_console.print("[yellow]interrupted: finished cases are kept; run the same "
                              "command again to resume[/]")
            raise typer.Exit(130) from None
    _csv(summary, output / "summary.csv", index=True)
    norms = sw.phase_norm_table(output, spec)
    if not norms.empty:
        _csv(norms.rename(columns={"number": "coupler or vehicle (1 = lead end)"}),
             output / "phase_norms.csv")
    table = _table(f"Sweep {file} ({len(spec.cases)} cases)",
                   ("case", "status", "RMS speed error [m/s]", "max tension [kN]",
                    "max compression [kN]", "max |a| [m/s^2]"))
    for case, row in summary.iterrows():
        if row.status == "ok":
            table.add_row(case, "ok", f"{row.rms_speed_error_m_s:.4f}",
                          f"{row.max_tension_N / 1e3:.0f}", f"{row.max_compression_N / 1e3:.0f}",
                          f"{row.max_abs_acceleration_m_s2:.2f}")
        else:
            table.add_row(case, str(row.status), str(row.get("error") or "")[:60], "", "", "")
    console.print(table)
    best = sw.best_case(summary, best_by)
    if best is None and (summary.status == "ok").any():
        _say(f"no case has a value for {best_by} (no speed controller?); "
             "choose another with --best-by")
    if best is not None:
        console.print(f"best case by {best_by}: [bold]{escape(best)}[/]")
        if figures:
            from ltdsim.viz.analysis import phase_figures

            sc = spec.scenario(next(c for c in spec.cases if c.id == best))
            files = phase_figures(_simulate(sc), output / "figures", sc, prefix=f"{best}_")
            _say(f"phase figures of {best} in {output / 'figures'} ({len(files)})")
    failed = summary[summary.status != "ok"]
    if len(failed):
        console.print(f"[yellow]{len(failed)} case(s) did not finish; see "
                      f"{escape(str(output))}/cases[/]")
    _say(f"summary written to {output / 'summary.csv'}")


def _counter(show: Display, description: str):
    """``progress(done, total)`` that starts a bar of ``show`` at its first call."""
    bar = {}

    def progress(done: int, total: int) -> None:
        if "update" not in bar:
            bar["update"] = show.bar(description, total, "cases")
        bar["update"](done)
    return progress


def _phases_or_fail(ds, sc):
    """Phase norms, or a ScenarioError when no declared phase overlaps the record."""
    from ltdsim.analysis.phases import phase_norms

    try:
        return phase_norms(ds, sc)
    except ValueError:
        names = ", ".join(f"{p.name} {p.start:g}-{p.end:g} s" for p in sc.phases)
        raise ScenarioError("phases", [("", f"no phase ({names}) overlaps the record "
                                            f"(0-{float(ds.time[-1]):g} s)")]) from None


@app.command()
def phases(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/phases"),
    quiet: QuietOpt = False,
) -> None:
    """Phase norms (study Table 5), critical couplers, traction check and Fig. 5-7.

    The phases are the scenario's phases tables; without them the whole run is one
    phase."""
    from ltdsim.analysis.phases import critical_couplers, traction_check
    from ltdsim.viz.analysis import phase_figures

    try:
        _check_folder(output)
        ds, sc = _result_or_scenario(file, case, overrides=set_, quiet=quiet)
        norms = _phases_or_fail(ds, sc)
    except (ScenarioError, SimulationError) as exc:
        _fail(exc)
        return
    ranking = critical_couplers(norms)
    check = traction_check(ds, sc)
    output.mkdir(parents=True, exist_ok=True)

    def long(dim, var, unit, col):
        frame = norms[[f"{var}_{k}" for k in ("2norm", "infnorm", "rms")]].to_dataframe()
        frame = frame.reset_index()[["phase", dim, *(f"{var}_{k}" for k in ("2norm", "infnorm",
                                                                           "rms"))]]
        frame[dim] = frame[dim] + 1
        return frame.rename(columns={dim: col, **{f"{var}_{k}": f"{var}_{k}_{unit}"
                                                  for k in ("2norm", "infnorm", "rms")}})

    ranked = ranking.assign(coupler=ranking.coupler + 1).rename(columns={"coupler": COUPLER_COL})
    for name, frame in (("phase_norms_couplers.csv", long("coupler", "coupler_force", "N",
                                                          COUPLER_COL)),
                        ("phase_norms_vehicles.csv", long("vehicle", "acceleration", "m_s2",
                                                          VEHICLE_COL)),
                        ("critical_couplers.csv", ranked), ("traction_check.csv", check)):
        _csv(frame, output / name)
    table = _table(f"Largest coupler force |F| per phase [kN], {file}"
                   + (f" [{sc.case}]" if sc.case else ""),
                   (COUPLER_COL, *(str(ph) for ph in norms.phase.values)))
    for j in norms.coupler.values:
        table.add_row(str(j + 1), *[
            f"{norms.coupler_force_infnorm.sel(phase=ph, coupler=j).item() / 1e3:.0f}"
            for ph in norms.phase.values])
    console.print(table)
    top = ranking[ranking["rank"] == 1].set_index(["phase", "criterion"])
    crit = _table("Critical coupler per phase: the largest force by peak (largest |F|) and "
                  "by RMS",
                  ("phase", "by peak: coupler", "peak [kN]", "by RMS: coupler", "RMS [kN]"))
    for ph in norms.phase.values:
        pk, rms = top.loc[(ph, "peak")], top.loc[(ph, "RMS")]
        crit.add_row(str(ph), str(int(pk.coupler) + 1), f"{pk.force_N / 1e3:.0f}",
                     str(int(rms.coupler) + 1), f"{rms.force_N / 1e3:.0f}")
    console.print(crit)
    over = int(check.loc[check.phase == "whole run", "samples_demand_over_adhesion"].item())
    _say(f"samples where traction demand exceeded adhesion: {over}")
    files = phase_figures(ds, output, sc)
    _say(f"tables and {len(files)} figures written to {output}")


@app.command()
def modal(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    stiffness: Annotated[str, typer.Option(
        help="the branch every coupling is linearised on: draft (tension; a simplified "
             "coupler's k2 + k3) or buff (compression; its k1), or a coupling stiffness in "
             "N/m")] = "draft",
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/modal"),
) -> None:
    """Natural frequencies and mode shapes of the train (study Fig. 8), linearised as the
    kernel simulates each coupling (its gears in series included: the key gears)."""
    from ltdsim.analysis.modal import train_modes
    from ltdsim.viz.analysis import save_mode_shapes

    try:
        _check_folder(output)
        if stiffness in ("draft", "buff"):
            which = stiffness
        else:
            try:
                which = float(stiffness)
            except ValueError:
                which = float("nan")
            if not 0.0 < which <= 1e12:
                raise ScenarioError("--stiffness", [("", "must be draft, buff or a coupling "
                                                         "stiffness in (0, 1e12] N/m "
                                                         f"(got {stiffness})")])
        _, sc = _result_or_scenario(file, case, run=False, overrides=set_)
        table = train_modes(sc, which)
    except (ScenarioError, ValueError) as exc:
        _fail(exc if isinstance(exc, ScenarioError) else
              ScenarioError("--stiffness", [("", str(exc))]))
        return
    gears = sorted({sc.coupler(j).gears for j in range(sc.n_couplers)})
    what = (f"{stiffness} branch" if isinstance(which, str) else f"{which:.4g} N/m")
    what += ", " + " or ".join(str(g) for g in gears) + " gear(s) per coupling"
    out = _table(f"Modes of {file}" + (f" [{sc.case}]" if sc.case else "") + f", {what}",
                 ("mode (1 = lowest)", "frequency [Hz]"))
    for i, f in enumerate(table.frequency_hz):
        out.add_row(str(i + 1), f"{f:.3f}")
    console.print(out)
    output.mkdir(parents=True, exist_ok=True)
    n = table.shape[1] - 1
    shapes = table.rename(columns={f"vehicle_{i}": f"vehicle {i + 1}" + (" (lead)" if i == 0
                                                                           else "")
                                   for i in range(n)})
    shapes.index = shapes.index + 1
    shapes.index.name = "mode (1 = lowest)"
    _csv(shapes, output / f"modes_{stiffness}.csv", index=True)
    save_mode_shapes(table, output / f"mode_shapes_{stiffness}.png", title=what)
    _say(f"table and mode-shape figure written to {output}")


#: the couplers the study calls critical (its numbering, 1 = behind the lead)
STUDY_COUPLERS = (1, 8, 9)


@app.command()
def spectrum(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    couplers: Annotated[Optional[str], typer.Option(
        help="coupler numbers, comma separated, 1 = behind the lead (1 to n-1); default "
             "1,8,9, the study's critical couplers (on a shorter train the last coupler "
             "stands in for those beyond it)")] = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/spectra"),
    quiet: QuietOpt = False,
) -> None:
    """Coupler force spectra per phase (study Tables 6-7) and a spectrogram."""
    from ltdsim.analysis.spectra import phase_spectra
    from ltdsim.viz.analysis import spectra_figures

    try:
        _check_folder(output)
        numbers = None if couplers is None else [int(c) for c in couplers.split(",")
                                                 if c.strip()]
        if numbers is not None and not numbers:
            raise ValueError
        if file.suffix != ".nc":  # refuse bad numbers before simulating
            from ltdsim.scenario import load_scenario

            _check_couplers(numbers, load_scenario(file, case=case).n_couplers)
        ds, sc = _result_or_scenario(file, case, overrides=set_, quiet=quiet)
        nc = ds.sizes["coupler"]
        _check_couplers(numbers, nc)
        if numbers is None:
            numbers = sorted({min(c, nc) for c in STUDY_COUPLERS})
    except (ScenarioError, SimulationError) as exc:  # (a ScenarioError is a ValueError)
        _fail(exc)
        return
    except ValueError:
        _fail(ScenarioError("--couplers", [("", f"not a list of coupler numbers: {couplers!r}")]))
        return
    which = tuple(c - 1 for c in numbers)  # the library counts from 0
    table = phase_spectra(ds, sc, which)
    output.mkdir(parents=True, exist_ok=True)
    table["coupler"] = table["coupler"] + 1
    _csv(table.rename(columns={"coupler": COUPLER_COL}), output / "phase_spectra.csv")
    out = _table("Coupler force spectra, 0-10 Hz",
                 ("phase", COUPLER_COL, "max [kN]", "at [Hz]", "band RMS [kN]", "main peaks"),
                 justify="left")
    for r in table.itertuples():
        out.add_row(r.phase, str(r.coupler), f"{r.max_N / 1e3:.1f}", f"{r.f_at_max_hz:.1f}",
                    f"{r.band_rms_N / 1e3:.1f}", r.peaks)
    console.print(out)
    files = spectra_figures(ds, output, sc, which)
    _say(f"table and {len(files)} figures written to {output}")


def _check_couplers(numbers, n: int) -> None:
    bad = [c for c in numbers or () if not 1 <= c <= n]
    if bad:
        raise ScenarioError("--couplers", [("", f"{', '.join(map(str, bad))} out of range "
                                                f"1-{n}: couplers are numbered 1 to {n} "
                                                "(coupler 1 is behind the lead)")])


@app.command()
def sysid(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    poles: Annotated[int, typer.Option(help="number of poles")] = 4,
    zeros: Annotated[int, typer.Option(help="number of zeros (feed-through included)")] = 3,
    resample_dt: Annotated[Optional[float], typer.Option(
        help="identify at this sample time, s (default: the record's)")] = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/sysid"),
    quiet: QuietOpt = False,
) -> None:
    """Identify the transfer function locomotive force -> acceleration of vehicle 2, the
    first wagon (study Table 3, Appendix II) and its step metrics (Table 4)."""
    import json

    from ltdsim.analysis.identify import identify_result
    from ltdsim.results.io import atomic_path
    from ltdsim.analysis.response import ramp_error, step_metrics

    try:
        _check_folder(output)
        _check_number("--poles", poles, 1, 20, whole=True)
        _check_number("--zeros", zeros, 0, poles, whole=True)
        if resample_dt is not None:
            _check_number("--resample-dt", resample_dt, 0.0, 10.0, lo_open=True, unit="s")
        ds, _ = _result_or_scenario(file, case, overrides=set_, quiet=quiet)
        step = float(ds.time[1] - ds.time[0]) if ds.sizes["time"] > 1 else float("nan")
        if resample_dt is not None and resample_dt < step * (1 - 1e-9):
            raise ScenarioError("--resample-dt", [("", f"must be at least the record's "
                                                       f"interval, {step:g} s (got "
                                                       f"{resample_dt:g})")])
    except (ScenarioError, SimulationError) as exc:
        _fail(exc)
        return
    m = identify_result(ds, resample_dt=resample_dt, na=poles, nb=zeros)
    info = step_metrics(m.tf())
    result = {
        "sample_time_s": m.dt, "numerator_z^-1": m.b.tolist(), "denominator_z^-1": m.a.tolist(),
        "fpe": m.fpe, "mse": m.mse, "fit_percent": m.fit_percent,
        "prediction_fit_percent": m.prediction_fit_percent, "function_evaluations": m.evaluations,
        "cost": m.cost, "norm_of_step": m.step_norm, "first_order_optimality": m.optimality,
        "step": {k: float(v) for k, v in info.items()}, "ramp_steady_state_error": ramp_error(m.tf()),
    }
    table = _table(f"Identified model, Ts = {m.dt:g} s, {poles} poles, {zeros} zeros",
                   ("quantity", "value"))
    for k in ("fpe", "mse", "fit_percent", "prediction_fit_percent", "function_evaluations",
              "cost", "norm_of_step", "first_order_optimality"):
        table.add_row(k, f"{result[k]:.4g}")
    for k in ("RiseTime", "SettlingTime", "Overshoot", "Peak", "PeakTime"):
        table.add_row(f"step {k}", f"{info[k]:.4g}")
    console.print(table)
    console.print("numerator (z^0, z^-1, ...): " + ", ".join(f"{v:.5g}" for v in m.b))
    console.print("denominator: " + ", ".join(f"{v:.5g}" for v in m.a))
    output.mkdir(parents=True, exist_ok=True)
    with atomic_path(output / "sysid.json") as tmp:
        tmp.write_text(json.dumps(result, indent=2))
    _say(f"written to {output / 'sysid.json'}")


@app.command()
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
        _check_workers(workers)
        for folder in (output, output / "cache", output / "sweep", output / "sweep" / "cases"):
            _check_folder(folder)
        overrides = parse_set(set_) if set_ else None
        with Display(err_console) as show:
            index = run_study(file, output, case=case, overrides=overrides, reduction=reduction,
                              workers=workers, force=force, progress=show.stage,
                              on_compile=show.compiling, notice=show.note)
            show.done(f"report written to {index}")
    except (ScenarioError, SimulationError) as exc:
        _fail(exc)
        return
    except KeyboardInterrupt:
        err_console.print("[yellow]interrupted: finished stages and cases are kept; run the "
                          "same command again to resume[/]")
        raise typer.Exit(130) from None
    _say(f"report written to {index}")


def main() -> None:  # pragma: no cover - console entry
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
