"""Sweeps: many variants of one scenario (named cases, grids, lists, seeded Monte-Carlo
samples) run on local worker processes or a Dask cluster, each finished case written
atomically and checked before it is reused, so a killed sweep resumes; its summary
tables and best case (core).

May import the base modules, ``scenario``, ``engine``, ``results`` and ``analysis``.
"""
