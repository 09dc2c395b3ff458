"""The study's reproduction: its stages (the model reduction, the 16 coupler cases,
the base case's phases and spectra, the modes), cached and resumable (stages), and the
report that sets ltdsim beside the study, table by table (report).

May import every layer below it: the base modules, ``physics``, ``scenario``,
``engine``, ``results``, ``analysis``, ``viz`` and ``sweep``.
"""
