"""Faults: a sweep whose main process is killed leaves no process behind and resumes to
the same results; damaged cached or output files (garbage, truncated, empty, deleted,
altered) are reported, and exactly the damaged cases and stages are computed again,
ending with the results of an undamaged run."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import xarray as xr

from ltdsim.sweep import core as sw
from ltdsim.errors import ScenarioError
from ltdsim.results.io import load_result, read_sealed
from ltdsim.study.stages import run_study

from conftest import PAPER, ROOT

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals and /proc")


def write_sweep(tmp_path, t_end: float, n: int):
    """A list sweep of ``n`` cases of the short train (coupler k3 from 3 to 6 MN/m)."""
    k3 = [3.0e6 + 3.0e6 * i / max(n - 1, 1) for i in range(n)]
    p = tmp_path / "sweep.toml"
    p.write_text(f'scenario = "{ROOT / "scenarios" / "short-train.toml"}"\n'
                 f'[overrides]\n"solver.t_end" = {t_end}\n"solver.output_interval" = 0.01\n'
                 f'[list]\n"couplers.default.k3" = {json.dumps(k3)}\n')
    return p


# ------------------------------------------------------------------ processes
def _children(pid: int) -> dict[int, str]:
    """Descendants of ``pid``: pid -> command line (psutil if installed, else /proc)."""
    try:
        import psutil

        out = {}
        for c in psutil.Process(pid).children(recursive=True):
            try:
                out[c.pid] = " ".join(c.cmdline())
            except psutil.Error:
                pass
        return out
    except ImportError:
        pass
    parents = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
                parents[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    out, todo = {}, [pid]
    while todo:
        p = todo.pop()
        for c, pp in parents.items():
            if pp == p and c not in out:
                try:
                    out[c] = (Path("/proc") / str(c) / "cmdline").read_bytes().replace(
                        b"\0", b" ").decode()
                except OSError:
                    out[c] = ""
                todo.append(c)
    return out


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie, dead but not yet reaped, is not alive)."""
    try:
        import psutil

        try:
            return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
        except psutil.NoSuchProcess:
            return False
    except ImportError:
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except OSError:
            return False
        return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def test_a_killed_sweep_leaves_no_process_and_resumes_to_the_same_results(tmp_path):
    """SIGKILL the main process of `ltdsim sweep --workers 2` while its workers run
    cases: 10 s later neither worker nor the resource tracker (of spawned workers) is
    alive; the same command resumes with only the unfinished cases and ends with an
    undisturbed run's results. On Linux the workers are forked from the main process
    (ltdsim._workers), elsewhere spawned."""
    n = 10
    path = write_sweep(tmp_path, 30.0, n)  # each case ~0.5 s on one core
    out = tmp_path / "killed"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-m", "ltdsim.cli.app", "sweep", str(path), "-o",
                             str(out), "--workers", "2", "--no-figures"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 300  # (a cold kernel compile on a busy machine)
        seen: dict[int, str] = {}
        while time.monotonic() < deadline and proc.poll() is None:
            seen.update(_children(proc.pid))
            if any((out / "cases").glob("*.json")):  # the workers are running cases
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the sweep ended before it could be killed: " + \
            proc.stderr.read().decode()[-2000:]
        seen.update(_children(proc.pid))
        tracker = [p for p, cmd in seen.items() if "resource_tracker" in cmd]
        workers = [p for p in seen if p not in tracker]
        assert len(workers) == 2 and all(_alive(p) for p in workers), seen
        if sys.platform.startswith("linux"):  # forked: the main process's command line
            assert all("multiprocessing.spawn" not in seen[p] for p in workers), seen
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    finished_before = {p.stem for p in (out / "cases").glob("*.json")}
    assert len(finished_before) < n  # killed mid-sweep
    time.sleep(10.0)
    survivors = [p for p in [*workers, *tracker] if _alive(p)]
    for p in survivors:  # leave nothing behind even when the test fails
        os.kill(p, signal.SIGKILL)
    assert not survivors, f"alive 10 s after the main process was killed: {survivors}"

    spec = sw.load_sweep(path)
    notes, ran = [], []
    resumed = sw.run_sweep(spec, out, workers=2, notice=notes.append,
                           progress=lambda d, total, c: ran.append(c) if c else None)
    # every record the killed run wrote is complete (atomic writes); at most a temporary
    # file it was writing when killed is left, and removed
    assert all(line.startswith("removed ") for line in notes), notes
    assert not list((out / "cases").glob(".*.part"))
    assert set(ran) == {c.id for c in spec.cases} - finished_before
    undisturbed = sw.run_sweep(spec, tmp_path / "undisturbed", workers=2)
    pd.testing.assert_frame_equal(resumed, undisturbed)


# ------------------------------------------------------------------ damaged files
def _garbage(p: Path):
    p.write_bytes(b"\x89not what was written\x00" * 20)


def _truncated(p: Path):
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])


def _empty(p: Path):
    p.write_bytes(b"")


def _deleted(p: Path):
    p.unlink()


