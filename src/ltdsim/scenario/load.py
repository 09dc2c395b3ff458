"""Reading scenario files: TOML in (with one clear line for a file that is not TOML), a
track profile CSV read beside it, the named case applied, a validated :class:`Scenario`
out.
"""

from __future__ import annotations

import tomllib
from pathlib import Path


from ltdsim.errors import ScenarioError
from ltdsim.scenario._base import MAX_CHAINAGE

from ltdsim.scenario.model import Scenario
from ltdsim.scenario.unused import first_of_each, no_effect, written


# ---------------------------------------------------------------------- loading
def load_scenario(path: str | Path, case: str | None = None) -> Scenario:
    """Read, validate and return the scenario in TOML file ``path``.

    Every named case under ``[cases.*]`` is validated too, so a bad case key fails at
    load time. With ``case`` given, that case's overrides are applied.

    Raises
    ------
    ScenarioError
        With the file name, the dotted key and the allowed range for each problem.
    """
    path = Path(path)
    data = read_toml(path)
    if isinstance(data.get("scenario"), str) and "makeups" in data:
        raise ScenarioError(str(path), [("", f"a make-up study file (its scenario and "
                                             f"makeups keys), not a scenario: run it with "
                                             f"`ltdsim makeup {path}`")])
    sweep = _sweep_tables(data)
    if sweep:
        raise ScenarioError(str(path), [("", f"a sweep file (its {sweep}), not a scenario: "
                                             f"run its cases with `ltdsim sweep {path}`")])
    track = data.get("track")
    if isinstance(track, dict) and isinstance(track.get("profile_file"), str):
        track["profile"] = read_profile(path.parent / track["profile_file"], str(path))
    return scenario_from_data(data, str(path), case)


#: what marks a sweep file (ltdsim.sweep.load_sweep): a scenario file it starts from and
#: the tables of its cases
_SWEEP_TABLES = ("overrides", "grid", "list", "monte_carlo")


def _sweep_tables(data: dict) -> str:
    """How ``data`` reads as a sweep file ("scenario key and [list] table"), or "" when it
    does not (a ``scenario`` string with one of the sweep's tables)."""
    if not isinstance(data.get("scenario"), str):
        return ""
    tables = [f"[{k}]" for k in _SWEEP_TABLES if isinstance(data.get(k), dict)]
    if not tables:
        return ""
    return f"scenario key and {' and '.join(tables)} table{'s' if len(tables) > 1 else ''}"


def read_profile(path: str | Path, source: str) -> list[list[float]]:
    """The rows [chainage m, curvature 1/m, cant m] of the alignment CSV ``path`` (a header
    line of text is skipped), or a :class:`ScenarioError` in one line naming the file
    and the line. ``source`` is the scenario file that names it."""
    import csv

    path = Path(path)
    key = "track.profile_file"
    try:
        text = path.read_text(encoding="utf-8-sig")  # (a byte-order mark dropped)
    except (OSError, UnicodeDecodeError) as exc:
        why = "file not found" if isinstance(exc, FileNotFoundError) else f"cannot read: {exc}"
        raise ScenarioError(source, [(key, f"{path}: {why}")]) from None
    rows = []
    for k, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        try:
            vals = [float(c) for c in row]
        except ValueError:
            if not rows and k == 1:
                continue  # header
            raise ScenarioError(source, [(key, f"{path} line {k}: not three numbers "
                                               f"(chainage m, curvature 1/m, cant m): "
                                               f"{','.join(row)!r}")]) from None
        if len(vals) != 3:
            raise ScenarioError(source, [(key, f"{path} line {k}: {len(vals)} columns, "
                                               "expected 3 (chainage m, curvature 1/m, "
                                               "cant m)")])
        if not abs(vals[0]) <= MAX_CHAINAGE:
            raise ScenarioError(source, [(key, f"{path} line {k}: the chainage must lie "
                                               f"within +-{MAX_CHAINAGE:g} m of chainage 0 "
                                               f"({MAX_CHAINAGE / 1e3:,.0f} km), got "
                                               f"{vals[0]:g} m")])
        rows.append(vals)
    if not rows:
        raise ScenarioError(source, [(key, f"{path}: no data rows")])
    return rows


def scenario_from_data(data: dict, source: str, case: str | None = None) -> Scenario:
    """:func:`load_scenario` of a table already read (``source`` names it in messages):
    the scenario and every case validated, ``case`` applied. A key given that would have
    no effect in the scenario and in every case (:mod:`ltdsim.scenario.unused`) is
    refused, and so is a ``case`` key (``--case`` chooses the case)."""
    scenario = Scenario.from_dict(data, source)
    if "case" in data:
        raise ScenarioError(source, [("case", scenario._case_key())])
    cases = {name: scenario.with_case(name, source) for name in scenario.cases}
    unused = [(k, m) for k, m in no_effect(scenario) if written(scenario, k)]
    for other in cases.values():  # a key a case reads is not without effect
        keys = {k for k, _ in no_effect(other)}
        unused = [(k, m) for k, m in unused if k in keys]
    if unused:
        raise ScenarioError(source, first_of_each(unused))
    if case is not None:
        scenario = cases[case] if case in cases else scenario.with_case(case, source)
    return scenario


def read_toml(path: str | Path, what: str = "scenario file") -> dict:
    """The table in TOML file ``path``, or a :class:`ScenarioError` in one line naming the
    file and what is wrong with it: missing, a folder, unreadable (permissions), not UTF-8
    text (a binary file, or a byte of another encoding in a string or comment; the line
    and column are given), or not valid TOML. A UTF-8 byte-order mark at the start is
    dropped."""
    path = Path(path)
    source = str(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError(source, [("", "file not found")]) from None
    except IsADirectoryError:
        raise ScenarioError(source, [("", f"is a folder, not a {what} (give the .toml "
                                          "file)")]) from None
    except PermissionError:
        raise ScenarioError(source, [("", "cannot read the file: permission denied")]) from None
    except OSError as exc:
        raise ScenarioError(source, [("", f"cannot read the file: "
                                          f"{exc.strerror or exc}")]) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        kind = ("a binary file, not TOML text" if b"\0" in raw[:8192] else
                "not UTF-8 text")
        raise ScenarioError(source, [("", f"{kind}: byte 0x{raw[exc.start]:02x} at line "
                                          f"{line}, column {col} (TOML files are UTF-8: "
                                          "save the file as UTF-8)")]) from None
    if text.startswith("\ufeff"):  # a byte-order mark some editors write: not TOML's
        text = text[1:]
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        kind = "a binary file, not TOML text" if "\0" in text[:8192] else "not valid TOML"
        raise ScenarioError(source, [("", f"{kind}: {exc}")]) from None
