"""Which version of ltdsim's code computed a cached result."""

from __future__ import annotations

import hashlib
from functools import cache
from pathlib import Path

from ltdsim._version import __version__

#: the packages and modules that only present results: editing them changes no computed
#: number (paths relative to the package)
PRESENTATION = ("cli/", "viz/", "study/report/")


@cache
def code_hash() -> str:
    """Hash (16 hex digits) of the version and of every source file that computes
    results, so caches written by other code are recomputed, not trusted."""
    here = Path(__file__).parent
    h = hashlib.sha256(__version__.encode())
    for path in sorted(here.rglob("*.py")):
        rel = path.relative_to(here).as_posix()
        if not rel.startswith(PRESENTATION):
            h.update(str(path.relative_to(here)).encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def source_commit() -> str:
    """The git commit of the checkout ltdsim runs from, with "+ local changes" when its
    package sources differ from that commit, or "no git checkout" for an installed
    package (a wheel carries no history)."""
    import subprocess

    here = Path(__file__).parent
    try:
        head = subprocess.run(["git", "-C", str(here), "rev-parse", "--short=12", "HEAD"],
                              capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--", "."],
                               capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return "no git checkout"
    return head.stdout.strip() + (" + local changes" if dirty.stdout.strip() else "")
