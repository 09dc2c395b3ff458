"""Analyses of results: the train's modes (modal), coupler-force spectra (spectra),
per-phase norms and critical couplers (phases), transfer-function identification
(identify), step and ramp metrics (response), why a speed-controlled run rings
(diagnostics), single gears on the rig and their catalogue ratings (gears), the model
reduction (reduction) and the study's standard experiments (experiments).

Each takes results, scenarios or arrays and returns tables or numbers; none draws (the
figures are in :mod:`ltdsim.viz`). May import the base modules, ``physics``,
``scenario``, ``engine`` (the gear rig, the couplers' linearised stiffness) and
``results``.
"""
