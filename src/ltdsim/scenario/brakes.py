"""``[brake]``: the lumped or the fluid-dynamic air brake, its valves (presets or inline
tables, checked by the valves' row builders), the pipe's air, and the driver's brake
commands.
"""

from __future__ import annotations

from typing import Any, Literal, Union

from pydantic import (
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from ltdsim.data import load_preset, preset_names

from ltdsim.scenario._base import MAX_CHAINAGE, _Strict, quantity
from ltdsim.scenario.messages import first_problem

# --- the valve tables' keys and their physical ranges ----------------------------------
# Generous bounds around what air brakes are built with, so that a typing slip (a
# boolean, a string, a value in bar or psi where Pa is meant, a pressure no pipe holds)
# is refused and every real valve passes. Pressures are Pa (gauge), volumes m^3,
# orifices effective diameters m, times s. The readings behind them:
# * brake pipes run at 5 bar (UIC 540/543), 90 psi = 6.2 bar (AAR freight) and up to
#   110 psi = 7.6 bar (heavy haul); 3-10 bar gauge covers them all;
# * main reservoirs are charged to 8-10 bar (UIC locomotives) or 130-150 psi = 9-10.3
#   bar (AAR); 12 bar gauge is above any working pressure;
# * brake cylinders reach 3.8 bar (UIC full service) to 64-77 psi = 4.4-5.3 bar (AAR
#   full service and emergency); no cylinder exceeds the pipe's 10 bar;
# * reservoirs and cylinders: the shipped presets' 2500 in^3 = 41 l to 100 l auxiliary
#   reservoirs, 17-20 l cylinders, 0.8-1 m^3 main reservoirs (the presets' sources);
# * orifices: chokes of tenths of a millimetre up to the 1 in. (25 mm) class vent valve;
#   50 mm is above the 1 1/4 in. (32 mm) pipe's bore;
# * thresholds and bands: 0.1 bar (1.5 psi) thresholds and 0.03-0.3 bar bands in the
#   presets; a proportional valve's band of 1 mbar or a piston slower than 10 s is not a
#   valve.
_PIPE = "the brake pipe: 5 bar UIC, 6.2 bar (90 psi) AAR, 7.6 bar (110 psi) heavy haul"
_MAIN = "main reservoirs: 8-10 bar UIC, 130-150 psi = 9-10.3 bar AAR"
_BAND = "a proportional valve's band"
_TIME = "a valve's travel or relaxation time"

_Cd = quantity(0.5, 1.0, "-", why="sharp-edged orifices 0.6, short chokes 0.8, rounded "
               "nozzles near 1")
_Diameter = quantity(1e-4, 0.05, "m", zero=True,
                     why="an effective diameter, from a 0.1 mm choke to a 50 mm vent")
_Band = quantity(100.0, 1e5, "Pa", why=_BAND)
_Time = quantity(1e-3, 10.0, "s", why=_TIME)
_Threshold = quantity(0.0, 1e5, "Pa", why="0.1 bar (1.5 psi) typical, 2 psi AAR release")
_Auxiliary = quantity(1e-3, 0.5, "m^3", why="1-500 l")
_Cylinder = quantity(5e-4, 0.2, "m^3", why="0.5-200 l with its piping")
_Control = quantity(5e-4, 0.1, "m^3", zero=True, why="UIC control reservoir, 0.5-100 l")
_Emergency = quantity(1e-3, 0.5, "m^3", zero=True, why="AAR emergency reservoir, 1-500 l")
_Bulb = quantity(1e-5, 0.01, "m^3", zero=True, why="quick-service bulb, 0.01-10 l")
_Chamber = quantity(1e-4, 0.02, "m^3", zero=True, why="quick-action chamber, 0.1-20 l")
_Branch = quantity(1e-4, 0.01, "m^3", zero=True,
                   why="branch pipe, dirt collector and pipe bracket, 0.1-10 l")
_MaxCylinder = quantity(0.5e5, 10e5, "Pa gauge", zero=True,
                        why="UIC full-service cylinder, 3.8 bar typical")
_FullDrop = quantity(1e3, 5e5, "Pa", zero=True,
                     why="UIC pipe drop of full service, 1.5 bar typical")
_QuickLimit = quantity(1e3, 3e5, "Pa gauge", why="0.4 bar UIC, 10 psi AAR")
_Trip = quantity(1e3, 5e5, "Pa", zero=True, why="0.45-0.6 bar in the presets")
_Cutoff = quantity(1e3, 3e5, "Pa gauge", zero=True, why="UIC, 0.2 bar typical")
_Inshot = quantity(1e3, 5e5, "Pa gauge", zero=True,
                   why="the first stage of a staged emergency, about 1 bar (15 psi)")
_MainVolume = quantity(0.05, 5.0, "m^3", why="locomotive main reservoirs, 50-5000 l")
_Equalising = quantity(5e-4, 0.1, "m^3", why="0.5-100 l")
_Regulated = quantity(3e5, 10e5, "Pa gauge", why=_PIPE)
_FullReduction = quantity(1e4, 4e5, "Pa", why="1.5 bar UIC, 26 psi = 1.8 bar AAR")
_MinReduction = quantity(0.0, 2e5, "Pa", why="0.5 bar UIC, 6-8 psi AAR")
_Compressor = quantity(0.0, 1.0, "kg/s", why="0.05 kg/s is about 2.5 m^3/min of free air")
_Governor = quantity(0.0, 12e5, "Pa gauge", why=_MAIN)
_GovernorBand = quantity(100.0, 1e5, "Pa", zero=True, why=_BAND)
_GovernorTime = quantity(1e-3, 60.0, "s", zero=True, why=_TIME)
_MainInitial = quantity(3e5, 12e5, "Pa gauge", why=_MAIN)
_Overcharge = quantity(0.0, 1e5, "Pa", zero=True,
                       why="a UIC fast fill's overcharge, a few tenths of a bar")
_OverchargeTime = quantity(0.1, 600.0, "s", zero=True,
                           why="an overcharge builds in seconds and decays over minutes")


class ControlValveTable(_Strict):
    """``brake.fluid.valve.control_valve``: the control valve (distributor) of every
    braked vehicle, as a preset writes it, each key's type and range. Keys left out
    take the preset's (none: 0, which the valve's row builder refuses where a key is
    needed)."""

    family: Literal["uic", "aar"] | None = None
    discharge_coefficient: _Cd | None = None
    auxiliary_volume: _Auxiliary | None = None
    cylinder_volume: _Cylinder | None = None
    control_volume: _Control | None = None
    emergency_volume: _Emergency | None = None
    quick_service_volume: _Bulb | None = None
    quick_action_volume: _Chamber | None = None
    charge_diameter: _Diameter | None = None
    control_diameter: _Diameter | None = None
    emergency_charge_diameter: _Diameter | None = None
    apply_diameter: _Diameter | None = None
    release_diameter: _Diameter | None = None
    quick_service_diameter: _Diameter | None = None
    quick_service_vent_diameter: _Diameter | None = None
    quick_service_cylinder_diameter: _Diameter | None = None
    quick_action_diameter: _Diameter | None = None
    quick_action_vent_diameter: _Diameter | None = None
    vent_diameter: _Diameter | None = None
    emergency_apply_diameter: _Diameter | None = None
    max_cylinder: _MaxCylinder | None = None
    full_drop: _FullDrop | None = None
    threshold: _Threshold | None = None
    release_threshold: _Threshold | None = None
    band: _Band | None = None
    piston_time: _Time | None = None
    quick_service_limit: _QuickLimit | None = None
    trip: _Trip | None = None
    trip_band: _Band | None = None
    emergency_time: _Time | None = None
    control_cutoff: _Cutoff | None = None
    emergency_inshot: _Inshot | None = None
    emergency_build_diameter: _Diameter | None = None
    accelerated_release_diameter: _Diameter | None = None
    branch_volume: _Branch | None = None


class DriverValveTable(_Strict):
    """``brake.fluid.valve.driver_valve``: the driver's brake valve of every
    brake-control point, as a preset writes it, each key's type and range (keys left
    out: the preset's)."""

    discharge_coefficient: _Cd | None = None
    main_volume: _MainVolume | None = None
    equalising_volume: _Equalising | None = None
    regulated: _Regulated | None = None
    full_reduction: _FullReduction | None = None
    minimum_reduction: _MinReduction | None = None
    charge_diameter: _Diameter | None = None
    service_diameter: _Diameter | None = None
    emergency_diameter: _Diameter | None = None
    feed_diameter: _Diameter | None = None
    exhaust_diameter: _Diameter | None = None
    vent_diameter: _Diameter | None = None
    regulating_band: _Band | None = None
    relay_band: _Band | None = None
    vent_time: _Time | None = None
    compressor_flow: _Compressor | None = None
    cut_in: _Governor | None = None
    cut_out: _Governor | None = None
    governor_band: _GovernorBand | None = None
    governor_time: _GovernorTime | None = None
    main_initial: _MainInitial | None = None
    fast_fill_diameter: _Diameter | None = None
    overcharge: _Overcharge | None = None
    overcharge_charge_time: _OverchargeTime | None = None
    overcharge_time: _OverchargeTime | None = None


def equalisation_pressure(regulated: float, auxiliary_volume: float,
                          cylinder_volume: float) -> float:
    """Pressure (Pa, gauge) at which an auxiliary reservoir charged to the pipe's
    ``regulated`` pressure (Pa, gauge) equalises with an empty brake cylinder: Boyle's
    law at constant temperature, ``regulated V_aux / (V_aux + V_cyl)`` (volumes m^3; the
    atmosphere's share cancels in gauge pressures). No cylinder of that valve can be
    filled above it from the auxiliary reservoir alone."""
    return regulated * auxiliary_volume / (auxiliary_volume + cylinder_volume)


def _bar(p: float) -> str:
    return f"{p / 1e5:.3g} bar"


def _relations(cv: dict, dv: dict) -> None:
    """What a brake designer checks between the valves' keys (both tables already
    within their ranges and accepted by the row builders); one ``ValueError`` line
    naming the keys and the relation."""
    def g(table: dict, key: str) -> float:
        return float(table.get(key, 0.0))

    where = "brake.fluid.valve"
    reg = g(dv, "regulated")
    va, vc = g(cv, "auxiliary_volume"), g(cv, "cylinder_volume")
    p_eq = equalisation_pressure(reg, va, vc)
    eq = (f"p_eq = driver_valve.regulated x auxiliary_volume / (auxiliary_volume + "
          f"cylinder_volume) = {_bar(reg)} x {va:g} / ({va:g} + {vc:g}) m^3 = {_bar(p_eq)}")
    if cv.get("family") == "uic":
        full = g(cv, "max_cylinder")
        if full > p_eq:
            raise ValueError(f"{where}: control_valve.max_cylinder ({_bar(full)}) must not "
                             f"exceed the pressure at which the auxiliary reservoir "
                             f"equalises with the cylinder, {eq} (gauge): the reservoir "
                             "cannot fill the cylinder higher")
        if g(cv, "control_cutoff") >= full:
            raise ValueError(f"{where}: control_valve.control_cutoff "
                             f"({_bar(g(cv, 'control_cutoff'))}) must be below "
                             f"control_valve.max_cylinder ({_bar(full)}): the control "
                             "reservoir must be isolated once the brake applies")
        if g(cv, "full_drop") > g(dv, "full_reduction"):
            raise ValueError(f"{where}: control_valve.full_drop ({_bar(g(cv, 'full_drop'))})"
                             " must not exceed driver_valve.full_reduction "
                             f"({_bar(g(dv, 'full_reduction'))}): a full service would "
                             "not reach control_valve.max_cylinder")
    else:
        full = min(g(dv, "full_reduction") * va / vc, p_eq)
    if g(cv, "quick_service_limit") >= full:
        raise ValueError(f"{where}: control_valve.quick_service_limit "
                         f"({_bar(g(cv, 'quick_service_limit'))}) must be below the "
                         f"full-service cylinder pressure ({_bar(full)}): quick service "
                         "would draw the pipe through the whole application")
    mini = g(dv, "minimum_reduction")
    if 0.0 < mini <= g(cv, "threshold"):
        raise ValueError(f"{where}: driver_valve.minimum_reduction ({_bar(mini)}) must "
                         f"exceed control_valve.threshold ({_bar(g(cv, 'threshold'))}): "
                         "a minimum service would apply no brake")
    if g(cv, "quick_action_volume") > 0.0 and g(cv, "trip") + g(cv, "trip_band") >= reg:
        raise ValueError(f"{where}: control_valve.trip + trip_band "
                         f"({_bar(g(cv, 'trip') + g(cv, 'trip_band'))}) must be below "
                         f"driver_valve.regulated ({_bar(reg)}): the quick-action chamber "
                         "stands at most the pipe's pressure above a vented pipe, so no "
                         "emergency would trip")
    if g(dv, "compressor_flow") > 0.0 and g(dv, "cut_in") <= reg:
        raise ValueError(f"{where}: driver_valve.cut_in ({_bar(g(dv, 'cut_in'))}) must "
                         f"exceed driver_valve.regulated ({_bar(reg)}): the compressor "
                         "must keep the main reservoir above the pipe it feeds")


def valve_tables(fluid: "FluidBrake") -> tuple[dict, dict]:
    """The ``[control_valve]`` and ``[driver_valve]`` tables of ``brake.fluid.valve``: a
    preset's, or an inline table's keys over its ``preset`` (if any); each key checked
    for its type and physical range (:class:`ControlValveTable`,
    :class:`DriverValveTable`), the tables by the valves' row builders, and the
    relations between the keys (:func:`_relations`). Raises ``ValueError`` in one line
    naming the key."""
    from ltdsim.physics.air.brakevalves import control_valve_row, driver_valve_row

    valve = fluid.valve
    if isinstance(valve, str):
        valve = {"preset": valve}
    unknown = sorted(set(valve) - {"preset", "control_valve", "driver_valve"})
    if unknown:
        raise ValueError(f"brake.fluid.valve: unknown key {unknown[0]!r}; allowed: preset, "
                         "control_valve, driver_valve")
    base: dict = {"control_valve": {}, "driver_valve": {}}
    name = valve.get("preset")
    if name is not None:
        names = preset_names("brakes")
        if not isinstance(name, str) or name not in names:
            raise ValueError(f"brake.fluid.valve: unknown preset {name!r}; available: "
                             f"{', '.join(names) or 'none (this install lacks its package data)'}")
        base = load_preset("brakes", name)
    tables = []
    for key in ("control_valve", "driver_valve"):
        own = valve.get(key, {})
        if not isinstance(own, dict):
            raise ValueError(f"brake.fluid.valve.{key}: must be a table")
        merged = {**base.get(key, {}), **own}
        tables.append(merged)
    cv, dv = tables
    if fluid.regulated_pressure is not None:
        dv = {**dv, "regulated": fluid.regulated_pressure}
    for key, table, model in (("control_valve", cv, ControlValveTable),
                              ("driver_valve", dv, DriverValveTable)):
        try:
            model.model_validate(table)
        except ValidationError as exc:
            raise ValueError(first_problem(exc, f"brake.fluid.valve.{key}.", model)) from None
    try:
        control_valve_row(cv)
    except ValueError as exc:
        raise ValueError(f"brake.fluid.valve: {exc}") from None
    try:
        driver_valve_row(dv)
    except ValueError as exc:
        raise ValueError(f"brake.fluid.valve: {exc}") from None
    _relations(cv, dv)
    return cv, dv


class BrakeCommand(_Strict):
    """One brake command of the driver: when (time or lead position) and what (handle
    position or pipe reduction)."""

    time: float | None = Field(None, ge=0.0, le=1e7,
                               description="issued at this time, s (give time or position)")
    position: float | None = Field(None, ge=-MAX_CHAINAGE, le=MAX_CHAINAGE,
                                   description="issued when the lead vehicle's centre "
                                               "passes this track position, m")
    handle: Literal["release", "fast-fill", "lap", "minimum", "full", "suppression",
                    "handle-off", "emergency"] | None = Field(
        None, description="driver's-valve handle position (give handle or reduction): "
                          "release (running: the pipe charged to the regulated pressure), "
                          "fast-fill (UIC: the main reservoir straight into the pipe while "
                          "held, then an overcharge that decays without applying; needs a "
                          "valve with fast_fill_diameter), lap (the valve holds the pipe "
                          "where it is), minimum (first service reduction), full (full "
                          "service), suppression (AAR 26L: a full-service reduction), "
                          "handle-off (AAR 26L: the pipe to zero at the service rate), "
                          "emergency; lumped brake: levels 0, 0, the level before, "
                          "brake.minimum_level, 1, 1, 1, 1")
    reduction: float | None = Field(
        None, gt=0.0, le=1e6,
        description="fluid brake: service reduction of the pipe below its regulated "
                    "pressure, Pa (a reduction beyond the full-service one gives full "
                    "service)")

    @model_validator(mode="after")
    def _one_each(self):
        if (self.time is None) == (self.position is None):
            raise ValueError("a brake command needs exactly one of time (s) and position (m)")
        if (self.handle is None) == (self.reduction is None):
            raise ValueError("a brake command needs exactly one of handle ('release', "
                             "'minimum', 'full', 'emergency') and reduction (Pa)")
        return self


class FluidBrake(_Strict):
    """The fluid-dynamic air brake's pipe and valves (``brake.model = "fluid"``)."""

    valve: Union[str, dict[str, Any]] | None = Field(
        None, description="valve preset (data/brakes: 'uic-g', 'uic-p', 'aar') giving every "
                          "braked vehicle's control valve and every brake-control point's "
                          "driver's valve, or an inline table {preset = NAME, control_valve = "
                          "{...}, driver_valve = {...}} whose keys replace the preset's "
                          "(without preset it must give every key); required by the fluid "
                          "brake")
    pipe_diameter: float = Field(0.0318, ge=0.01, le=0.1,
                                 description="inner diameter of the brake pipe (1 1/4 in "
                                             "by default), m")
    cells_per_vehicle: int = Field(2, ge=1, le=20,
                                   description="finite-volume cells of the pipe per vehicle "
                                               "(each vehicle's pipe is its length over "
                                               "couplers)")
    roughness: float = Field(4.6e-5, ge=0.0, le=1e-3,
                             description="wall roughness of the pipe (commercial steel "
                                         "4.6e-5), m")
    leakage: float = Field(0.0, ge=0.0, le=1e-4,
                           description="leak to atmosphere per vehicle as discharge "
                                       "coefficient x area, shared by its cells, m^2 (0: "
                                       "tight; a 1 mm hole at Cd 0.6 is 4.7e-7)")
    regulated_pressure: float | None = Field(
        None, ge=3e5, le=1e6,
        description="pipe pressure the driver's valves charge to (none: the preset's "
                    "driver_valve.regulated), Pa (gauge)")
    hose_volume: float = Field(
        2.0e-4, ge=0.0, le=5e-3,
        description="volume per vehicle that its hoses, couplings, angle cocks and tees add "
                    "to its pipe's bore (capacitance without inertance: it slows the "
                    "pipe's waves); default two 1 3/8 in x 22 in hoses (AAR S-400) of 34.9 "
                    "mm bore around a 31.8 mm pipe, with the couplings' cavities, m^3")


#: the air temperatures the fluid brake takes, K: -40 C to +50 C, the ambient range of
#: rolling stock (EN 50125-1's classes T1-T3 span -40 C to +45 C outside the vehicle, as
#: summarised at railwaynews.net, 2024; beyond them a customer's class Tx; ltdsim's
#: bound)
AIR_TEMPERATURE_RANGE = (233.15, 323.15)


class Air(_Strict):
    """Gas data of the fluid air brake: the ambient temperature (the pipe wall's and the
    valves' air), the pipe air's thermal mode, the gas properties."""

    gamma: float = Field(1.4, gt=1.0, le=1.67,
                         description="ratio of specific heats (the orifice law only), -")
    gas_constant: float = Field(287.05, gt=200.0, le=400.0,
                                description="specific gas constant of air, J/(kg K) (dry air)")
    temperature: float = Field(293.15, ge=AIR_TEMPERATURE_RANGE[0],
                               le=AIR_TEMPERATURE_RANGE[1],
                               description="ambient temperature: the brake pipe's wall and "
                                           "the air at the start, the valves' air throughout "
                                           "(233.15-323.15 K is -40 C to +50 C), K")
    thermal: Literal["wall", "adiabatic", "isothermal"] = Field(
        "wall", description="the brake pipe air's energy: wall (an energy balance per cell "
                            "with heat exchange to the wall: fronts near-adiabatic, slow "
                            "charging near the wall's temperature), adiabatic (no exchange), "
                            "isothermal (the air always at temperature: waves at sqrt(R T), "
                            "the model before the energy balance)")
    conductivity: float | None = Field(
        None, ge=0.0, le=0.1,
        description="thermal conductivity of air for the wall's heat exchange, W/(m K) "
                    "(none: Sutherland's law at temperature, 0.0257 at 20 C; 0: no "
                    "exchange)")
    atmosphere: float = Field(101325.0, ge=5e4, le=1.1e5,
                              description="atmospheric pressure, Pa (absolute)")
    linear_ratio: float = Field(0.995, ge=0.9, lt=1.0,
                                description="orifice law: pressure ratio above which the "
                                            "flow is taken linear in the pressure "
                                            "difference, -")
    viscosity: float | None = Field(
        None, ge=0.0, le=1e-4,
        description="dynamic viscosity of air for the pipe's wall friction (none: "
                    "Sutherland's law at temperature, 1.81e-5 at 20 C; 0: frictionless), "
                    "Pa s")

    @field_validator("temperature", mode="before")
    @classmethod
    def _temperature_range(cls, value):
        # (before the bounds: their message names one end; this one names both, in K
        # and C; a value of the wrong type is left to the type's message)
        lo, hi = AIR_TEMPERATURE_RANGE
        if isinstance(value, (int, float)) and not isinstance(value, bool) and \
                not lo <= value <= hi:
            raise ValueError(f"must be within {lo:g} K to {hi:g} K (-40 C to +50 C; the key "
                             f"is in kelvin: this is {value - 273.15:.4g} C)")
        return value


#: the lumped brake's keys a valve preset's [lumped] table may give (``brake.calibration``)
LUMPED_CALIBRATED = ("propagation_speed", "apply_time_constant", "release_time_constant",
                     "minimum_level", "emergency_level")


class Brake(_Strict):
    """Train air brake: brake-pipe signal and brake-cylinder dynamics (lumped), or the
    brake pipe's gas dynamics, valves, reservoirs and cylinders (fluid)."""

    model: Literal["lumped", "fluid"] = Field(
        "lumped", description="lumped: a command reaches each cylinder after a signal delay "
                              "and fills it with a first-order lag; fluid: the brake pipe's "
                              "unsteady air flow, driver's valves, control valves, reservoirs "
                              "and cylinders ([brake.fluid], [brake.air])")

    mode: Literal["pneumatic", "ecp"] = Field(
        "pneumatic", description="pneumatic: a command reaches a vehicle after its distance "
                                 "from the nearest brake-control point / propagation_speed; "
                                 "ecp (electronically controlled): everywhere at once")
    propagation_speed: float = Field(250.0, ge=10.0, le=400.0,
                                     description="brake-pipe signal speed, m/s")
    apply_time_constant: float = Field(3.0, gt=0.0, le=120.0,
                                       description="brake-cylinder fill time constant while "
                                                   "the command is above the fill, s")
    release_time_constant: float = Field(10.0, gt=0.0, le=300.0,
                                         description="the same while the command is below "
                                                     "the fill, s")
    standstill_speed: float = Field(0.01, gt=0.0, le=1.0,
                                    description="speed below which the brake force fades "
                                                "linearly to 0, so that a stopped vehicle is "
                                                "held, not pushed back, m/s")
    level_step: float = Field(0.1, gt=0.0, le=1.0,
                              description="controller-made applications come in steps of "
                                          "this brake level, -")
    minimum_level: float = Field(0.25, gt=0.0, le=1.0,
                                 description="lumped brake: the brake level of handle = "
                                             "'minimum' in driver.brake_commands (about 6 "
                                             "of 26 psi, AAR; 0.4 of 1.5 bar, UIC), -")
    emergency_level: float = Field(1.0, ge=1.0, le=1.5,
                                   description="lumped brake: the brake level of an "
                                               "emergency, relative to full service (AAR "
                                               "valves about 1.2 from their emergency "
                                               "reservoirs; UIC 1), -")
    calibration: str | None = Field(
        None, description="lumped brake: take propagation_speed, apply_time_constant, "
                          "release_time_constant, minimum_level and emergency_level as "
                          "measured on the fluid brake with this valve preset (its "
                          "[lumped] table in data/brakes); keys given beside it replace "
                          "them")
    fluid: FluidBrake | None = Field(None, description="fluid brake: pipe and valves")
    air: Air = Field(Air(), description="fluid brake: gas data")

    @model_validator(mode="after")
    def _calibrated(self):
        if self.calibration is None:
            return self
        if self.model != "lumped":
            raise ValueError("calibration sets the lumped brake's constants from a valve "
                             "preset; the fluid brake (model = 'fluid') takes the valve "
                             "itself in brake.fluid.valve")
        try:
            table = load_preset("brakes", self.calibration).get("lumped")
        except ValueError as exc:
            raise ValueError(f"calibration: {exc}") from None
        if not isinstance(table, dict):
            raise ValueError(f"calibration: the brake preset {self.calibration!r} has no "
                             "[lumped] table (no lumped constants measured for it)")
        for key, value in table.items():
            if key not in LUMPED_CALIBRATED:
                raise ValueError(f"calibration: {self.calibration!r}: unknown key {key!r} "
                                 f"in its [lumped] table; allowed: "
                                 f"{', '.join(LUMPED_CALIBRATED)}")
            if key not in self.model_fields_set:
                setattr(self, key, float(value))
        return self

    @model_validator(mode="after")
    def _fluid_keys(self):
        if self.model == "fluid":
            if self.mode == "ecp":
                raise ValueError("mode = 'ecp' is a lumped-brake mode: the fluid brake "
                                 "has no electronic control (use model = 'lumped')")
            if self.fluid is None or self.fluid.valve is None:
                raise ValueError("model = 'fluid' needs brake.fluid.valve (a preset: "
                                 f"{', '.join(preset_names('brakes')) or 'none installed'}; or a "
                                 "table)")
            valve_tables(self.fluid)  # names and keys checked here (one line)
        return self
