"""The data ltdsim ships: the study's published tables transcribed as JSON, and the named
parameter sets (presets) of every family, one TOML file each with its sources: draft
gears (``gears/``), brake valves (``brakes/``), traction motors (``motors/``) and rail
conditions for the creep law (``creep/``), the strengths of couplers and draw gear
(``strength/``, proof and ultimate loads with their sources) and their fatigue curves
(``fatigue/``, S-N curves in coupler force range with their sources), and the force
limits a make-up study compares its runs with (``limits/``, per wagon type).

One loader serves every family (:func:`preset_names`, :func:`load_preset`), reading
package data through importlib.resources so that an installed wheel finds it as a
source tree does. Imports nothing of ltdsim: every layer may read it.
"""

from __future__ import annotations

import copy
import json
import tomllib
from functools import cache
from importlib import resources

#: the preset families: their folder under the package data, and what a preset is
FAMILIES = {"gears": "gear preset", "brakes": "brake valve preset",
            "motors": "motor preset", "creep": "creep preset",
            "strength": "coupler strength grade", "fatigue": "coupler fatigue curve",
            "limits": "make-up force limit set"}


@cache
def study_tables() -> dict:
    """The study's published tables (Appendix I, Tables 1-7, Appendix II) as a dict.

    Units are in the key names (``_N``, ``_m_s``, ...); see the ``source`` entry.
    """
    return json.loads(resources.files(__package__).joinpath("study_tables.json").read_text())


def _folder(family: str):
    if family not in FAMILIES:
        raise ValueError(f"unknown preset family {family!r}; known: {', '.join(FAMILIES)}")
    return resources.files(__package__).joinpath(family)


@cache
def preset_names(family: str) -> tuple[str, ...]:
    """Names of the shipped presets of ``family`` ("gears", "brakes", "motors", "creep",
    "strength", "fatigue"),
    sorted; empty for an install without its package data."""
    folder = _folder(family)
    if not folder.is_dir():
        return ()
    return tuple(sorted(p.name.removesuffix(".toml") for p in folder.iterdir()
                        if p.name.endswith(".toml") and p.is_file()))


@cache
def _read(family: str, name: str) -> dict:
    # read once per process: a train of 200 preset gears asks 200 times
    return tomllib.loads(_folder(family).joinpath(f"{name}.toml").read_text(encoding="utf-8"))


def load_preset(family: str, name: str) -> dict:
    """The keys of preset ``name`` of ``family`` (a copy: the caller may change it).
    Raises ``ValueError`` in one line naming the preset and the ones available."""
    names = preset_names(family)
    if not isinstance(name, str) or name not in names:
        raise ValueError(f"unknown {FAMILIES[family]} {name!r}; available: "
                         f"{', '.join(names) or 'none (this install lacks its package data)'}")
    return copy.deepcopy(_read(family, name))
