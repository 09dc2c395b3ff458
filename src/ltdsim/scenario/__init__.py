"""The input: a scenario file (TOML) read, validated into a :class:`Scenario` (strict
pydantic models with a range on every number, one class per table: solver, vehicles,
couplers with one class per coupler model, track, traction with the induction drive's
motor and creep, brakes, driver), its named cases and ``--set`` overrides applied,
presets merged, and the key reference of docs/scenario.md generated from the schema
(doc). A bad input gets one :class:`~ltdsim.errors.ScenarioError` line naming the file,
the key and what is allowed (messages).

Validation checks the input alone: it never lowers or runs anything (the step's
stability is the engine's preflight). May import the base modules and ``physics`` (the
valves' and the creep law's row builders check their tables, the track's alignment
gives the curve resistance's table). Its modules import one another, never this face.
"""

from ltdsim.scenario.load import load_scenario, read_profile, read_toml, scenario_from_data  # noqa: F401
from ltdsim.scenario.model import Initial, Phase, STUDY_PHASES, Scenario  # noqa: F401
from ltdsim.scenario.solver import Solver  # noqa: F401
from ltdsim.scenario.vehicles import Davis, Vehicle, VehicleBrake, VehicleGeometry  # noqa: F401
from ltdsim.scenario.couplers import COUPLER_CLASSES, CouplerOverride, CouplerParams, Couplers, FrictionWedgeGear, LinearCoupler, PolymerGear, STable, SimplifiedCoupler, TableGear, gear_presets  # noqa: F401
from ltdsim.scenario.track import Curving, Track  # noqa: F401
from ltdsim.scenario.traction import Locomotive, Traction, TractionMotor  # noqa: F401
from ltdsim.scenario.brakes import Air, Brake, BrakeCommand, FluidBrake, valve_tables  # noqa: F401
from ltdsim.scenario.driver import Driver, PID  # noqa: F401

__all__ = [
    "Air",
    "Brake",
    "BrakeCommand",
    "COUPLER_CLASSES",
    "CouplerOverride",
    "CouplerParams",
    "Couplers",
    "Curving",
    "Davis",
    "Driver",
    "FluidBrake",
    "FrictionWedgeGear",
    "Initial",
    "LinearCoupler",
    "Locomotive",
    "PID",
    "Phase",
    "PolymerGear",
    "STUDY_PHASES",
    "STable",
    "Scenario",
    "SimplifiedCoupler",
    "Solver",
    "TableGear",
    "Track",
    "Traction",
    "TractionMotor",
    "Vehicle",
    "VehicleBrake",
    "VehicleGeometry",
    "gear_presets",
    "load_scenario",
    "read_profile",
    "read_toml",
    "scenario_from_data",
    "valve_tables",
]
