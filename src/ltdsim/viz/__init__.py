"""Figures: a run's overview, brake pressures and curving (plotting), the figures of
the analyses, the study's Fig. 5-9 among them (analysis), and a run's interactive
page for ``ltdsim view`` (explorer, a self-contained Bokeh HTML file). Every axis
carries its unit, couplers and vehicles count from 1, and each function writes one file.

May import the base modules, ``physics`` (the track's alignment), ``scenario``,
``results`` and ``analysis``.
"""
