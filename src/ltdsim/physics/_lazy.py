"""numba ufuncs compiled when first called instead of when ltdsim is imported.

``numba.vectorize`` with signatures compiles at import (or loads from the cache). For a
law that the kernels never call and most runs never use (checks, plots, set-up of one
gear model), that compile is paid by every first run on a machine: about 3 s of CPU for
the wedge gear's quasi-static curves alone. :func:`vectorize_when_used` defers it to the
first call; the ufunc is the same (same signatures, same cache).

Such a law cannot be called from compiled code (it is a Python object until first
used); the kernels call the scalar functions the ufuncs are built on.
"""

from __future__ import annotations

import functools

from numba import vectorize


class _WhenUsed:
    def __init__(self, pyfunc, signatures, options):
        functools.update_wrapper(self, pyfunc)
        self._build = (pyfunc, signatures, options)
        self._ufunc = None

    @property
    def ufunc(self):
        """The numba ufunc (compiled, or loaded from the cache, on first access)."""
        if self._ufunc is None:
            pyfunc, signatures, options = self._build
            self._ufunc = vectorize(signatures, **options)(pyfunc)
        return self._ufunc

    def __call__(self, *args, **kwargs):
        return self.ufunc(*args, **kwargs)

    def __getattr__(self, name):  # ufunc attributes (nin, reduce, ...)
        if name.startswith("__") or name in ("_build", "_ufunc"):
            raise AttributeError(name)
        return getattr(self.ufunc, name)

    def __repr__(self):
        return f"<ltdsim ufunc {self.__name__}, compiled when first used>"


def vectorize_when_used(signatures, **options):
    """``numba.vectorize(signatures, **options)``, compiled at the first call."""
    def decorate(pyfunc):
        return _WhenUsed(pyfunc, signatures, options)
    return decorate
