"""``ltdsim gear loop|impact|ratings`` and ``ltdsim reduce``: one draft gear on the rig
(its force-deflection loop, a two-wagon impact, a table gear from catalogue ratings)
and the simplified coupler fitted to a detailed gear.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from ltdsim.errors import ScenarioError
from ltdsim.progress import Display
from ltdsim.cli.common import (
    CouplerOpt, PresetOpt, ScenarioOpt, check_new, check_number, check_output, console,
    err_console, fail, gear_params, image_suffixes, plain_table, say, write_csv,
)


gear_app = typer.Typer(no_args_is_help=True, help=(
    "A single draft gear on the rig: loop (its force-deflection loop), impact (two wagons "
    "run together) and ratings (a table gear from catalogue ratings)."))

#: the most samples ``gear loop`` lets the rig record (at its 1e-4 s step, four arrays:
#: about 4 GB and 20 s with the figure): one cycle of the longest --period
MAX_LOOP_SAMPLES = 36_000_001


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

    from ltdsim.analysis.gears import DEFLECTION_DT, drive_deflection, loop_energy, rig_samples

    try:
        check_output(plot, "--plot", image_suffixes(), inputs=(scenario,))
        check_number("--amplitude", amplitude, 0.0, 1.0, lo_open=True, unit="m")
        check_number("--period", period, 0.1, 3600.0, unit="s")
        check_number("--cycles", cycles, 1, 100, whole=True)
        samples = rig_samples(cycles * period)
        if samples > MAX_LOOP_SAMPLES:
            most = (MAX_LOOP_SAMPLES - 1) * DEFLECTION_DT
            raise ScenarioError("--period x --cycles", [("", (
                f"{period:g} s x {cycles} = {cycles * period:g} s would record {samples:,} "
                f"samples (the rig's {DEFLECTION_DT:g} s step); at most {most:g} s "
                f"({MAX_LOOP_SAMPLES:,} samples): give fewer cycles or a shorter period"))])
        params = gear_params(preset, scenario, coupler)
    except ScenarioError as exc:
        fail(exc)
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
    say(f"figure written to {plot}")


@gear_app.command("impact")
def gear_impact(
    preset: PresetOpt = None, scenario: ScenarioOpt = None, coupler: CouplerOpt = 1,
    speeds: Annotated[str, typer.Option(help="impact speeds, m/s, comma separated")] = "0.5,1,1.5,2,2.5,3",
    mass: Annotated[float, typer.Option(help="mass of each wagon, kg")] = 90000.0,
    csv: Annotated[Optional[Path], typer.Option(help="write the table as CSV")] = None,
) -> None:
    """Run a wagon into a standing wagon at several speeds: peak force, travel, energy."""
    import pandas as pd

    from ltdsim.analysis.gears import impact, lightest_impact_mass
    from ltdsim.scenario._base import MAX_MASS

    try:
        check_output(csv, "--csv", (".csv",), inputs=(scenario,))
        check_number("--mass", mass, 0.0, MAX_MASS, lo_open=True, unit="kg")  # (the schema's)
        params = gear_params(preset, scenario, coupler)
        lightest = lightest_impact_mass(params)  # (the rig's fixed 1e-4 s step)
        if lightest is None:
            raise ScenarioError("--mass", [("", "no wagon mass up to the vehicle limit "
                                                f"{MAX_MASS:g} kg keeps the impact's 1e-4 s "
                                                "step stable on this gear")])
        if mass < lightest:
            check_number("--mass", mass, lightest, MAX_MASS, unit="kg",
                         reason="on this gear lighter wagons ring faster than the "
                                "impact's fixed 1e-4 s step can follow")
        values = [float(v) for v in speeds.split(",") if v.strip()]
        if not values:
            raise ValueError
        for v in values:
            check_number("--speeds", v, 0.0, 30.0, lo_open=True, unit="m/s")
    except ScenarioError as exc:
        fail(exc)
        return
    except ValueError:
        fail(ScenarioError("--speeds", [("", f"not a list of numbers: {speeds!r}")]))
        return
    rows = []
    table = plain_table(f"Impact of two {mass / 1e3:.0f} t wagons ({params.model} gear)",
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
        write_csv(pd.DataFrame(rows), csv)
        say(f"table written to {csv}")


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
    """A table gear from its catalogue ratings (travel, force, capacity, absorptivity).

    Checked by closing and releasing it slowly on the rig."""
    import numpy as np

    from ltdsim.analysis.gears import (drive_deflection, loop_energy, series_range,
                                       table_from_ratings, table_toml)
    from ltdsim.scenario import CouplerParams

    try:
        check_output(toml, "--toml", (".toml",))
        check_new(toml, "--toml")
        check_output(plot, "--plot", image_suffixes())
        check_number("--slack", slack, 0.0, 1.0, unit="m")
        check_number("--series", series, *series_range(), whole=True)
    except ScenarioError as exc:
        fail(exc)
        return
    try:
        gear = table_from_ratings(travel, force, capacity, absorptivity, preload=preload,
                                  series=series)
    except ValueError as exc:
        key, _, why = str(exc).partition(" ")
        fail(ScenarioError("ratings", [(f"--{key}", why)]))
        return
    params = CouplerParams(**{k: v for k, v in gear.items() if k != "exponent"})
    t = np.linspace(0.0, 20.0, 20001)
    # one slow closing and release of the whole connection (its gears in series)
    d = series * gear["travel"] * 0.5 * (1 - np.cos(2 * np.pi * t / 20.0))
    ds = drive_deflection(params, t, d, dt=1e-3)
    half = len(t) // 2 + 1
    closing = ds.isel(time=slice(0, half))
    taken, absorbed = loop_energy(closing), loop_energy(ds)
    table = plain_table("Table gear from ratings (rig: one slow closing and release)",
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
        say(f"figure written to {plot}")
    if toml is not None:
        from ltdsim.results.io import atomic_path

        note = (f"table gear from ratings: travel {travel:g} m, force {force:g} N, "
                f"capacity {capacity:g} J, absorptivity {absorptivity:g}, preload {preload:g} N, "
                f"{series} in series"
                f"\nloading exponent n = {gear['exponent']:.4f} "
                "(ltdsim.analysis.gears.table_from_ratings)")
        with atomic_path(toml) as tmp:
            tmp.write_text(table_toml(gear, slack=slack, comment=note))
        say(f"gear written to {toml}")


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
    maxiter: Annotated[int, typer.Option(help="generations at most")] = 1000,
    seed: Annotated[int, typer.Option(help="random seed")] = 0,
    plot: Annotated[Path, typer.Option("--plot", "-p", help="figure file (.png, .svg, "
                                                            ".pdf, ...)")] = Path(
        "results/reduction.png"),
    toml: Annotated[Optional[Path], typer.Option(help="write the fitted coupler as TOML")] = None,
    max_time: Annotated[Optional[float], typer.Option(
        "--max-time", help="refuse a search that could take longer than this (all "
                           "--maxiter generations), s of wall time (default: no limit)")] = None,
) -> None:
    """Fit the simplified coupler to a detailed gear under the study's chain of sines.

    Before the search one generation's rig runs are timed, in this process and through
    one process per core, and the faster way is taken (the result is the same either
    way); the longest the search can take is printed (it usually converges much
    earlier)."""
    from ltdsim.analysis.reduction import Search, reduce_gear

    try:
        check_output(plot, "--plot", image_suffixes(), inputs=(scenario,))
        check_output(toml, "--toml", (".toml",), inputs=(scenario,))
        check_new(toml, "--toml")
        check_number("--mass", mass, 0.0, 1e8, lo_open=True, unit="kg")
        check_number("--dt", dt, 0.0, 1e-2, lo_open=True, unit="s")
        check_number("--maxiter", maxiter, 1, 1_000_000, whole=True)
        check_number("--seed", seed, 0, 2**32 - 1, whole=True)
        if max_time is not None:
            check_number("--max-time", max_time, lo=0.0, lo_open=True, unit="s")
        target = gear_params(preset, scenario, coupler)
        if rig not in ("deflection", "force"):
            raise ScenarioError("--rig", [("", f"must be deflection or force, got {rig!r}")])
        if fade not in ("deflection", "rate"):
            raise ScenarioError("--fade", [("", f"must be deflection or rate, got "
                                                    f"{fade!r}")])
    except ScenarioError as exc:
        fail(exc)
        return
    try:
        with Display(err_console) as show:
            def announce(est):
                if max_time is not None and est.upper_seconds > max_time:
                    from ltdsim.engine.run import duration

                    raise ScenarioError("--max-time", [("", (
                        f"{est.line()}, beyond the limit of {duration(max_time)}; lower "
                        "--maxiter, raise --dt, or raise --max-time"))])
                show.info(est.line())

            update = show.bar("fitting", maxiter, "generations at most")
            result = reduce_gear(target, rig=rig, mass=mass, dt=dt, workers=-1,
                                 search=Search(maxiter=maxiter, seed=seed), fade=fade,
                                 progress=lambda g, n, c: update(g), before_search=announce)
    except ScenarioError as exc:
        fail(exc)
        return
    table = plain_table(f"Simplified coupler fitted to {preset or scenario}", ("parameter", "value"))
    units = {"damping": "N s/m", "k1": "N/m", "k2": "N/m", "k3": "N/m",
             "v_c": "m/s" if fade == "rate" else "m"}
    for k, v in result.parameters.items():
        table.add_row(f"{k} [{units[k]}]", f"{v:.6g}")
    table.add_row("fit [%]", f"{result.fit_percent:.2f}")
    table.add_row("generations", f"{result.generations} of at most {maxiter}")
    table.add_row("evaluations (rig runs)", str(result.evaluations))
    console.print(table)
    from ltdsim.viz.plotting import save_reduction

    save_reduction(result, plot, title=f"{preset or scenario}: detailed vs simplified")
    say(f"figure written to {plot}")
    if toml is not None:
        from ltdsim.results.io import atomic_path

        with atomic_path(toml) as tmp:
            tmp.write_text(result.toml(target.slack))
        say(f"fitted coupler written to {toml}")
