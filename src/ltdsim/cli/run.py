"""``ltdsim run``: one scenario simulated, its coupler peaks, motion, energy balance,
fluid-brake propagation and curving safety printed, the result, figures and a one-page
report written where asked.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.markup import escape

from ltdsim.errors import ScenarioError, SimulationError
from ltdsim.results.outputs import check_own_folder, replace_own_files
from ltdsim.cli.common import (
    COUPLER_COL, MAX_TIME_ANYWAY, RESULT_SUFFIXES, SET_HELP, MaxTimeOpt, check_folder,
    check_number, check_output, console, err_console, fail, image_suffixes, parse_set,
    plain_table, say, scenario_label, simulate_shown,
)


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
    max_time: MaxTimeOpt = None,
) -> None:
    """Simulate one scenario (optionally one named case) and summarise coupler forces."""
    from ltdsim.results.io import save_result
    from ltdsim.scenario import load_scenario
    from ltdsim.results.summary import coupler_summary, critical_rows, run_summary, travel_warning

    try:
        if max_time is not None:
            check_number("--max-time", max_time, lo=0.0, unit="s",
                         reason="0 means no limit")
        check_output(output, "--output", RESULT_SUFFIXES, inputs=(file,))
        if plot is not None:  # (matplotlib only when a figure is asked for)
            check_output(plot, "--plot", image_suffixes(), inputs=(file,))
        if report is not None:
            check_folder(report, "--report")
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
            check_output(brake_plot, "--plot (the brake-pressure figure beside it)",
                          image_suffixes(), inputs=(file,))
        curving_plot = (curving_figure_path(plot) if plot is not None
                        and sc.curving is not None else None)
        if curving_plot is not None:
            check_output(curving_plot, "--plot (the curving figure beside it)",
                          image_suffixes(), inputs=(file,))
        earlier = (check_report_folder(report, {"--output": output, "--plot": plot,
                                                "--plot (the brake-pressure figure beside it)":
                                                brake_plot,
                                                "--plot (the curving figure beside it)":
                                                curving_plot})
                   if report is not None else [])
        label = scenario_label(sc)  # plain text: _table keeps it so
        ds = simulate_shown(sc, quiet, file, "--set" if set_ else None, max_time,
                            MAX_TIME_ANYWAY)
    except (ScenarioError, SimulationError) as exc:
        fail(exc)
        return

    summary = coupler_summary(ds)
    shown = critical_rows(summary)
    title = f"Coupler forces: {label}"
    if len(shown) < len(summary):
        title += f" (the {len(shown)} most loaded of {len(summary)} couplers)"
    table = plain_table(title, (COUPLER_COL, "max tension [kN]", "at [s]", "max compression [kN]",
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
    _print_strength(ds, sc)
    _print_fatigue(ds, sc)
    warning = travel_warning(ds, sc)
    if warning:
        err_console.print(f"[yellow]warning:[/] {escape(warning)}")
    try:  # (checked before the run; a disk that fills up meanwhile still fails here)
        if output is not None:
            save_result(ds, output)
            say(f"result written to {output}")
        if plot is not None:
            from ltdsim.viz.plotting import save_overview

            save_overview(ds, plot)
            say(f"figure written to {plot}")
        if brake_plot is not None and "brake_pipe_pressure" in ds:
            from ltdsim.viz.plotting import save_brake_pressures

            save_brake_pressures(ds, brake_plot, summary=brake)
            say(f"brake-pressure figure written to {brake_plot}")
        if curving_plot is not None and curving is not None:
            from ltdsim.viz.plotting import save_curving

            save_curving(ds, curving_plot, summary=curving)
            say(f"curving figure written to {curving_plot}")
        if report is not None:
            page = write_report(ds, report, f"ltdsim run: {label}", earlier)
            say(f"report written to {page}")
    except OSError as exc:
        err_console.print(f"[bold red]error (writing failed):[/] "
                          f"{escape(str(exc.filename or output or plot))}: "
                          f"{escape(exc.strerror or str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(3) from None


#: the record ``run --report`` leaves in its folder: the files it wrote there, each with
#: its size and content hash, so that a later report into the folder knows them
REPORT_RECORD = "run-report.json"
#: the files a run's report may write (ltdsim.study.report.run_page.write_run_report)
REPORT_FILES = ("index.html", "couplers.csv", "curving.png", "curving_worst.csv")


def check_report_folder(folder: Path, outputs: dict) -> list[dict]:
    """Refuse, before the run, a ``--report`` folder holding anything but an earlier
    report of ``ltdsim run`` and this command's other ``outputs`` (option: path), or an
    output where the report writes (:func:`ltdsim.results.outputs.check_own_folder`).
    Returns the records of the earlier report's files."""
    return check_own_folder(folder, REPORT_RECORD, REPORT_FILES, outputs,
                            "ltdsim run --report", "--report")


