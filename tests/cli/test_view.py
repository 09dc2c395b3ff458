"""``ltdsim view``: what it refuses (one line naming the file and what is wrong, exit
code 2, no traceback, nothing written) and what it writes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

import ltdsim
from ltdsim.cli.app import app

from conftest import build, cli_refused, train_dict


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    ds = ltdsim.simulate(build(train_dict([1e5, 8e4, 8e4], t_end=2.0, dt=1e-3)))
    return ltdsim.save_result(ds, tmp_path_factory.mktemp("res") / "good.nc")


def _view(*args):
    res = CliRunner().invoke(app, ["view", *map(str, args), "--no-open"])
    return res.exit_code, res.stdout + res.stderr


@pytest.mark.parametrize("kind, words", [
    ("truncated", "cut short"), ("empty", "empty file"), ("text", "a text file"),
    ("foreign", "not a result written by ltdsim"), ("no_force", "lacks coupler_force"),
    ("folder", "is a folder"), ("missing", "file not found"), ("one_vehicle", "no couplers"),
])
def test_a_file_the_viewer_cannot_show_is_named_with_what_is_wrong(tmp_path, good, kind,
                                                                   words):
    path = tmp_path / f"{kind}.nc"
    data = good.read_bytes()
    if kind == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "text":
        path.write_text("time,force\n0.0,1.0\n")
    elif kind == "foreign":
        xr.Dataset({"u": ("x", np.arange(3.0))}).to_netcdf(path, engine="h5netcdf")
    elif kind == "no_force":
        sc = build(train_dict([1e5, 8e4, 8e4], t_end=0.5, dt=1e-3))
        sc = sc.with_overrides({"solver.record": ["velocity"]})
        ltdsim.save_result(ltdsim.simulate(sc), path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "one_vehicle":
        ltdsim.save_result(ltdsim.simulate(build(train_dict([1e5], t_end=0.2))), path)
    msg = cli_refused("view", path, "--no-open")
    assert str(path) in msg and words in msg, msg
    assert not path.with_suffix(".html").exists()
    if kind == "no_force":  # what to do about it
        assert "solver.record" in msg


def test_the_page_never_replaces_an_input_or_a_file_it_did_not_write(tmp_path, good):
    msg = cli_refused("view", good, "-o", good, "--no-open")
    assert "is an input" in msg
    notes = tmp_path / "notes.html"
    notes.write_text("<p>someone's notes</p>")
    msg = cli_refused("view", good, "-o", notes, "--no-open")
    assert str(notes) in msg and "not a page of ltdsim view" in msg
    assert notes.read_text() == "<p>someone's notes</p>"
    msg = cli_refused("view", good, "-o", tmp_path / "page.png", "--no-open")
    assert "'.png'" in msg and ".html" in msg
    (tmp_path / "dir.html").mkdir()
    assert "is a folder" in cli_refused("view", good, "-o", tmp_path / "dir.html", "--no-open")


def test_the_page_is_written_beside_the_result_and_written_again(tmp_path, good):
    result = tmp_path / "run.nc"
    result.write_bytes(good.read_bytes())
    code, out = _view(result)
    page = tmp_path / "run.html"
    assert code == 0, out
    assert page.is_file() and f"page written to {page}" in " ".join(out.split())
    first = page.stat().st_mtime_ns
    code, out = _view(result)  # its own page: replaced
    assert code == 0, out and page.stat().st_mtime_ns >= first
    text = page.read_text()
    # offline: Bokeh's code is in the file, nothing is fetched
    assert "<script src=" not in text and "Bokeh" in text
    assert "brake-pipe and brake-cylinder pressures" in text  # (a lumped-brake run)


def test_a_selective_recording_gives_a_page_that_says_what_it_leaves_out(tmp_path):
    sc = build(train_dict([1e5, 8e4, 8e4], t_end=0.5, dt=1e-3))
    sc = sc.with_overrides({"solver.record": ["coupler_force"]})
    result = ltdsim.save_result(ltdsim.simulate(sc), tmp_path / "sel.nc")
    code, out = _view(result, "-o", tmp_path / "sel-page.html")
    assert code == 0, out
    flat = " ".join(out.split())
    assert "not shown: coupler deflection" in flat and "not shown: speed" in flat
