"""Every variable a run's result holds, declared once: name, dimensions, unit,
description and the kernel's record array that fills it.

Everything else derives from these declarations: the names ``solver.record`` accepts
(:data:`RECORDABLE`), the kernel's record arrays and their variables
(:data:`RECORD_ARRAYS`), the order of the induction drives' recorded signals
(:data:`DRIVE_SIGNALS`) and of the energy terms (:data:`ENERGY_TERMS`), which the
engine's layouts turn into column constants, and each variable's ``units`` and
``long_name`` in the result (:mod:`ltdsim.results.simulate`). Plain data: this module
imports nothing of ltdsim, and every layer may read it.
"""

from __future__ import annotations

from typing import NamedTuple


class Variable(NamedTuple):
    """One result variable."""

    name: str
    dims: tuple[str, ...]  #: its dimensions in the result ("time", "vehicle", ...)
    units: str  #: the ``units`` attribute ("m", "N", "Pa (gauge)", "1" for a ratio)
    description: str  #: the ``long_name`` attribute
    #: the kernel's record array it comes from (``ltdsim.engine.kernel.Outputs`` field),
    #: "" for what is always kept (the train's signals, the peaks over every step)
    record: str = ""


TV = ("time", "vehicle")
TC = ("time", "coupler")
TL = ("time", "locomotive")
T = ("time",)

#: the induction drives' signals (kernel ``Work.dsig`` and the record ``Outputs.m``), in
#: their columns' order: one motor's torque, speed and current, the wheelsets' creep, the
#: locomotive's creep force and DC power, one motor's flux linkages
_DRIVE = (
    ("motor_torque", "N m", "induction drive: electromagnetic torque of one traction motor "
                            "at its shaft (NaN: a consist on the traction curve)"),
    ("motor_speed", "rad/s", "induction drive: shaft speed of one traction motor (x 30/pi "
                             "for rpm)"),
    ("stator_current", "A (rms)", "induction drive: stator winding current of one "
                                  "traction motor, rms"),
    ("creep", "1", "induction drive: creep of the driven wheelsets, slip velocity over "
                   "max(speed, v_reg)"),
    ("creep_force", "N", "induction drive: longitudinal creep force of all the "
                         "locomotive's driven wheelsets, + forward"),
    ("dc_power", "W", "induction drive: DC-link power of all the locomotive's inverters, + "
                      "drawn (motoring), - returned (braking)"),
    ("stator_flux_d", "Wb", "induction drive: stator flux linkage of one traction motor, "
                            "d axis of the controller's synchronous frame, peak"),
    ("stator_flux_q", "Wb", "induction drive: stator flux linkage of one traction motor, "
                            "q axis of the controller's synchronous frame, peak"),
    ("rotor_flux_d", "Wb", "induction drive: rotor flux linkage of one traction motor "
                           "(referred to the stator), d axis of the controller's "
                           "synchronous frame, peak"),
    ("rotor_flux_q", "Wb", "induction drive: rotor flux linkage of one traction motor "
                           "(referred to the stator), q axis of the controller's "
                           "synchronous frame, peak"),
)
#: the energy terms (``solver.energy = true``), in the order of the kernel's energy
#: totals: each the work since the start, J
_ENERGY = (
    ("traction_energy", "work of the traction force at the rail while motoring (its power "
                        "on each vehicle > 0), since the start"),
    ("dynamic_brake_energy", "work the dynamic brake took from the train at the rail, "
                             "since the start (>= 0; the most it can regenerate)"),
    ("air_brake_energy", "work of the air brakes (shoe friction), since the start"),
    ("davis_energy", "work against the Davis running resistance, since the start"),
    ("grade_energy", "work against gravity on grades since the start: the potential energy "
                     "gained (< 0 downhill)"),
    ("curve_energy", "work against curve resistance, since the start"),
)

