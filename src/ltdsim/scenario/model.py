"""The :class:`Scenario`: every table together, its initial state and analysis phases, its
named cases and ``--set`` overrides, and the checks that need the whole train (couplers
merged with their overrides, the brake model's needs).
"""

from __future__ import annotations

import copy
from typing import Annotated, Any, Literal

from pydantic import (
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from ltdsim.scenario.creep import wheelset_row
from ltdsim.errors import ScenarioError

from ltdsim.scenario._base import MAX_VEHICLES, _Strict, _set_dotted
from ltdsim.scenario.brakes import Brake, valve_tables
from ltdsim.scenario.couplers import COUPLER_CLASSES, Couplers, DEFAULT_COUPLER_MODEL, SHARED_COUPLER_KEYS, _COUPLER_ADAPTER, _CouplerBase, over
from ltdsim.scenario.driver import Driver
from ltdsim.scenario.messages import _problems
from ltdsim.scenario.solver import Solver
from ltdsim.scenario.track import Curving, Track
from ltdsim.scenario.traction import Locomotive, Traction
from ltdsim.scenario.unused import first_of_each, flat_keys, given_by, no_effect
from ltdsim.scenario.vehicles import Vehicle


class Initial(_Strict):
    """Initial state of the train."""

    speed: float = Field(0.0, ge=0.0, le=150.0,
                         description="initial speed of every vehicle, m/s")
    velocities: list[Annotated[float, Field(ge=-150.0, le=150.0)]] | None = Field(
        None, description="one initial speed per vehicle, front to rear (instead of speed), "
                          "m/s")
    couplers: Literal["neutral", "stretched", "bunched"] = Field(
        "neutral", description="couplers start centred in their slack (neutral), at the "
                               "draft end (stretched) or at the buff end (bunched)")


class Phase(_Strict):
    """A named time window for analyses (the study's phases, paper §5.1)."""

    name: str = Field(min_length=1, description="label in tables, CSV files and figures; "
                                                "different for each phase")
    start: float = Field(ge=0.0, description="start of the window (simulated time), s")
    end: float = Field(gt=0.0, description="end of the window, after start, s")

    @model_validator(mode="after")
    def _order(self):
        if self.end <= self.start:
            raise ValueError(f"phase {self.name!r}: end ({self.end} s) must be after start "
                             f"({self.start} s)")
        return self


#: the study's analysis windows (paper §5.1)
STUDY_PHASES = [
    {"name": "acceleration", "start": 0.0, "end": 10.0},
    {"name": "curving", "start": 75.0, "end": 85.0},
    {"name": "deceleration", "start": 120.0, "end": 130.0},
    {"name": "slope_climbing", "start": 185.0, "end": 195.0},
]


CaseOverrides = dict[str, Any]


class Scenario(_Strict):
    """A validated scenario. Build it with :func:`load_scenario` or :meth:`from_dict`."""

    name: str = Field("scenario", description="free text, copied into the result's "
                                              "attributes")
    description: str = Field("", description="free text, copied into the result's "
                                             "attributes")
    solver: Solver = Field(description="integration settings")
    vehicles: list[Vehicle] = Field(min_length=1, description="one table per vehicle or "
                                                              "group, front to rear")
    couplers: Couplers | None = Field(None, description="draft gears and slack; needed by a "
                                                        "train of more than one vehicle")
    track: Track = Field(Track(), description="grades and curves, piecewise constant along "
                                              "the line")
    traction: Traction = Field(description="traction curve of all powered vehicles together, "
                                           "or, with [[locomotives]], the default of each "
                                           "consist")
    locomotives: list[Locomotive] = Field(
        [], description="distributed power: each entry a consist with its own traction "
                        "curve, lag state and optionally its own commands; the first is the "
                        "lead consist")
    brake: Brake = Field(Brake(), description="train air brake: brake-pipe signal and "
                                              "brake-cylinder dynamics")
    driver: Driver = Field(Driver(mode="force"),
                           description="the driver's commands: speed, force or notch "
                                       "control, and air-brake commands")
    initial: Initial = Field(Initial(), description="initial state of the train")
    curving: Curving | None = Field(None, description="curving-safety indicators of the run "
                                                      "(coupler angles, L/V); none: not "
                                                      "computed")
    # analysis windows; none given: the whole run is one phase (ltdsim.analysis.phases.phases_of)
    phases: list[Phase] = Field(
        [], description="named time windows for the per-phase analyses; none: the whole "
                        "run is one phase")
    cases: dict[str, CaseOverrides] = Field(
        {}, description="named sets of dotted-key overrides ([cases.NAME], "
                        "\"vehicles.3.mass\" = 9e4), applied with --case NAME")
    case: str | None = Field(None, description="name of the applied case, if any (set by "
                                               "--case)")

    @field_validator("vehicles")
    @classmethod
    def _expand(cls, vehicles: list[Vehicle]) -> list[Vehicle]:
        total = sum(v.count for v in vehicles)
        if total > MAX_VEHICLES:
            raise ValueError(f"at most {MAX_VEHICLES} vehicles, got {total}")
        out = []
        for v in vehicles:
            out.extend(v.model_copy(update={"count": 1}) for _ in range(v.count))
        return out

    @model_validator(mode="after")
    def _consistency(self):
        n = len(self.vehicles)
        if not any(v.powered for v in self.vehicles):
            raise ValueError("vehicles: at least one vehicle needs powered = true")
        if n > 1 and self.couplers is None:
            raise ValueError("a train of more than one vehicle needs [couplers.default]")
        vel = self.initial.velocities
        if vel is not None and len(vel) != n:
            raise ValueError(f"initial.velocities has {len(vel)} values for {n} vehicles")
        self._check_locomotives(n)
        if self.curving is not None:
            missing = [k for k in ("position", "velocity", "coupler_force")
                       if self.solver.record is not None and k not in self.solver.record]
            if missing:
                raise ValueError(f"solver.record: [curving] is computed from "
                                 f"{', '.join(missing)}; add them to solver.record or leave "
                                 "it out")
            for i, v in enumerate(self.vehicles):
                problem = v.geometry_problem()
                if problem:
                    raise ValueError(f"vehicles.{i}.{problem} (needed by [curving])")
        self._check_drives()
        if self.case is not None and self.case not in self.cases:
            avail = ", ".join(sorted(self.cases)) or "none defined"
            raise ValueError(f"case: {self.case!r} is not a case of this scenario (its "
                             f"cases: {avail}); case names the case applied by --case NAME")
        names = [p.name for p in self.phases]
        if len(set(names)) != len(names):
            raise ValueError(f"phases: names must differ, got {names}")
        if self.driver.brakes_commanded and not any(v.brake for v in self.vehicles):
            raise ValueError("driver: brake commands given but no vehicle has a [brake] table")
        self._check_brake()
        pid = self.driver.pid
        if self.driver.mode == "speed" and pid is not None:
            ratio = pid.ts / self.solver.dt
            if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio:
                raise ValueError(f"driver.pid.ts ({pid.ts:g} s) must be a whole multiple of "
                                 f"solver.dt ({self.solver.dt:g} s)")
        merged = []
        if self.couplers is not None:
            for k, o in enumerate(self.couplers.override):
                if o.index > n - 2:
                    raise ValueError(
                        f"couplers.override.{k}.index = {o.index} is out of range: "
                        f"{n} vehicles have coupler indices 0 to {n - 2}")
            for i in range(n - 1):
                try:
                    merged.append(self.coupler(i))  # validates merged parameters
                except ValidationError as exc:
                    text = "; ".join(m for _, m in _problems(exc, Scenario))
                    raise ValueError(f"coupler {i + 1} (index {i}; default merged with "
                                     f"overrides): {text}") from None
        return self

    def _check_brake(self) -> None:
        """The brake model's own needs: the lumped brake needs every cylinder_force and
        takes no pipe reductions; the fluid brake's reductions stay below the regulated
        pressure."""
        cmds = self.driver.brake_commands or []
        if self.brake.model == "lumped":
            for i, v in enumerate(self.vehicles):
                if v.brake is not None and v.brake.cylinder_force is None:
                    raise ValueError(f"vehicles.{i}.brake.cylinder_force: required by the "
                                     "lumped brake (brake.model = 'lumped')")
            for k, c in enumerate(cmds):
                if c.reduction is not None:
                    raise ValueError(f"driver.brake_commands.{k}.reduction: a pipe reduction "
                                     "needs brake.model = 'fluid'; the lumped brake takes "
                                     "handle positions or brake levels")
            return
        _, dv = valve_tables(self.brake.fluid)
        regulated = float(dv["regulated"])
        for k, c in enumerate(cmds):
            if c.handle == "fast-fill" and not float(dv.get("fast_fill_diameter", 0.0)) > 0.0:
                raise ValueError(f"driver.brake_commands.{k}.handle: 'fast-fill' needs a "
                                 "driver's valve with a fast-fill position (brake.fluid.valve "
                                 "driver_valve.fast_fill_diameter > 0, as the UIC presets); "
                                 "this valve has none: use 'release'")
            if c.reduction is not None and c.reduction >= regulated:
                raise ValueError(f"driver.brake_commands.{k}.reduction: {c.reduction:g} Pa "
                                 f"must be below the regulated pipe pressure, {regulated:g} "
                                 "Pa (gauge)")

    def _check_drives(self) -> None:
        """The induction drive: at most one motor per axle, a wheel load the creep law's
        contact geometry is meant for."""
        t = self.traction
        for k, loco in enumerate(self.consists()):
            if (loco.drive or t.drive) != "induction":
                continue
            axles = t.creep.wheelset.axles
            if t.motor.per_locomotive > axles:
                raise ValueError(f"traction.motor.per_locomotive: {t.motor.per_locomotive} "
                                 f"motors but traction.creep.wheelset.axles = {axles}: at "
                                 "most one motor per axle")
            for i in loco.vehicles:
                if self.vehicles[i].weight_mass * self.track.gravity / (2 * axles) > 2.5e5:
                    raise ValueError(f"vehicles.{i}: a wheel load above 250 kN "
                                     f"(static mass over 2 x traction.creep.wheelset.axles)")
                try:  # the contact ellipse must lie within Kalker's table
                    wheelset_row(t.creep.wheelset, self.vehicles[i].weight_mass,
                                 self.track.gravity)
                except ValueError as exc:
                    raise ValueError(f"traction.creep.wheelset: {exc}") from None

    def _check_locomotives(self, n: int) -> None:
        if not self.locomotives:
            return
        if self.locomotives[0].notch_profile is not None:
            raise ValueError("locomotives.0.notch_profile: the lead consist follows [driver] "
                             "(use driver.mode = 'notch' for notch control)")
        seen: dict[int, str] = {}
        for k, loco in enumerate(self.locomotives):
            for i in loco.vehicles:
                where = f"locomotives.{k}.vehicles"
                if i >= n:
                    raise ValueError(f"{where}: vehicle index {i} is out of range 0-{n - 1}")
                if not self.vehicles[i].powered:
                    raise ValueError(f"{where}: vehicle {i} ({self.vehicles[i].name!r}) "
                                     "is not powered")
                if i in seen:
                    raise ValueError(f"{where}: vehicle {i} is already in {seen[i]!r}")
                seen[i] = loco.name
            tau = loco.time_constant if loco.time_constant is not None else \
                self.traction.time_constant
            jerk = loco.jerk_limit if loco.jerk_limit is not None else self.traction.jerk_limit
            if jerk > 0.0 and tau == 0.0:
                raise ValueError(f"locomotives.{k}: jerk_limit needs time_constant > 0")
        missing = [i for i, v in enumerate(self.vehicles) if v.powered and i not in seen]
        if missing:
            raise ValueError(f"locomotives: powered vehicles {missing} belong to no locomotive")

    def consists(self) -> list[Locomotive]:
        """The locomotive consists, lead first; without ``[[locomotives]]`` one consist of
        every powered vehicle with the ``[traction]`` curve."""
        if self.locomotives:
            return list(self.locomotives)
        return [Locomotive(name="lead", vehicles=[i for i, v in enumerate(self.vehicles)
                                                  if v.powered])]

    # ------------------------------------------------------------------ helpers
    @property
    def n_vehicles(self) -> int:
        return len(self.vehicles)

    @property
    def n_couplers(self) -> int:
        return len(self.vehicles) - 1

    def coupler(self, i: int) -> _CouplerBase:
        """Parameters of coupler ``i`` (default merged with its overrides; the rule is
        in :class:`Couplers`), an instance of its model's class."""
        assert self.couplers is not None
        default = self.couplers.default
        overrides = [o for o in self.couplers.override if o.index == i]
        if not overrides:
            return default
        params = default.model_dump()
        for o in overrides:
            changed = o.model_dump(exclude_none=True, exclude={"index"})
            if "preset" in changed:  # another gear: only the coupling's own keys (its
                # slack, how many gears it holds, its coupler's strength and fatigue
                # curve) carry over
                params = {"slack": params["slack"], "gears": params["gears"],
                          "strength": params["strength"], "fatigue": params["fatigue"]}
            elif changed.get("model", params["model"]) != params["model"]:
                # another model: the keys every model shares carry over, not the old
                # model's own
                params = {k: params[k] for k in SHARED_COUPLER_KEYS}
            over(params, changed)  # (S_table given replaces the default's S, S its S_table)
        return _COUPLER_ADAPTER.validate_python(params)

    @classmethod
    def from_dict(cls, data: dict, source: str = "<dict>") -> "Scenario":
        """Validate a plain dictionary (as read from TOML) into a Scenario: types, ranges
        and relations, as for a file. It does not refuse keys that would have no effect
        (a dump of a scenario, :meth:`to_dict`, holds every key): for a user's table use
        :func:`ltdsim.scenario.scenario_from_data`, which also does that and applies a
        case, as :func:`ltdsim.load_scenario` does for a file."""
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            raise ScenarioError(source, _problems(exc, Scenario)) from None

    @classmethod
    def from_saved(cls, data: dict, source: str = "result") -> "Scenario":
        """:meth:`from_dict` of a scenario saved with a result (its ``scenario_json``).

        Results written before each coupler model had its own keys saved every coupler
        key for every model (the keys of other models as null or at their defaults, all
        unused by the model). Those are dropped here, for a saved dump only: in a file
        a key of another model is refused.
        """
        data = copy.deepcopy(data)
        default = (data.get("couplers") or {}).get("default")
        if isinstance(default, dict):
            model = COUPLER_CLASSES.get(default.get("model", DEFAULT_COUPLER_MODEL))
            if model is not None:
                data["couplers"]["default"] = {k: v for k, v in default.items()
                                               if k in model.model_fields}
        return cls.from_dict(data, source)

    def to_dict(self) -> dict:
        """Plain-data form (vehicles expanded, one entry each)."""
        return self.model_dump(mode="json")

    def with_overrides(self, overrides: dict[str, Any], source: str = "override") -> "Scenario":
        """Return a copy with dotted-key overrides applied and validated.

        Keys address the expanded form: ``"couplers.default.k3"``, ``"solver.t_end"``,
        ``"vehicles.3.mass"`` (vehicle 3, lead = 0), ``"driver.pid.kp"``. An override
        that would have no effect (:mod:`ltdsim.scenario.unused`) is refused, and so is
        ``case`` (:meth:`with_case` applies a case).
        """
        if "case" in overrides:
            raise ScenarioError(source, [("case", self._case_key())])
        data = self.to_dict()
        for key, value in overrides.items():
            _set_dotted(data, key, value, source)
        out = Scenario.from_dict(data, source)
        # (a key read back from the dictionary is given: only the overrides' own count)
        keys = flat_keys(overrides)
        unused = [(k, m) for k, m in no_effect(out) if given_by(keys, k)]
        if unused:
            raise ScenarioError(source, first_of_each(unused))
        return out

    def _case_key(self) -> str:
        """Why ``case`` is not a key to give: what --case does instead."""
        avail = ", ".join(sorted(self.cases)) or "none defined"
        return ("names the case applied, set by --case NAME, which applies the case's "
                "overrides; given as a key it would only relabel the run (the cases: "
                f"{avail})")

    def with_case(self, name: str, source: str = "scenario") -> "Scenario":
        """Return a copy with the named case's overrides applied."""
        if name not in self.cases:
            avail = ", ".join(sorted(self.cases)) or "none defined"
            raise ScenarioError(source, [("case", f"unknown case {name!r}; available: {avail}")])
        out = self.with_overrides(self.cases[name], source=f"{source} [cases.{name}]")
        return out.model_copy(update={"case": name})
