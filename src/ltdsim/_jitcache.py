"""Point numba's on-disk cache at a folder keyed by a hash of ltdsim's compiled sources.

numba checks only the timestamp of the file that defines a cached function, not of the
functions it calls, so editing a force law would otherwise leave a stale compiled
kernel in use. Keying the folder on the sources of every compiled module makes any
change start a fresh cache. A ``NUMBA_CACHE_DIR`` set by the user is respected: the
keyed folder goes inside it (``$NUMBA_CACHE_DIR/ltdsim-<hash>``), so that a cache
shared between versions of ltdsim, or between edits of its force laws, never hands one
version's kernels to another (numba would load a kernel whose inlined callees have
changed in another file, and run it without a word).

numba's cache is not safe when processes write to it side by side (numba issues 4807
and 10128): saving a kernel reads the function's index, picks the first free data-file
number and writes both back, so two processes that compile two versions of one
function at once (the study's workers compiling two kernel sets, a test suite's
workers) both take the same number; one version's index entry is lost, or points at
the other version's code. :func:`configure` therefore holds a file lock, per function
(``<index>.lock`` beside numba's index), around each save (exclusive) and each load
(shared), where the operating system has ``fcntl`` (Linux, macOS; elsewhere numba's
cache is used as it is).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
from pathlib import Path

import numba
from numba.core import caching

try:
    import fcntl
except ImportError:  # (Windows)
    fcntl = None

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


@contextlib.contextmanager
def _cache_lock(index_path: str, exclusive: bool):
    """Hold the lock of the cache index at ``index_path`` (exclusive for a writer, shared
    for a reader) while the block runs; no lock where the folder cannot hold one."""
    try:
        fh = open(index_path + ".lock", "ab")
    except OSError:  # (no folder yet, or read-only: numba reports the cache itself)
        yield
        return
    with fh:
        fcntl.flock(fh, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _locked(method, exclusive: bool):
    @functools.wraps(method)
    def under_lock(self, *args, **kwargs):
        with _cache_lock(self._index_path, exclusive):
            return method(self, *args, **kwargs)

    under_lock.ltdsim_locked = True
    return under_lock


def configure() -> None:
    """Point numba's cache at :func:`cache_dir` and make its saves and loads take the
    index's lock (once per process)."""
    numba.config.CACHE_DIR = str(cache_dir())
    files = caching.IndexDataCacheFile
    if fcntl is not None and not getattr(files.save, "ltdsim_locked", False):
        files.save = _locked(files.save, exclusive=True)
        files.load = _locked(files.load, exclusive=False)


configure()
