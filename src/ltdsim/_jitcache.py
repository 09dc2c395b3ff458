"""Point numba's on-disk cache at a folder keyed by a hash of ltdsim's compiled sources.

numba checks only the timestamp of the file that defines a cached function, not of the
functions it calls, so editing a force law would otherwise leave a stale compiled
kernel in use. Keying the folder on the sources of every compiled module makes any
change start a fresh cache. A ``NUMBA_CACHE_DIR`` set by the user is respected: the
keyed folder goes inside it (``$NUMBA_CACHE_DIR/ltdsim-<hash>``), so that a cache
shared between versions of ltdsim, or between edits of its force laws, never hands one
version's kernels to another (numba would load a kernel whose inlined callees have
changed in another file, and run it without a word).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

#: modules without compiled code whose constants the kernels freeze
LAYOUTS = ("layout.py", "lowering.py")


def source_hash() -> str:
    """Hash of the package's compiled modules and the numba version (12 hex digits).

    The compiled modules are found, not listed: every module that mentions numba (a
    hand-kept list would go stale silently and load old kernels), plus layout.py and
    lowering.py, whose column constants numba freezes into the kernels as globals
    (coupler_models.py, with the coupler table's, compiles code and is found anyway).
    Editing a module that numba does not compile leaves the cache valid.
    """
    here = Path(__file__).parent
    h = hashlib.sha256(numba.__version__.encode())
    for path in sorted(here.rglob("*.py")):
        text = path.read_bytes()
        if path.name != "_jitcache.py" and (b"numba" in text or path.name in LAYOUTS):
            h.update(str(path.relative_to(here)).encode())
            h.update(text)
    return h.hexdigest()[:12]


def cache_dir() -> Path:
    """The folder numba's on-disk cache uses in this process: ``$NUMBA_CACHE_DIR/ltdsim-<hash>``
    when that variable is set, else ``$XDG_CACHE_HOME/ltdsim/numba-<hash>`` (by default
    under ``~/.cache``), ``<hash>`` the :func:`source_hash`."""
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        return Path(user) / f"ltdsim-{source_hash()}"
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "ltdsim" / f"numba-{source_hash()}"


def configure() -> None:
    numba.config.CACHE_DIR = str(cache_dir())


configure()