def _altered(p: Path):
    """One byte changed in the middle: same size, other content."""
    data = bytearray(p.read_bytes())
    data[len(data) // 2] ^= 0xFF
    p.write_bytes(bytes(data))


def _stamps(folder: Path) -> dict[str, int]:
    """Inode of every file: an atomic rewrite (temporary file renamed) gives a new one."""
    return {str(p.relative_to(folder)): p.stat().st_ino for p in folder.rglob("*")
            if p.is_file()}


def _rewritten(before: dict, folder: Path) -> set[str]:
    after = _stamps(folder)
    return {k for k, ino in after.items() if before.get(k) != ino}


def _same_data(a: Path, b: Path):
    """Two result files hold equal time series (attributes, e.g. the wall time, aside)."""
    xr.testing.assert_equal(load_result(a), load_result(b))


def test_damaged_case_files_rerun_exactly_those_cases_to_the_same_results(tmp_path):
    """Under --keep-results: each kind of damage to a case record or a kept time series
    reruns that case and no other, with one line naming it, and the results equal the
    undamaged run's (summary and time series)."""
    spec = sw.load_sweep(write_sweep(tmp_path, 2.0, 12))
    out = tmp_path / "out"
    reference = sw.run_sweep(spec, out, workers=2, keep_results=True)
    ref = tmp_path / "reference"
    shutil.copytree(out, ref)
    ids = [c.id for c in spec.cases]
    kinds = [_garbage, _truncated, _empty, _deleted, _altered]
    # each kind of damage to a record and to a time series, each on its own case; the
    # last two cases stay whole
    damage = {**{(ids[i], "json"): how for i, how in enumerate(kinds)},
              **{(ids[5 + i], "nc"): how for i, how in enumerate(kinds)}}
    for (case, ext), how in damage.items():
        how(out / "cases" / f"{case}.{ext}")
    before = _stamps(out)
    notes, ran = [], []
    summary = sw.run_sweep(spec, out, workers=2, keep_results=True, notice=notes.append,
                           progress=lambda d, n, c: ran.append(c) if c else None)
    damaged = {case for case, _ in damage}
    assert sorted(ran) == sorted(damaged)  # exactly the damaged cases, once each
    # one line per damaged case; a deleted record is a case not run yet (no line)
    said = {line.split(":")[0].removeprefix("recomputing case ") for line in notes}
    assert len(notes) == len(said)
    assert said == {case for (case, ext), how in damage.items()
                    if not (ext == "json" and how is _deleted)}
    assert all(line.startswith("recomputing case ") for line in notes)
    assert {Path(p).stem for p in _rewritten(before, out)} == damaged
    pd.testing.assert_frame_equal(summary, reference)
    for case in ids:
        _same_data(out / "cases" / f"{case}.nc", ref / "cases" / f"{case}.nc")
        a = read_sealed(out / "cases" / f"{case}.json")
        b = read_sealed(ref / "cases" / f"{case}.json")
        for rec in (a, b):
            rec["summary"].pop("wall_time_s")
            rec.pop("result_file")  # (another write: other bytes, e.g. the wall time)
        assert a == b


def test_damaged_study_state_recomputes_exactly_the_damaged_stages(tmp_path):
    """A short study (one case, 4 s, no reduction): a damaged stage result (netCDF) or
    stage cache, case record or settings record is reported in one line; only the stages
    (and sweep cases) they belong to run again, and the report's tables are the same as
    before. (Every kind of damage is tried on the sweep's files above; the study checks
    its files with the same functions.)"""
    text = PAPER.read_text()
    head, _, cases = text.partition("[cases.")
    lhhl = "[cases." + next(b for b in cases.split("\n[cases.") if b.startswith("LHHL"))
    scenario = tmp_path / "paper-one-case.toml"
    scenario.write_text(head + lhhl)
    out = tmp_path / "report"

    def study():
        notes, stages = [], []
        run_study(scenario, out, overrides={"solver.t_end": 4.0}, reduction=False, workers=1,
                  notice=notes.append, progress=lambda s, m: stages.append((s, m)))
        return notes, stages

    study()
    tables = {p.name: p.read_text() for p in out.glob("*.csv")}
    assert tables
    ref_nc = tmp_path / "base_case.nc"
    shutil.copy(out / "base_case.nc", ref_nc)
    rounds = [
        # file: (damage, the stage or sweep case it belongs to)
        {"base_case.nc": (_truncated, "base"), "sweep/cases/LHHL.json": (_empty, "sweep"),
         "study.json": (_garbage, "settings")},
        {"cache/modal.json": (_garbage, "modal")},
    ]
    for damage in rounds:
        for name, (how, _) in damage.items():
            how(out / name)
        before = _stamps(out)
        notes, stages = study()
        kinds = {kind for how, kind in damage.values()}
        assert len(notes) == len(damage), notes  # one line each
        for name, (how, kind) in damage.items():
            assert any(name.rsplit("/", 1)[-1] in line for line in notes), (name, notes)
        rewritten = _rewritten(before, out)
        assert ("base_case.nc" in rewritten) == ("base" in kinds)
        assert ("cache/base.json" in rewritten) == ("base" in kinds)
        assert ("cache/modal.json" in rewritten) == ("modal" in kinds)
        assert ("fig8_modes.png" in rewritten) == ("modal" in kinds)
        assert ("sweep/cases/LHHL.json" in rewritten) == ("sweep" in kinds)
        reused = {s for s, m in stages if m.startswith("reused")}
        assert reused == {"base", "modal"} - kinds
        assert {p.name: p.read_text() for p in out.glob("*.csv")} == tables
        _same_data(out / "base_case.nc", ref_nc)

    # a damaged study.json is a study's own only beside a study's cache: a folder of
    # somebody else's files is still refused, before any work
    other = tmp_path / "other"
    other.mkdir()
    (other / "study.json").write_text("somebody else's notes")
    with pytest.raises(ScenarioError, match="--output.*not empty"):
        run_study(scenario, other, reduction=False, workers=1)
    assert (other / "study.json").read_text() == "somebody else's notes"