def write_report(ds, folder: Path, title: str, earlier: list[dict]) -> Path:
    """Write the run's report into ``folder`` (checked by :func:`check_report_folder`),
    remove the earlier report's files the new one did not write again, and record the
    files written. Returns the page's path."""
    from ltdsim.study.report import write_run_report

    return replace_own_files(folder, REPORT_RECORD, lambda: write_run_report(ds, folder, title),
                             earlier, "ltdsim run --report")


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
    say(f"lead vehicle: top speed {_speed(v['max_speed_m_s'])}, final speed "
         f"{_speed(v['final_speed_m_s'])}")
    stop = stopping(ds)
    if stop is not None:
        say(f"stopped in {stop['stopping_distance_m']:.1f} m and {stop['stopping_time_s']:.1f} s "
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
    table = plain_table("Energy balance (work since the start; + in: traction; + out: the rest)",
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
    say(f"energy balance closes to {e['largest_balance_error']:.3g} J at worst"
         + (f" ({share:.2g} of the traction throughput, {e['throughput'] / 1e6:.4g} MJ)"
            if share == share else ""))
    if e["traction_kwh_per_km"] == e["traction_kwh_per_km"]:
        def kwh(x: float) -> str:
            x /= KWH
            return f"{x:,.0f}" if abs(x) >= 1e3 else f"{x:.4g}"

        say(f"traction at the rail: {kwh(e['traction_energy'])} kWh over "
             f"{abs(e['distance_m']) / 1e3:.3g} km, {e['traction_kwh_per_km']:.3g} kWh/km, "
             f"{e['traction_wh_per_gross_tonne_km']:.3g} Wh per gross tonne-km "
             f"({e['gross_tonnes']:,.0f} t); dynamic braking took back "
             f"{kwh(e['dynamic_brake_energy'])} kWh at the rail (what regeneration can "
             "recover before the drive's losses)")


def _print_strength(ds, sc) -> None:
    """The couplers whose force went over their proof or ultimate load, the most severe
    first (ltdsim.results.strength); nothing when no coupler has a strength or none went
    over. Gears closed solid are the travel warning's."""
    from ltdsim.results.strength import event_lines, stored_events, strength_events

    table = stored_events(ds)
    if table is None:
        table = strength_events(ds, sc)
    for line in event_lines(table):
        console.print(escape(line), highlight=False, soft_wrap=True)


def _print_fatigue(ds, sc) -> None:
    """The couplers' fatigue damage by Miner's rule on rainflow-counted forces, the most
    damaged first, this trip and per km (ltdsim.results.fatigue); nothing when no coupler
    has a ``fatigue`` curve, a note when the run did not record coupler_force."""
    from ltdsim.results.fatigue import damage_lines, fatigue_damage, stored_damage

    table = stored_damage(ds)
    if table is None:
        table = fatigue_damage(ds, sc)
    if table.empty and "coupler_force" not in ds and any(
            sc.coupler(j).fatigue is not None for j in range(sc.n_couplers)):
        say("fatigue: not counted (solver.record leaves out coupler_force, the history "
            "the cycles are counted from)")
        return
    for line in damage_lines(table):
        console.print(escape(line), highlight=False, soft_wrap=True)


def _fluid(sc) -> bool:
    """Whether the scenario brakes with the fluid air brake (``brake.model = "fluid"``)."""
    return getattr(sc.brake, "model", "lumped") == "fluid"


def curving_figure_path(plot: Path) -> Path:
    """Where ``ltdsim run --plot FIG`` writes the curving figure of a run with
    ``[curving]``: beside FIG, ``<stem>-curving<suffix>``."""
    return plot.with_name(f"{plot.stem}-curving{plot.suffix}")


def _print_curving(ds) -> dict | None:
    """The worst wheel L/V, wheelset force and coupler angle of a run with [curving]."""
    from ltdsim.results.summary import curving_summary, l_over_v_text

    c = curving_summary(ds)
    if c is None:
        return None
    say(f"curving: {l_over_v_text(c)}; "
         f"largest wheelset lateral force {c['max_wheelset_force_N'] / 1e3:.1f} kN "
         f"({100 * c['wheelset_force_share_of_limit']:.0f} % of Prud'homme's "
         f"{c['prudhomme_limit_N'] / 1e3:.1f} kN) at vehicle {c['wheelset_force_vehicle']}, "
         f"{c['wheelset_force_time_s']:.1f} s")
    if "max_coupler_angle_rad" in c:
        say(f"curving: largest coupler angle {1e3 * c['max_coupler_angle_rad']:.1f} mrad at coupler "
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
    # no vehicle away from its brake-control point (one vehicle): no distance to
    # travel, so no propagation speed (0 m over the time is no speed)
    alone = not b["farthest_distance_m"] > 0.0
    if alone:
        why = ("one vehicle" if b["arrival_s"].size == 1
               else "every vehicle is a brake-control point")
        line += f"propagation n/a ({why}); "
    elif b["propagation_time_s"] == b["propagation_time_s"]:
        line += (f"propagation {b['end_to_end_speed_m_s']:.0f} m/s end to end (the pipe's "
                 f"{drop} drop {b['propagation_time_s']:.2f} s after the command at vehicle "
                 f"{b['farthest_vehicle'] + 1}, {b['farthest_distance_m']:.0f} m away)")
        if b["propagation_speed_m_s"] == b["propagation_speed_m_s"]:
            line += (f", {b['propagation_speed_m_s']:.0f} m/s along the train (slope over "
                     f"{b['vehicles_reached']} vehicles)")
        line += "; "
    else:
        line += f"the {drop} drop did not reach vehicle {b['farthest_vehicle'] + 1}; "
    if b["vent_time_s"] == b["vent_time_s"] and not alone:
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
    say(line.rstrip("; "))
    return b
