"""Figures: a run's overview, brake pressures and curving (plotting), and the figures of
the analyses, the study's Fig. 5-9 among them (analysis). Every axis carries its unit,
couplers and vehicles count from 1, and each function writes one image file.

May import the base modules, ``scenario``, ``results`` and ``analysis``.
"""