VARIABLES: tuple[Variable, ...] = (
    Variable("position", TV, "m", "track position of the vehicle centre (lead vehicle "
                                  "starts at 0)", "x"),
    Variable("relative_position", TV, "m", "position relative to the lead vehicle's, minus "
                                           "the initial offset (x_i - x_0)", "x"),
    Variable("velocity", TV, "m/s", "vehicle speed, + forwards", "v"),
    Variable("relative_velocity", TV, "m/s", "velocity relative to the lead vehicle "
                                             "(v_i - v_0)", "v"),
    Variable("acceleration", TV, "m/s^2", "vehicle acceleration", "a"),
    Variable("coupler_deflection", TC, "m", "coupler deflection from neutral, + draft "
                                            "(stretched)", "d"),
    Variable("coupler_force", TC, "N", "coupler force, + tension (draft), - compression "
                                       "(buff)", "f"),
    Variable("traction_force", T, "N", "total traction (+) or dynamic-brake (-) force of "
                                       "the powered vehicles"),
    Variable("speed_reference", T, "m/s", "reference speed of the speed controller"),
    Variable("speed_error", T, "m/s", "reference minus measured speed of the lead powered "
                                      "vehicle", "v"),
    Variable("adhesion_limit", T, "N", "Curtius-Kniffler adhesion limit at the lead "
                                       "powered vehicle's speed"),
    Variable("demanded_acceleration", T, "m/s^2", "speed controller output after the "
                                                  "acceleration limits"),
    Variable("traction_demand", T, "N", "force demanded of the powered vehicles before the "
                                        "traction curve (adhesion, force, power) limits it"),
    Variable("max_coupler_force", ("coupler",), "N", "largest coupler force over every step "
                                                     "of the run (+ tension)"),
    Variable("min_coupler_force", ("coupler",), "N", "smallest coupler force over every "
                                                     "step of the run (- compression)"),
    Variable("time_max_coupler_force", ("coupler",), "s", "time of max_coupler_force"),
    Variable("time_min_coupler_force", ("coupler",), "s", "time of min_coupler_force"),
    Variable("brake_command", T, "1", "brake level last commanded at the brake-control "
                                      "points (0-1)"),
    Variable("brake_force", TV, "N", "air-brake retarding force, + opposing forward motion",
             "b"),
    Variable("brake_cylinder", TV, "1", "brake-cylinder fill: 0 released, 1 full "
                                        "application (fluid brake: cylinder pressure over a "
                                        "full service's)", "p"),
    Variable("locomotive_force", TL, "N", "traction (+) or dynamic-brake (-) force of each "
                                          "locomotive consist", "c"),
    Variable("brake_pipe_pressure", TV, "Pa (gauge)", "brake-pipe pressure at the vehicle "
                                                      "(the cell its valve connects to), "
                                                      "gauge", "bp"),
    Variable("auxiliary_reservoir_pressure", TV, "Pa (gauge)", "auxiliary-reservoir "
             "pressure of the vehicle's control valve, gauge (NaN: unbraked vehicle)", "ar"),
    Variable("brake_cylinder_pressure", TV, "Pa (gauge)", "brake-cylinder pressure, gauge "
                                                          "(NaN: unbraked vehicle)", "bc"),
    Variable("air_exhausted", T, "kg", "air the brake has let out to atmosphere since the "
                                       "start (vents, exhausts, leaks; less what "
                                       "compressors took in)", "ax"),
    *(Variable(name, TL, units, text, "m") for name, units, text in _DRIVE),
    *(Variable(name, T, "J", text, "e") for name, text in _ENERGY),
    Variable("coupler_energy", TC, "J", "net work the coupler took since the start: what "
                                        "its gears dissipated plus what they store at that "
                                        "moment", "e"),
    Variable("kinetic_energy", T, "J", "kinetic energy of the train, sum of m v^2 / 2 with "
                                       "the dynamic masses (rotating parts included)", "e"),
    Variable("energy_balance_error", T, "J", "traction_energy - dynamic_brake_energy - "
                                             "air_brake_energy - davis_energy - "
                                             "grade_energy - curve_energy - the couplers' "
                                             "energy - the change of kinetic_energy: what "
                                             "the integration leaves unaccounted", "e"),
)
#: the declarations by name
BY_NAME = {v.name: v for v in VARIABLES}
#: the induction drives' signals, in their record columns' order
DRIVE_SIGNALS = tuple(name for name, _, _ in _DRIVE)
#: the energy terms, in the order of the kernel's energy totals
ENERGY_TERMS = tuple(name for name, _ in _ENERGY)
#: every variable of the energy balance (``solver.energy = true``)
ENERGY_VARIABLES = tuple(v.name for v in VARIABLES if v.record == "e")
#: the variables ``solver.record`` can name (those a recording can leave out)
RECORDABLE = tuple(v.name for v in VARIABLES if v.record)
#: the kernel's record arrays and the variables each gives: an array is recorded when
#: one of its variables is named (``relative_position`` comes with ``position``, the
#: drive's signals together, the energy balance whole)
RECORD_ARRAYS = {key: tuple(v.name for v in VARIABLES if v.record == key)
                 for key in dict.fromkeys(v.record for v in VARIABLES if v.record)}
#: units of every variable and of the time coordinate
UNITS = {"time": "s", **{v.name: v.units for v in VARIABLES}}
