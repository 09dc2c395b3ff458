"""``[brake]``: the lumped or the fluid-dynamic air brake, its valves (presets or inline
tables, checked by the valves' row builders), the pipe's air, and the driver's brake
commands.
"""

from __future__ import annotations

from typing import Any, Literal, Union

from pydantic import (
    Field,
    model_validator,
)

from ltdsim.data import load_preset, preset_names

from ltdsim.scenario._base import _Strict
from ltdsim.scenario.messages import _TYPE_MESSAGES, _toml


#: the valves' keys that take text (every other key is a number)
_VALVE_TEXT_KEYS = ("family",)


def valve_tables(fluid: "FluidBrake") -> tuple[dict, dict]:
    """The ``[control_valve]`` and ``[driver_valve]`` tables of ``brake.fluid.valve``: a
    preset's, or an inline table's keys over its ``preset`` (if any); each checked by
    the valves' row builders. Raises ``ValueError`` in one line naming the key."""
    from ltdsim.physics.air.brakevalves import (CV_PARAMS, DV_PARAMS, _CV_ORIFICES,
                                                _DV_ORIFICES, control_valve_row,
                                                driver_valve_row)

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
    known = {"control_valve": {*CV_PARAMS, *_CV_ORIFICES, "discharge_coefficient"},
             "driver_valve": {*DV_PARAMS, *_DV_ORIFICES, "discharge_coefficient"}}
    for key in ("control_valve", "driver_valve"):
        own = valve.get(key, {})
        if not isinstance(own, dict):
            raise ValueError(f"brake.fluid.valve.{key}: must be a table")
        for name, value in own.items():  # the row builders read a string as 'not given'
            if name not in known[key]:
                continue  # (refused by the row builder, with the keys allowed)
            want = _TYPE_MESSAGES["string_type" if name in _VALVE_TEXT_KEYS else "float_type"]
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if (name in _VALVE_TEXT_KEYS) != isinstance(value, str) or (
                    name not in _VALVE_TEXT_KEYS and not number):
                raise ValueError(f"brake.fluid.valve.{key}.{name}: {want} (got "
                                 f"{_toml(value)})")
        merged = {**base.get(key, {}), **own}
        tables.append(merged)
    cv, dv = tables
    if fluid.regulated_pressure is not None:
        dv = {**dv, "regulated": fluid.regulated_pressure}
    try:
        control_valve_row(cv)
    except ValueError as exc:
        raise ValueError(f"brake.fluid.valve: {exc}") from None
    try:
        driver_valve_row(dv)
    except ValueError as exc:
        raise ValueError(f"brake.fluid.valve: {exc}") from None
    return cv, dv


class BrakeCommand(_Strict):
    """One brake command of the driver: when (time or lead position) and what (handle
    position or pipe reduction)."""

    time: float | None = Field(None, ge=0.0, le=1e7,
                               description="issued at this time, s (give time or position)")
    position: float | None = Field(None, ge=-1e8, le=1e8,
                                   description="issued when the lead vehicle's centre "
                                               "passes this track position, m")
    handle: Literal["release", "minimum", "full", "emergency"] | None = Field(
        None, description="driver's-valve handle: release, minimum (first service "
                          "reduction), full (full service), emergency (give handle or "
                          "reduction); lumped brake: levels 0, brake.minimum_level, 1, 1")
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
        None, ge=1e5, le=1.2e6,
        description="pipe pressure the driver's valves charge to (none: the preset's "
                    "driver_valve.regulated), Pa (gauge)")


class Air(_Strict):
    """Gas data of the fluid air brake: isothermal air."""

    gamma: float = Field(1.4, gt=1.0, le=1.67,
                         description="ratio of specific heats (the orifice law only), -")
    gas_constant: float = Field(287.05, gt=200.0, le=400.0,
                                description="specific gas constant of air, J/(kg K) (dry air)")
    temperature: float = Field(293.15, ge=223.15, le=333.15,
                               description="temperature of the air everywhere (isothermal), "
                                           "K")
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
    fluid: FluidBrake | None = Field(None, description="fluid brake: pipe and valves")
    air: Air = Field(Air(), description="fluid brake: gas data")

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
