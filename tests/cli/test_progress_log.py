"""Long commands report their progress also when stderr is a log file, not a terminal.

rich's live display prints nothing useful into a file or a pipe; there the commands
write timestamped lines instead. These tests run the commands with stderr captured (not
a terminal) and read the lines a log would hold.
"""

import io
import re
import subprocess
import sys

from numba import njit
from rich.console import Console

from ltdsim.progress import COMPILING, Display
from ltdsim.engine.warmup import KernelCall, warm_up

from conftest import ROOT
from conftest import short_paper

STAMP = r"\d\d:\d\d:\d\d "


def _cli(*args, cwd=None):
    proc = subprocess.run([sys.executable, "-m", "ltdsim.cli.app", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=900)
    assert proc.returncode == 0, proc.stderr
    return proc.stderr.splitlines()


def test_run_logs_the_simulated_time_from_start_to_end():
    lines = _cli("run", ROOT / "scenarios" / "short-train.toml", "--set", "solver.t_end=3")
    sim = [ln for ln in lines if "s simulated" in ln]
    assert re.fullmatch(STAMP + r"simulating short-train: 0\.0/3\.0 s simulated", sim[0]), sim
    assert re.fullmatch(STAMP + r"simulating short-train: 3\.0/3\.0 s simulated, \d+ s",
                        sim[-1]), sim
    # no rich live-display remnants (cursor movements) in the log
    assert not any("\x1b" in ln for ln in lines)


def test_study_logs_every_stage_and_the_sweep_count(tmp_path):
    scenario = short_paper(tmp_path)  # two cases
    lines = _cli("study", scenario, "--output", tmp_path / "report", "--set",
                 "solver.t_end=4", "--no-reduction", "--workers", "1")
    stages = [m.group(1) for ln in lines if (m := re.match(STAMP + r"([a-z]+): ", ln))]
    order = [s for i, s in enumerate(stages) if s not in stages[:i]]
    assert order == ["sweep", "base", "modal", "report", "done"], lines
    assert any(re.fullmatch(STAMP + r"sweep: 2/2 cases(, \d+ s)?", ln) for ln in lines), lines
    assert lines[-1].endswith("index.html")
    assert not any("\x1b" in ln for ln in lines)


@njit  # (a fresh function: nothing in memory or on disk, so the call compiles)
def _fresh(x):
    total = 0.0
    for i in range(x.shape[0]):
        total += x[i] * x[i]
    return total


def test_a_compile_is_announced_with_its_elapsed_time_and_a_cached_kernel_is_not():
    import numpy as np

    log = io.StringIO()
    console = Console(file=log, force_terminal=False, width=200)
    call = KernelCall("test kernel", _fresh, (np.ones(3),))
    assert call.ready() is False
    with Display(console, interval=0.0) as show:
        spent = warm_up([call], show.compiling, interval=0.001)
    lines = log.getvalue().splitlines()
    assert spent > 0.0
    assert re.fullmatch(STAMP + re.escape(COMPILING) + ": .*", lines[0]), lines
    assert re.fullmatch(STAMP + r"compiled in \d+ s .*", lines[-1]), lines
    assert call.ready() is True
    log.truncate(0)
    with Display(console) as show:
        assert warm_up([call], show.compiling) == 0.0
    assert log.getvalue() == ""
