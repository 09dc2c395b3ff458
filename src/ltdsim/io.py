"""Saving and loading results (netCDF-4 via h5netcdf), written atomically."""

from __future__ import annotations

import hashlib
import json
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


# ----------------------------------------------------- records of what was written
# Files that are reused later (sweep case records and time series, the study's stage
# caches and their files) carry what they were when written: a file its size in bytes
# and BLAKE2b content hash, a JSON record the hash of its own content. A reader that
# finds anything else says why in one line and computes the thing again.
DIGEST = "blake2b"  # (32-byte digests, as hex)
#: the key of a sealed JSON record that holds the hash of the rest of the record
SEAL = "content_blake2b"


def _hasher(data: bytes = b""):
    return hashlib.blake2b(data, digest_size=32)


def file_record(path: str | Path, root: str | Path) -> dict:
    """``{"path", "size", "blake2b"}`` of a file just written: its path relative to
    ``root`` (so the folder can move), its size in bytes and its content hash."""
    path = Path(path)
    with open(path, "rb") as f:
        digest = hashlib.file_digest(f, _hasher).hexdigest()
    return {"path": os.path.relpath(path, root), "size": path.stat().st_size, DIGEST: digest}


def file_problem(record, root: str | Path) -> str | None:
    """Why the file of ``record`` (see :func:`file_record`) is no longer what was
    written, in words (missing, empty, another size, other content); None if it is."""
    if not (isinstance(record, dict) and isinstance(record.get("path"), str)
            and isinstance(record.get("size"), int) and isinstance(record.get(DIGEST), str)):
        return "the record of its files is damaged"
    path = Path(root) / record["path"]
    try:
        if not path.is_file():
            return f"{path} is missing" if not path.exists() else f"{path} is not a file"
        size = path.stat().st_size
        if size != record["size"]:
            return (f"{path} is empty (written with {record['size']} bytes)" if size == 0
                    else f"{path} has {size} bytes (written with {record['size']})")
        with open(path, "rb") as f:
            digest = hashlib.file_digest(f, _hasher).hexdigest()
    except OSError as exc:
        return f"{path} cannot be read ({exc.strerror or exc})"
    if digest != record[DIGEST]:
        return f"{path} differs from what was written (another content hash)"
    return None


def _content_hash(obj) -> str:
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"))
    return _hasher(text.encode()).hexdigest()


def sealed_json(record: dict) -> str:
    """``record`` as JSON text with the hash of its content under :data:`SEAL` (numpy
    numbers are written as floats)."""
    plain = json.loads(json.dumps(record, default=float))  # as it will read back
    return json.dumps({**plain, SEAL: _content_hash(plain)}, indent=1)


def read_sealed(path: str | Path) -> dict:
    """The record written by :func:`sealed_json` to ``path``.

    Raises FileNotFoundError when there is no file, ValueError saying what is wrong
    when it is not such a record (unreadable, empty, not JSON, another content)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise ValueError(f"{path} cannot be read ({exc.strerror or exc})") from None
    if not data.strip():
        raise ValueError(f"{path} is empty")
    try:
        rec = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise ValueError(f"{path} is not a JSON record (damaged or truncated)") from None
    if not isinstance(rec, dict) or SEAL not in rec:
        raise ValueError(f"{path} is not a record written by ltdsim (no content hash)")
    seal = rec.pop(SEAL)
    if seal != _content_hash(rec):
        raise ValueError(f"{path} differs from what was written (another content hash)")
    return rec


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
