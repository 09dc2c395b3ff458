"""The compiled-kernel cache never hands out a force law older than its source.

numba finds a cached function by the file that defines it and that file's timestamp,
not by the functions inlined into it from other files; ltdsim keys its cache folder on
the sources instead (:mod:`ltdsim._jitcache`), also inside a ``NUMBA_CACHE_DIR`` the
user sets. Checked the way it would fail: a force law is compiled into the cache, a
function it inlines from another module is edited, and the next process must compute
with the edit.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import ltdsim

# a simplified coupler (paper Eq. 9, its fade read on the rate) 10 mm into draft past its
# slack, at rest: its stiffness fade exp(-|v|/v_c) is 1, so T = P + (k3 + k2) e (N, m,
# N s/m, N/m, m/s)
SLACK, PRELOAD, DAMP, K1, K2, K3, VC = 0.02, 5e4, 1e3, 8.0e6, 1.9e6, 3.5e6, 0.6
D = 0.5 * SLACK + 0.01  # m, coupler deflection: 10 mm past the slack's edge

FORCE = (
    "import math, ltdsim.physics.gears.couplers as c; "
    f"print(repr(float(c.coupler_simplified({D}, 0.0, {SLACK}, {PRELOAD}, {DAMP}, {K1}, "
    f"{K2}, {K3}, {VC}, True, math.inf, 0.0))))"
)


def _force(pkg_root: Path, cache: Path) -> float:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "NUMBA_DISABLE_JIT")}
    env.update(PYTHONPATH=str(pkg_root), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", FORCE], env=env, cwd=pkg_root,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return float(out.stdout.strip())


def test_an_edited_inlined_force_law_is_recompiled_under_a_user_cache_folder(tmp_path):
    pkg = tmp_path / "src"
    shutil.copytree(Path(ltdsim.__file__).parent, pkg / "ltdsim",
                    ignore=shutil.ignore_patterns("__pycache__"))
    cache = tmp_path / "numba-cache"
    e = D - 0.5 * SLACK
    before = _force(pkg, cache)
    assert abs(before - (PRELOAD + (K3 + K2) * e)) <= 1e-9 * before  # Eq. 9 at rest
    # the fade exp(-|v|/v_c), inlined from decay.py into couplers.py, now doubled: the
    # draft force at rest gains k2 e; couplers.py itself is untouched
    decay = pkg / "ltdsim" / "physics" / "decay.py"
    head, sep, body = decay.read_text().partition("def exp_neg(z):")
    old = "    if 0.0 <= z < SERIES_LIMIT:\n        return _series(z)\n"
    assert sep and old in body
    decay.write_text(head + sep + body.replace(old, old.replace("return _series(z)",
                                                                  "return 2.0 * _series(z)"), 1))
    after = _force(pkg, cache)
    assert abs(after - (PRELOAD + (K3 + 2.0 * K2) * e)) <= 1e-9 * after, (before, after)
    # both versions stay cached side by side, each in its own keyed folder
    assert len([p for p in cache.iterdir() if p.name.startswith("ltdsim-")]) == 2


# ---------------------------------------------------------------------------------------
# Two processes saving two versions of one function into the cache at once
RACY = "from numba import njit\n\n@njit(cache=True)\ndef shift(x):\n    return x + 1\n"

#: a process that compiles ``shift`` for one argument type into the cache. Its save waits,
#: inside numba's read-index/write-index step, until the other process has come to the
#: cache (its lookup before compiling) and then to its own save, or, when that does not
#: come within 3 s (the other process waits for the lock), no longer; then 0.5 s more.
#: Without a lock both processes thus read the index before either writes it: the
#: overlap that loses one version (numba issues 4807, 10128)
SAVER = """
import pathlib, sys, time
import ltdsim
from numba.core import caching
here, me, other, arg = pathlib.Path(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
files = caching.IndexDataCacheFile
load, save, write = files.load, files.save, files._save_index
def look(self, key):
    (here / (me + ".load")).touch()
    return load(self, key)
def arrive(self, key, data):
    (here / (me + ".save")).touch()
    return save(self, key, data)
def wait_for(name, seconds):
    t0 = time.monotonic()
    while not (here / name).exists() and time.monotonic() - t0 < seconds:
        time.sleep(0.01)
def late_write(self, overloads):
    wait_for(other + ".load", 60.0)
    wait_for(other + ".save", 3.0)
    time.sleep(0.5)
    return write(self, overloads)
files.load, files.save, files._save_index = look, arrive, late_write
sys.path.insert(0, str(here))
import racy
print(repr(racy.shift(int(arg) if me == "a" else float(arg))))
"""

LOADER = """
import sys
import ltdsim
sys.path.insert(0, sys.argv[1])
import racy
print(repr(racy.shift(3)), repr(racy.shift(3.5)), len(racy.shift.stats.cache_hits), sum(racy.shift.stats.cache_misses.values()))
"""


def test_two_processes_saving_two_versions_of_a_kernel_at_once_keep_both(tmp_path):
    (tmp_path / "racy.py").write_text(RACY)
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_DISABLE_JIT",)}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "cache")
    run = dict(env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
               text=True)
    procs = [subprocess.Popen([sys.executable, "-c", SAVER, str(tmp_path), me, other, "1"],
                              **run) for me, other in (("a", "b"), ("b", "a"))]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-2000:] for o in outs]
    assert [o[0].strip() for o in outs] == ["2", "2.0"]
    # a third process finds both versions in the cache, each computing its own type
    out = subprocess.run([sys.executable, "-c", LOADER, str(tmp_path)], timeout=300,
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    # both versions loaded, neither compiled again
    assert out.stdout.split() == ["4", "4.5", "2", "0"], out.stdout
