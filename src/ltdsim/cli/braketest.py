"""``ltdsim brake-test``: a valve preset's (or a scenario's) stand test and train test,
each figure beside its norm's window (:mod:`ltdsim.analysis.braketest`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from ltdsim.cli.common import (
    check_output, console, err_console, fail, plain_table, say, write_csv,
)
from ltdsim.errors import ScenarioError
from ltdsim.progress import Display

#: how the table writes a value of each unit
_SHOW = {"s": ("s", 1.0, "{:.1f}"), "m/s": ("m/s", 1.0, "{:.0f}"), "Pa": ("bar", 1e-5, "{:.3f}")}


def _shown(value, unit: str) -> str:
    name, scale, fmt = _SHOW[unit]
    return fmt.format(value * scale) + f" {name}" if value == value else "not measured"


def _window(c) -> str:
    name, scale, fmt = _SHOW[c.unit]
    if not c.judged:
        return "-"
    lo = "" if c.low is None else fmt.format(c.low * scale)
    hi = "" if c.high is None else fmt.format(c.high * scale)
    if c.low is not None and c.high is not None:
        return f"{lo}-{hi} {name}"
    return f">= {lo} {name}" if c.low is not None else f"<= {hi} {name}"


def brake_test(
    preset: Annotated[Optional[str], typer.Argument(help="valve preset (aar, uic-g, uic-p)")] = None,
    scenario: Annotated[Optional[Path], typer.Option(
        "--scenario", help="test this fluid-brake scenario's valves (its preset's windows) "
                           "instead of a preset")] = None,
    train: Annotated[bool, typer.Option("--train/--no-train", help="also the train test "
                                                                    "(the emergency front)")] = True,
    csv: Annotated[Optional[Path], typer.Option("--csv", help="write the table as CSV")] = None,
) -> None:
    """The stand test of one braked vehicle (fill and release from the handle, cylinder
    and pipe pressures) and the emergency front on a test train at the norm's
    temperatures, each beside its window with pass or fail."""
    from ltdsim.data import load_preset, preset_names
    from ltdsim.physics.air.brakevalves import control_valve_row, driver_valve_row

    try:
        check_output(csv, "--csv", (".csv",), inputs=(scenario,))
        if (preset is None) == (scenario is None):
            raise ScenarioError("brake-test", [("", "give a valve preset ("
                                                    f"{', '.join(preset_names('brakes'))}) "
                                                    "or --scenario FILE, not both")])
        if scenario is not None:
            from ltdsim.scenario import load_scenario, valve_tables

            sc = load_scenario(scenario)
            if sc.brake.model != "fluid":
                raise ScenarioError(str(scenario), [("brake.model", "the brake test needs "
                                                     "the fluid brake ('fluid'), got "
                                                     f"{sc.brake.model!r}")])
            valve = sc.brake.fluid.valve
            cv_table, dv_table = valve_tables(sc.brake.fluid)
            name = valve if isinstance(valve, str) else valve.get("preset")
            label = f"{scenario} ({name or 'inline valves'})"
        else:
            try:
                table = load_preset("brakes", preset)
            except ValueError as exc:
                raise ScenarioError("brake-test", [("", str(exc))]) from None
            valve, name, label = preset, preset, preset
            cv_table, dv_table = table["control_valve"], table["driver_valve"]
        windows = load_preset("brakes", name).get("brake_test", {}) if name else {}
    except ScenarioError as exc:
        fail(exc)
        return
    from ltdsim.analysis.braketest import stand_test, train_test

    cv, dv = control_valve_row(cv_table), driver_valve_row(dv_table)
    with Display(err_console) as show:
        show.stage("brake test", "stand")
        checks = stand_test(cv, dv, windows)
        if train:
            update = show.bar("train test", len(windows.get("front_temperatures", [0])),
                              "temperatures")
            checks += train_test(valve, windows, progress=lambda k, n: update(k))
        show.done("brake test")
    table = plain_table(f"Brake test: {label}", ("test", "check", "measured", "window",
                                                 "result", "source"), justify="left")
    for c in checks:
        result = "-" if c.passed is None else ("pass" if c.passed else "FAIL")
        table.add_row(c.test, c.name, _shown(c.value, c.unit), _window(c), result, c.source)
    console.print(table)
    judged = [c for c in checks if c.passed is not None]
    failed = [c for c in judged if not c.passed]
    say(f"{len(judged) - len(failed)} of {len(judged)} judged checks pass"
        + (f"; failing: {', '.join(c.name for c in failed)}" if failed else ""))
    if csv is not None:
        import pandas as pd

        write_csv(pd.DataFrame([{
            "test": c.test, "check": c.name, "value": c.value,
            "unit": "Pa gauge" if c.unit == "Pa" else c.unit,
            "low": c.low, "high": c.high, "passed": c.passed, "source": c.source}
            for c in checks]), csv)
        say(f"table written to {csv}")
    if failed:
        raise typer.Exit(1)
