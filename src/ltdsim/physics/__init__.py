"""Force laws of longitudinal train dynamics as pure functions: running resistance
(resistance), the speed controller (control), the fast exponentials the laws share
(decay), the track in the plane (alignment), curving safety's limits (curving), and in
subpackages the couplers and draft gears (gears), the air brake (air) and traction with
the induction drive (drive).

Every law a user calls on arrays is a numba ufunc: called from Python it broadcasts
over numpy arrays, called from the compiled kernel it is inlined for scalars. The laws
the kernels never call are compiled at their first call rather than at import (see
:mod:`ltdsim.physics._lazy`). All quantities are SI (m, s, kg, N, W). May import only
the base modules (errors, the data files): physics knows nothing of scenarios or
kernels.
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
