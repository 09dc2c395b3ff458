"""Output folders the commands write into: the checks before the work and the record of
the files written, so that running again into a folder replaces a command's own files
while a file of someone else's (or one changed since) is never written over."""

from __future__ import annotations

from pathlib import Path

from ltdsim.errors import ScenarioError

# (ltdsim.results.io, which imports xarray, is imported where it is used: the command
# line reads this module at start-up)

#: the record the analysis commands (phases, spectrum, sysid) and sweeps leave in their
#: output folder: the files they wrote there, each with its size and content hash
WRITTEN = "ltdsim-analysis-files.json"


def check_output_files(folder: Path, names, option: str = "--output") -> None:
    """Refuse, before any work, a file name the command writes in ``folder`` (each of
    ``names``) that is taken by something other than a file (a folder): writing it would
    fail only after the work."""
    for name in names:
        path = folder / name
        if path.exists() and not path.is_file():
            raise ScenarioError(option, [("", f"{path} is a folder where this command "
                                              "writes a file; move or remove it, or choose "
                                              f"another {option}")])


def owned_files(folder: Path) -> dict:
    """The files of ``folder`` the analyses wrote and that are unchanged since: name ->
    record (size and hash)."""
    from ltdsim.results.io import file_problem, read_sealed

    try:
        rec = read_sealed(folder / WRITTEN)
    except (FileNotFoundError, NotADirectoryError, ValueError):
        return {}
    files = rec.get("files") if isinstance(rec, dict) else None
    if not isinstance(files, list):
        return {}
    return {f["path"]: f for f in files if isinstance(f, dict)
            and isinstance(f.get("path"), str) and Path(f["path"]).name == f["path"]
            and file_problem(f, folder) is None}


def check_outputs(folder: Path, names, command: str, option: str = "--output") -> None:
    """Refuse, before any work, a name the command writes in ``folder`` (each of
    ``names``, and the record of written files) that is taken by a folder, or by a file
    an analysis did not write there (or that changed since)."""
    from ltdsim.results.io import read_sealed

    check_output_files(folder, (*names, WRITTEN), option)
    record = folder / WRITTEN
    if record.is_file():
        try:
            read_sealed(record)
        except ValueError:
            raise ScenarioError(option, [("", f"{record} is not the record of files ltdsim "
                                              f"writes there; ltdsim {command} does not "
                                              "write over it: move or remove it, or choose "
                                              f"another {option}")]) from None
    own = owned_files(folder)
    for name in names:
        if (folder / name).is_file() and name not in own:
            raise ScenarioError(option, [("", f"{folder / name} exists and is not a file an "
                                              f"earlier ltdsim {command} wrote there (or it "
                                              f"changed since); ltdsim {command} does not "
                                              "write over it: move or remove it, or choose "
                                              f"another {option}")])


def record_outputs(folder: Path, paths) -> None:
    """Add the files just written (``paths`` in ``folder``) to the folder's record."""
    from ltdsim.results.io import atomic_path, file_record, sealed_json

    own = owned_files(folder)
    for path in paths:
        own[Path(path).name] = file_record(path, folder)
    with atomic_path(folder / WRITTEN) as tmp:
        tmp.write_text(sealed_json({"written_by": "ltdsim phases, spectrum, sysid, sweep",
                                    "files": [own[k] for k in sorted(own)]}))
