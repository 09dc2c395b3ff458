"""The compiled engine: a validated scenario lowered to flat arrays (lowering, with the
column layouts of layout and the coupler-model registry of couplers), the step's
stability checked before a run (preflight), the numba kernel (kernel: named structures,
right-hand side, brakes, driver, Runge-Kutta stepping, recording) with its tableaux
(integrators), the run chunk by chunk (run), the single-gear rig (rig) and the compile
cache's warm-up (warmup).

Only this package knows how a train is laid out in memory. May import the base
modules, ``physics`` and ``scenario``.
"""
