"""Published data of the study (paper tables transcribed as JSON)."""

from __future__ import annotations

import json
from functools import cache
from importlib import resources


@cache
def study_tables() -> dict:
    """The study's published tables (Appendix I, Tables 1-7, Appendix II) as a dict.

    Units are in the key names (``_N``, ``_m_s``, ...); see the ``source`` entry.
    """
    return json.loads(resources.files(__package__).joinpath("study_tables.json").read_text())
