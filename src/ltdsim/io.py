"""Saving and loading results (netCDF-4 via h5netcdf), written atomically."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import xarray as xr


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path beside ``path``; move it into place only on success."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def save_result(ds: xr.Dataset, path: str | Path) -> Path:
    """Write a result dataset to netCDF-4 (opens in MATLAB, Python, Julia, R).

    The file appears complete or not at all: it is written to a temporary file in the
    same folder and renamed.
    """
    path = Path(path)
    encoding = {name: {"zlib": True, "complevel": 1} for name in ds.data_vars}
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="h5netcdf", encoding=encoding)
    return path


def load_result(path: str | Path) -> xr.Dataset:
    """Read a result written by :func:`save_result` into memory."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()
