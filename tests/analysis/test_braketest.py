"""The brake test of every shipped valve preset against its norm's windows (UIC 540 /
UIC 543 for the UIC distributors, the AAR's pressures and measured fronts for the AAR
valve), as ``ltdsim brake-test`` runs it."""

import pandas as pd
import pytest
from typer.testing import CliRunner

from ltdsim.analysis.braketest import stand_test, train_test
from ltdsim.cli.app import app
from ltdsim.data import load_preset, preset_names
from ltdsim.engine.brakerig import rows

from conftest import ROOT, cli_refused


@pytest.mark.parametrize("name", preset_names("brakes"))
def test_every_shipped_preset_meets_its_windows_on_the_stand_and_in_the_train(name):
    windows = load_preset("brakes", name)["brake_test"]
    cv, dv = rows(name)
    checks = stand_test(cv, dv, windows) + train_test(name, windows)
    judged = [c for c in checks if c.judged]
    assert len(judged) >= 4  # pressures and the fronts at least
    bad = [f"{c.name}: {c.value:.4g} {c.unit} outside [{c.low}, {c.high}]"
           for c in judged if not c.passed]
    assert not bad, bad
    fronts = [c for c in checks if c.test == "train"]
    assert len(fronts) == len(windows["front_temperatures"])
    # colder air, slower front (the speed of sound goes as sqrt(T))
    speeds = [c.value for c in fronts]
    assert speeds == sorted(speeds)


def test_the_command_writes_its_table_with_units(tmp_path):
    out = tmp_path / "uic-p.csv"
    res = CliRunner().invoke(app, ["brake-test", "uic-p", "--no-train", "--csv", str(out)])
    assert res.exit_code == 0, res.stdout + res.stderr
    assert "5 of 5 judged checks pass" in " ".join(res.stdout.split())
    table = pd.read_csv(out)
    assert set(table.unit) == {"s", "Pa gauge"}
    fill = table[table.check.str.startswith("fill")].iloc[0]
    assert 3.0 <= fill.value <= 5.0 and fill.low == 3.0 and fill.high == 5.0


def test_the_command_refuses_a_lumped_scenario_and_two_sources(tmp_path):
    msg = cli_refused("brake-test", "aar", "--scenario", ROOT / "scenarios" / "uic-freight.toml")
    assert "give a valve preset" in msg and "not both" in msg
    msg = cli_refused("brake-test", "--scenario", ROOT / "scenarios" / "heavy-haul.toml")
    assert "brake.model: the brake test needs the fluid brake" in msg
