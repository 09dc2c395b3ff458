"""Saving and loading results (netCDF-4 via h5netcdf), written atomically."""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path

import xarray as xr

from ltdsim.errors import ScenarioError


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


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether paths ``a`` and ``b`` name one file (the same path, or one file reached
    by a link); False when either cannot be looked at."""
    a, b = Path(a), Path(b)
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists()
                                              and os.path.samefile(a, b))
    except OSError:
        return False


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


#: what every result :func:`save_result` writes holds (dimensions and variables)
RESULT_DIMS = ("time", "vehicle", "coupler")
RESULT_VARS = ("position", "velocity", "acceleration", "coupler_deflection", "coupler_force",
               "traction_force", "speed_reference", "speed_error", "adhesion_limit",
               "traction_demand")
_HDF5 = b"\x89HDF\r\n\x1a\n"


def load_result(path: str | Path, needs: tuple[str, ...] = RESULT_VARS,
                keep: tuple[str, ...] | None = None, purpose: str = "") -> xr.Dataset:
    """Read a result written by :func:`save_result` into memory.

    Parameters
    ----------
    path : str or Path
        The result file (.nc, netCDF-4).
    needs : tuple of str
        The variables the caller cannot do without (by default every variable a whole
        recording holds); a result without one of them is refused.
    keep : tuple of str, optional
        Read only these data variables (those of them the file holds) and the
        coordinates, to spare the time and memory of the others; None: all of them.
    purpose : str
        What ``needs`` are for, in a few words ("the viewer draws from it"), said when
        a result written by ltdsim lacks one of them; empty: the whole recording is
        read.

    Raises
    ------
    ScenarioError
        In one line naming the file, when it is missing, a folder, empty, text or other
        bytes rather than netCDF-4, cut short, damaged, or a netCDF file that ltdsim did
        not write (without the variables and the scenario a result holds).
    """
    path = Path(path)
    _check_result_file(path)
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            missing = [v for v in RESULT_DIMS if v not in ds.dims]
            if keep is not None:
                ds = ds[[v for v in ds.data_vars if v in keep]]
            ds = ds.load()
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - h5py, h5netcdf and xarray raise many kinds
        raise _bad(path, _damage(path, exc)) from None
    missing += [v for v in needs if v not in ds.variables]
    if "scenario_json" not in ds.attrs:
        missing.append("the scenario_json attribute")
    if missing:
        shown = ", ".join(missing[:6]) + (f" and {len(missing) - 6} more" if len(missing) > 6
                                          else "")
        if "scenario_json" in ds.attrs and "ltdsim_version" in ds.attrs and purpose:
            raise _bad(path, f"a result written by ltdsim that lacks {shown} ({purpose}): "
                             "its run recorded only some time series (solver.record); "
                             "name it in solver.record, or leave solver.record out, and "
                             "run the scenario again")
        if "scenario_json" in ds.attrs and "ltdsim_version" in ds.attrs:
            # an ltdsim result of a run that recorded a selection (solver.record)
            raise _bad(path, f"a result written by ltdsim that lacks {shown}: its run "
                             "recorded only some time series (solver.record), and this "
                             "command reads the whole recording; run the scenario again "
                             "without solver.record")
        raise _bad(path, f"a netCDF-4 file, but not a result written by ltdsim: it lacks "
                         f"{shown} (results come from ltdsim run -o FILE.nc or "
                         "ltdsim.save_result)")
    try:
        json.loads(ds.attrs["scenario_json"])
    except (TypeError, ValueError):
        raise _bad(path, "its scenario_json attribute is not valid JSON; the result was "
                         "damaged or not written by ltdsim") from None
    return ds


def _bad(path: Path, why: str) -> ScenarioError:
    return ScenarioError(str(path), [("", why)])


def check_result_file(path: str | Path) -> None:
    """Refuse, by its first bytes and before any reading, what cannot be a netCDF-4
    result (a ScenarioError in one line naming the file, as :func:`load_result`)."""
    _check_result_file(Path(path))


def _check_result_file(path: Path) -> None:
    """Refuse, by its first bytes, what cannot be a netCDF-4 result."""
    if path.is_dir():
        raise _bad(path, "is a folder, not a result file (.nc)")
    try:
        size = path.stat().st_size
        with path.open("rb") as fh:
            head = fh.read(2048 + 8)
    except FileNotFoundError:
        raise _bad(path, "file not found") from None
    except OSError as exc:
        raise _bad(path, f"cannot read: {exc.strerror or exc}") from None
    if size == 0:
        raise _bad(path, "empty file (0 bytes), not a result; rerun the simulation that "
                         "writes it")
    if any(head[k:k + 8] == _HDF5 for k in (0, 512, 1024, 2048)):
        return
    if head[:3] == b"CDF":
        raise _bad(path, "a netCDF-3 (classic) file, not a result written by ltdsim "
                         "(ltdsim writes netCDF-4)")
    if head[:3] == b"\x89HD" or (size < 8 and _HDF5.startswith(head)):
        raise _bad(path, f"cut short: {size:,} bytes, not even a netCDF-4 header")
    try:
        text = head.decode("utf-8")
        is_text = all(c.isprintable() or c in "\t\r\n" for c in text)
    except UnicodeDecodeError:
        is_text = False
    kind = "a text file" if is_text else "unknown bytes (no netCDF-4/HDF5 signature)"
    raise _bad(path, f"{kind}, not a result written by ltdsim (.nc, netCDF-4)")


def _damage(path: Path, exc: Exception) -> str:
    """What is wrong with a netCDF-4 file the reader refused, in a few words."""
    text = str(exc)
    found = re.search(r"eof = (\d+).*stored_eof = (\d+)", text)
    if "truncated file" in text and found:
        have, want = (int(x) for x in found.groups())
        return (f"cut short: {have:,} of its {want:,} bytes (an interrupted copy or "
                "write); copy it again or rerun the simulation that writes it")
    first = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
    return f"a damaged netCDF-4 file ({type(exc).__name__}: {first[:160]})"


def scenario_of(ds: xr.Dataset, scenario=None):
    """The scenario that made result ``ds``: ``scenario`` when given, else the one the
    result stores (its ``scenario_json`` attribute, :meth:`Scenario.from_saved`)."""
    if scenario is not None:
        return scenario
    from ltdsim.scenario import Scenario

    return Scenario.from_saved(json.loads(ds.attrs["scenario_json"]), "result")

