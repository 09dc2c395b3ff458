"""Force laws of longitudinal train dynamics as pure functions.

Every law is a numba ufunc: called from Python it broadcasts over numpy arrays, called
from the compiled kernel it is inlined for scalars. The laws the kernels never call
(``davis_resistance``: the kernels use its scalar form; the wedge gear's quasi-static
curves; the exponential checks) are compiled at their first call rather than at import
(see :mod:`ltdsim.physics._lazy`). All quantities are SI (m, s, kg, N, W).
"""

from ltdsim.physics.air.brakes import brake_retardation, karwatzki
from ltdsim.physics.control import pid_init, pid_step
from ltdsim.physics.gears.couplers import coupler_linear, coupler_simplified
from ltdsim.physics.resistance import curve_resistance, davis_resistance, grade_resistance
from ltdsim.physics.drive.traction import adhesion_limit, traction_limit

__all__ = [
    "adhesion_limit",
    "brake_retardation",
    "coupler_linear",
    "coupler_simplified",
    "curve_resistance",
    "davis_resistance",
    "grade_resistance",
    "karwatzki",
    "pid_init",
    "pid_step",
    "traction_limit",
]
