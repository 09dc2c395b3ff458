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


def _recorded(folder: Path, record: str) -> list | None:
    """The file records listed in ``folder / record`` (None without a valid record)."""
    from ltdsim.results.io import read_sealed

    try:
        rec = read_sealed(folder / record)
    except (FileNotFoundError, NotADirectoryError, ValueError):
        return None
    files = rec.get("files") if isinstance(rec, dict) else None
    return files if isinstance(files, list) else None


def owned_files(folder: Path, record: str = WRITTEN) -> dict:
    """The files of ``folder`` that ltdsim wrote there (listed in its ``record``) and that
    are unchanged since: name -> record (size and hash)."""
    from ltdsim.results.io import file_problem

    return {f["path"]: f for f in _recorded(folder, record) or [] if isinstance(f, dict)
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
        tmp.write_text(sealed_json({"written_by": "ltdsim phases, spectrum, sysid, modal, "
                                                  "sweep",
                                    "files": [own[k] for k in sorted(own)]}))


# ------------------------------------------------ a folder a command has to itself
def check_own_folder(folder: Path, record: str, names, outputs: dict, command: str,
                     option: str) -> list[dict]:
    """Refuse, before the work, a folder ``option`` (``folder``) that a command has to
    itself (``ltdsim run --report``) when it holds anything but that command's earlier
    files (those its ``record`` lists, unchanged since: the same size and content) and
    the command's other ``outputs`` (option: path), so that nothing of someone else's is
    written over and no earlier file is left beside new ones; refuse too one of
    ``outputs`` where the command writes one of ``names``. Returns the records of the
    earlier files (replaced or removed by :func:`replace_own_files`)."""
    from ltdsim.results.io import same_file

    for other, path in outputs.items():
        for name in (*names, record):
            if path is not None and same_file(path, folder / name):
                raise ScenarioError(other, [("", f"{path} is where {option} writes its "
                                                 f"{name}; choose another path")])
    if not folder.is_dir():
        return []
    listed = _recorded(folder, record)
    own = list(owned_files(folder, record).values())
    known = {f["path"] for f in own} | ({record} if listed is not None else set())
    keep = {Path(path).name for path in outputs.values()
            if path is not None and same_file(Path(path).parent, folder)}
    foreign = sorted(e.name for e in folder.iterdir() if e.name not in known | keep)
    if foreign:
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3
                                          else "")
        raise ScenarioError(option, [("", f"{folder} holds what {command} did not write "
                                          f"({shown}); give an empty or new folder, or one "
                                          f"holding only what an earlier {command} wrote")])
    return own


def replace_own_files(folder: Path, record: str, write, earlier: list[dict],
                      written_by: str):
    """Call ``write()`` (which writes into ``folder``, checked by
    :func:`check_own_folder`), remove the ``earlier`` files it did not write again (if
    still as written then), and record the files it wrote in ``record``. Returns what
    ``write`` returns."""
    import os

    from ltdsim.results.io import atomic_path, file_problem, file_record, sealed_json

    def seen() -> dict:
        if not folder.is_dir():
            return {}
        return {e.name: (st.st_ino, st.st_mtime_ns) for e in folder.iterdir()
                for st in (e.stat(),)}

    before = seen()
    out = write()
    written = sorted(name for name, st in seen().items()
                     if before.get(name) != st and name != record)
    for rec in earlier:
        if rec["path"] not in written and file_problem(rec, folder) is None:
            os.unlink(folder / rec["path"])
    with atomic_path(folder / record) as tmp:
        tmp.write_text(sealed_json({"written_by": written_by,
                                    "files": [file_record(folder / n, folder)
                                              for n in written]}))
    return out
