"""Which subsystems a kernel is compiled with: flags that are types, not values.

numba compiles a kernel once per set of argument types, so a flag carried in a type
picks the code at compile time. :class:`On` and :class:`Off` are two empty named
tuples, distinct types with no data; :class:`Features` (in the
:class:`~ltdsim.engine.kernel.structs.Train`) and :class:`CouplerKinds` (in the
:class:`~ltdsim.engine.kernel.structs.CouplerArrays`) hold one per subsystem that a
scenario may leave out. A subsystem is called through :func:`when`::

    when(tr.features.fluid, _fluid_brakes, None, t, y, ...)

which compiles to the call ``_fluid_brakes(t, y, ...)`` when the flag is :class:`On`
and to the constant ``None`` (its third argument) when it is :class:`Off`, without
typing or compiling ``_fluid_brakes`` at all. The kernels are compiled for the sets
of flags in :data:`KERNEL_SETS` (the study's subsystems, or all of them); a scenario
with the lumped brake, the traction curve and simplified couplers thus compiles neither
the fluid brake, nor the induction drive, nor the hysteretic gears. Each set is its own
entry in numba's on-disk cache, compiled the first time a scenario needs it.

A flag only removes code that the scenario's data would never run: every call behind
:func:`when` also sits behind the run-time test it had before (an empty array, a model
code), so a kernel with every flag :class:`On` gives the same numbers as one with only
the flags the scenario needs, bit for bit (tests/engine/test_features.py;
``benchmarks/check_bit_identical.py`` against the code before the flags, which compiled
everything, in docs/performance.md, "The first run").
"""

from __future__ import annotations

from typing import NamedTuple

from numba import types
from numba.extending import overload


class On(NamedTuple):
    """The subsystem is compiled into the kernel."""


class Off(NamedTuple):
    """The subsystem is left out of the kernel: its calls compile to a constant."""


ON = On()
OFF = Off()


def flag(present: bool) -> On | Off:
    """:data:`ON` when ``present``, else :data:`OFF`."""
    return ON if present else OFF


class Features(NamedTuple):
    """The train's optional subsystems (each :data:`ON` or :data:`OFF`)."""

    fluid: On | Off  # the fluid-dynamic air brake (brake.model = "fluid")
    drive: On | Off  # an induction drive on some consist (traction.drive = "induction")
    energy: On | Off  # the energy accounting (solver.energy)


class CouplerKinds(NamedTuple):
    """The coupler models whose code is large enough to leave out when no coupler of
    the train has them (each :data:`ON` or :data:`OFF`); the linear and simplified
    couplers are always compiled."""

    hysteretic: On | Off  # friction-wedge, table and polymer gears (couplers._gear)
    cushion: On | Off  # hydraulic cushioning units (couplers._cushion)
    dispatch: On | Off  # some coupler is not the simplified one: the loop that picks each
    # coupler's law by its model code (kernel.rhs._dispatched_couplers)


#: every subsystem compiled (the gear rig, and the check that the flags change nothing)
ALL_FEATURES = Features(fluid=ON, drive=ON, energy=ON)
ALL_KINDS = CouplerKinds(hysteretic=ON, cushion=ON, dispatch=ON)

#: the sets of subsystems the kernels are compiled for, smallest first; a scenario runs
#: on the first set that holds every subsystem it has (:func:`compiled_set`). Each set
#: is a compile of its own, 17 s of CPU for the first (the study's case: lumped brake,
#: traction curves, simplified couplers), 45-52 s for the last; a test suite, a sweep or
#: a study that meets many scenarios compiles each set it meets once, so two sets keep
#: that to two kernels per method (fixed step, bs23), where one per combination of
#: subsystems would be up to 16 (docs/performance.md, "The first run").
KERNEL_SETS: tuple[tuple[Features, CouplerKinds], ...] = (
    (Features(fluid=OFF, drive=OFF, energy=OFF),
     CouplerKinds(hysteretic=OFF, cushion=OFF, dispatch=OFF)),
    (ALL_FEATURES, ALL_KINDS),
)


def compiled_set(features: Features, kinds: CouplerKinds) -> tuple[Features, CouplerKinds]:
    """The smallest of :data:`KERNEL_SETS` that compiles every subsystem :data:`ON` in
    ``features`` and ``kinds`` (what a scenario has)."""
    need = (*features, *kinds)
    for have_f, have_k in KERNEL_SETS:
        have = (*have_f, *have_k)
        if all(isinstance(h, On) or not isinstance(n, On) for n, h in zip(need, have)):
            return have_f, have_k
    raise AssertionError("KERNEL_SETS must end with the set of every subsystem")


def when(on, fn, off, *args):
    """``fn(*args)`` when ``on`` is :data:`ON`, the constant ``off`` when it is
    :data:`OFF`; in a compiled kernel ``fn`` is then not compiled at all (and as plain
    Python, ``NUMBA_DISABLE_JIT=1``, not called)."""
    return fn(*args) if isinstance(on, On) else off


def _is_off(ty) -> bool:
    return isinstance(ty, types.BaseNamedTuple) and ty.instance_class is Off


def _is_on(ty) -> bool:
    return isinstance(ty, types.BaseNamedTuple) and ty.instance_class is On


# (forceinline: LLVM inlines the call into its caller, as the kernels' large functions
# are; a call left standing would pass ``fn`` as an address, which numba cannot cache)
@overload(when, jit_options={"forceinline": True})
def _when(on, fn, off, *args):
    if _is_off(on):
        def left_out(on, fn, off, *args):
            return off
        return left_out
    if _is_on(on):
        def compiled_in(on, fn, off, *args):
            return fn(*args)
        return compiled_in
    return None  # (not a flag: numba reports the call as untyped)
