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
