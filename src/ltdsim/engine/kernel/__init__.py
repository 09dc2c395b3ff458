"""The compiled simulation loop: right-hand side, driver, Runge-Kutta stepping, records.

Owns the two kernels, :func:`run` (a fixed-step explicit Runge-Kutta method on the
run's grid) and :func:`run_adaptive` (the bs23 pair under error control), and every
compiled function they call. It may import the laws of :mod:`ltdsim.physics`, the
engine's table layouts (:mod:`ltdsim.engine.layout`, :mod:`ltdsim.engine.couplers`)
and the integrators' tableaux, nothing above the engine. Everything here runs under
numba and also as plain Python (``NUMBA_DISABLE_JIT=1``).

Modules, each importing only those before it:

- :mod:`~ltdsim.engine.kernel.structs`: the named structures the kernels take
  (``NamedTuple`` classes of arrays: :class:`Train`, :class:`CouplerArrays`,
  :class:`DriverArrays`, :class:`Controller`, :class:`FixedStep`, :class:`Adaptive`,
  :class:`Work`, :class:`Outputs`), the numpy records of the states carried between
  calls (``CONTROLLER``, ``STEPPER``, ``SIGNALS``) and their builders;
- :mod:`~ltdsim.engine.kernel.tables`: look-ups in tables (linear interpolation, step
  functions) with search cursors;
- :mod:`~ltdsim.engine.kernel.rk`: the Runge-Kutta stage routine, the step's end and
  the finite check;
- :mod:`~ltdsim.engine.kernel.brakes`: the lumped and the fluid-dynamic air brake,
  the fluid brake's own pneumatic steps;
- :mod:`~ltdsim.engine.kernel.traction`: the driver's demand, the traction curves and
  the induction drives;
- :mod:`~ltdsim.engine.kernel.energy`: the power of every force and the energy
  accounting;
- :mod:`~ltdsim.engine.kernel.rhs`: the right-hand side, one subsystem after another
  (resistance, brakes, traction, induction drives, couplers, force balance);
- :mod:`~ltdsim.engine.kernel.driver`: the speed controller's samples and the brake
  commands;
- :mod:`~ltdsim.engine.kernel.slack`: the adaptive kernel's error of a hysteretic
  gear and the exact relaxation of a gear in its slack;
- :mod:`~ltdsim.engine.kernel.recording`: the records and the peak forces;
- :mod:`~ltdsim.engine.kernel.stepping`: the two kernels.

The state vector is ``y = [x_0..x_(n-1), v_0..v_(n-1), z...]``: displacement of each
vehicle from its initial position (m), its speed (m/s), then the internal states of the
hysteretic draft gears (internal force N; wedge gears also the plate displacement m,
and with an S table the impact speed m/s; :mod:`ltdsim.physics.gears.draftgear`), the
traction lags, the brake-cylinder fills or the fluid brake's pneumatic states, the
induction drives' states and, under bs23 with ``solver.energy``, the energy states.
The discrete PID is sampled between steps and its output held over the step
(zero-order hold), as a digital controller is; every continuous quantity is a pure
function of ``(t, y)``, so any Runge-Kutta method can evaluate it any number of times
per step.

Compiling. Small helpers are inlined by numba into their callers
(``inline="always"``); the large ones (the right-hand side and its subsystems, the
records, the controller, the brake commands, the stage routine) are compiled once each
and inlined by LLVM (``forceinline=True``), which keeps the first compile short; the
induction drive's axle (:func:`~ltdsim.engine.kernel.traction._drive_axle`) is called,
not inlined. The subsystems a scenario may leave out (the fluid brake, the induction
drives, the energy accounting, the hysteretic gears and the cushioning units) are called
through :func:`ltdsim.engine.features.when`, whose flags are types in the
:class:`Train` and :class:`CouplerArrays`: a kernel is compiled for the subsystems its
scenario has, and each set of them is its own entry in the cache (the study's case
compiles in about half the time of a kernel with every subsystem). No argument of these
functions may be a constant at a call site: numba
compiles a function once per set of argument types, and a constant such as ``0`` is a
type of its own. The measurements behind these choices and behind the kernels' loop
forms are in docs/performance.md.
"""

from __future__ import annotations

from ltdsim.engine.kernel.rk import _advance, _stages
from ltdsim.engine.kernel.slack import _relax_in_slack
from ltdsim.engine.kernel.stepping import run, run_adaptive
from ltdsim.engine.kernel.structs import (
    ABSURD, EVENTS_FULL, N_PEAKS, N_SCALARS, NONFINITE, OK, PK_MAX, PK_MIN, PK_TMAX,
    PK_TMIN, SG_ADEM, SG_ADHESION, SG_BRAKE, SG_DEMAND, SG_TRACTION, SG_VREF, Adaptive,
    AirBrake, Controller, CouplerArrays, Drive, DriverArrays, FixedStep, Outputs, Train,
    Work, make_controller, make_couplers, make_driver, make_stepper, make_train,
    make_work, uniform_model, work_size,
)
from ltdsim.engine.kernel.tables import _interp, _segment

__all__ = [
    "ABSURD", "EVENTS_FULL", "N_PEAKS", "N_SCALARS", "NONFINITE", "OK", "PK_MAX",
    "PK_MIN", "PK_TMAX", "PK_TMIN", "SG_ADEM", "SG_ADHESION", "SG_BRAKE", "SG_DEMAND",
    "SG_TRACTION", "SG_VREF", "Adaptive", "AirBrake", "Controller", "CouplerArrays", "Drive",
    "DriverArrays", "FixedStep", "Outputs", "Train", "Work", "make_controller",
    "make_couplers", "make_driver", "make_stepper", "make_train", "make_work", "run",
    "run_adaptive", "uniform_model", "work_size", "_advance", "_interp", "_relax_in_slack",
    "_segment", "_stages",
]
