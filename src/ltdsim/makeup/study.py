"""The make-up study file (``ltdsim makeup STUDY.toml``): its keys as strict pydantic
models (the scenario's conventions: strict types, unknown keys refused, a range on every
number), the checks that need the base scenario (the wagon types' base vehicles, the
locomotive consists the make-ups keep, the rules' worst cases), and the loaded
:class:`Study`.

A bad key is one :class:`~ltdsim.errors.ScenarioError` line naming the study file, the
dotted key and what is allowed (docs/makeup.md, "The study file").
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal, Union

from pydantic import BeforeValidator, Field, ValidationError, field_validator, model_validator

from ltdsim.data import load_preset, preset_names
from ltdsim.errors import ScenarioError
from ltdsim.scenario import Davis, Scenario, VehicleBrake, VehicleGeometry, load_scenario, read_toml
from ltdsim.scenario._base import MAX_MASS, MAX_LENGTH, MAX_VEHICLES, _array_to_tuple, _Strict
from ltdsim.scenario.couplers import CouplerOverride
from ltdsim.scenario.messages import _problems

#: the most make-ups one study draws
MAX_MAKEUPS = 10_000
#: the manoeuvres a study can run (docs/makeup.md, "Manoeuvres")
KINDS = ("emergency", "full_service", "traction_start", "dynamic_brake", "crest", "sag")
#: manoeuvres that start from a speed (the rest start at rest)
MOVING = ("emergency", "full_service", "dynamic_brake", "crest", "sag")
#: the shipped limit sets (``limits = NAME`` of a wagon type: ltdsim/data/limits)
LIMITS_FAMILY = "limits"
#: a name that can stand in a case id and a file name
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]*$")

IntRange = Annotated[tuple[int, int], BeforeValidator(_array_to_tuple)]
ShareRange = Annotated[tuple[float, float], BeforeValidator(_array_to_tuple)]


def _plain_name(v: str) -> str:
    if not _NAME.match(v):
        raise ValueError(f"{v!r}: letters, digits, '-' and '_' only, starting with a letter "
                         "or digit (it names case ids and files)")
    return v


class WagonState(_Strict):
    """A wagon type's keys in one state (loaded or empty): the scenario's ``[[vehicles]]``
    keys, each replacing the base vehicle's (a table given replaces the base's whole
    table)."""

    mass: float | None = Field(None, gt=0.0, le=MAX_MASS,
                               description="dynamic mass (includes rotating inertia), kg "
                                           "(none: the base vehicle's)")
    static_mass: float | None = Field(None, gt=0.0, le=MAX_MASS,
                                      description="mass whose weight acts on grades and "
                                                  "curves, kg (none: the base vehicle's, "
                                                  "or mass when mass is given)")
    davis: Davis | None = Field(None, description="Davis resistance a + b v + c v^2 (none: "
                                                  "the base vehicle's)")
    brake: VehicleBrake | None = Field(None, description="tread brake in this state, e.g. "
                                                         "an empty-load device's reduced "
                                                         "cylinder force (none: the base "
                                                         "vehicle's)")
    geometry: VehicleGeometry | None = Field(None, description="curving geometry (none: "
                                                               "the base vehicle's)")
    limits: Union[str, "LimitTable"] | None = Field(
        None, description="force limits of its couplers in this state: a shipped set "
                          "(ltdsim/data/limits) or a table {lcf = N, ltf = N} (none: the "
                          "type's limits); not a vehicle key")

    @field_validator("limits")
    @classmethod
    def _known(cls, v):
        return _known_limits(v)

    def vehicle_keys(self) -> dict:
        """The ``[[vehicles]]`` keys given (JSON types), without the limits."""
        return self.model_dump(mode="json", exclude_none=True, exclude={"limits"})


class LimitTable(_Strict):
    """Force limits of a coupler, N: the largest longitudinal compressive force (LCF)
    and tensile force (LTF) it may carry."""

    lcf: float | None = Field(None, gt=0.0, le=1e8,
                              description="largest longitudinal compressive force, N")
    ltf: float | None = Field(None, gt=0.0, le=1e8,
                              description="largest longitudinal tensile force, N")

    @model_validator(mode="after")
    def _one(self):
        if self.lcf is None and self.ltf is None:
            raise ValueError("a limits table needs lcf (N) or ltf (N)")
        return self


def _known_limits(v):
    if isinstance(v, str) and v not in limit_sets():
        raise ValueError(f"unknown limit set {v!r}; available: "
                         f"{', '.join(limit_sets()) or 'none'}")
    return v


def limit_sets() -> tuple[str, ...]:
    """Names of the shipped limit sets (``ltdsim/data/limits``)."""
    return preset_names(LIMITS_FAMILY)


def limit_table(limits: "str | LimitTable | None") -> LimitTable | None:
    """The limits of a type's ``limits`` key: a shipped set's (by name) or the table."""
    if limits is None or isinstance(limits, LimitTable):
        return limits
    data = load_preset(LIMITS_FAMILY, limits)
    return LimitTable(**{k: float(data[k]) for k in ("lcf", "ltf") if k in data})


WagonState.model_rebuild()


class WagonType(_Strict):
    """A wagon type: the base scenario's vehicle it starts from and its keys loaded and
    empty."""

    name: str = Field(min_length=1, description="label in results (letters, digits, - "
                                                "and _)")
    vehicle: str | None = Field(None, description="name of the base scenario's vehicle "
                                                  "whose keys it starts from (none: the "
                                                  "first unpowered vehicle)")
    length: float | None = Field(None, gt=0.0, le=MAX_LENGTH,
                                 description="length over couplers, m (none: the base "
                                             "vehicle's)")
    coupler: dict[str, Any] | None = Field(
        None, description="keys of the coupler ahead of each wagon of this type (joining it "
                          "to the vehicle in front), as a [[couplers.override]] table "
                          "without index, e.g. {preset = 'mt-2'} (none: the base's default)")
    limits: Union[str, LimitTable] | None = Field(
        None, description="force limits of its couplers, loaded and empty unless a state "
                          "gives its own: a shipped set (ltdsim/data/limits) or a table "
                          "{lcf = N, ltf = N} (none: the study's [limits])")
    loaded: WagonState = Field(WagonState(), description="its keys loaded")
    empty: WagonState = Field(WagonState(), description="its keys empty")

    _name = field_validator("name")(lambda v: _plain_name(v))

    @field_validator("limits")
    @classmethod
    def _known(cls, v):
        return _known_limits(v)

    @field_validator("coupler")
    @classmethod
    def _coupler(cls, v):
        if v is None:
            return v
        if "index" in v:
            raise ValueError("index: not a key here (the coupler ahead of each wagon of the "
                             "type is meant)")
        try:
            CouplerOverride.model_validate({"index": 0, **v})
        except ValidationError as exc:
            key, msg = _problems(exc)[0]
            raise ValueError(f"{key}: {msg}" if key else msg) from None
        return v


class MixEntry(_Strict):
    """How many wagons of one type in one state a make-up holds: a count, a share (fixed
    or drawn uniformly from [low, high] for each make-up), or neither (the rest)."""

    type: str = Field(description="a wagon type's name")
    state: Literal["loaded", "empty"] = Field(description="loaded or empty")
    count: int | None = Field(None, ge=0, le=MAX_VEHICLES,
                              description="wagons, a whole number of blocks, -")
    share: Union[Annotated[float, Field(ge=0.0, le=1.0)], ShareRange] | None = Field(
        None, description="share of the wagons, 0-1, or [low, high] drawn for each make-up, -")

    @model_validator(mode="after")
    def _one(self):
        if self.count is not None and self.share is not None:
            raise ValueError("give count or share (or neither: the rest), not both")
        if isinstance(self.share, tuple):
            lo, hi = self.share
            if not 0.0 <= lo <= hi <= 1.0:
                raise ValueError(f"share: [low, high] with 0 <= low <= high <= 1, got "
                                 f"[{lo:g}, {hi:g}]")
        return self


class Manoeuvre(_Strict):
    """One standard manoeuvre each make-up runs (docs/makeup.md, "Manoeuvres")."""

    name: str = Field(min_length=1, description="label in case ids and results (letters, "
                                                "digits, - and _)")
    kind: Literal[KINDS] = Field(  # type: ignore[valid-type]
        description="emergency, full_service (a brake application from speed, power off), "
                    "traction_start (from rest, brakes released as traction ramps up), "
                    "dynamic_brake (from speed), crest or sag (coasting over a change of "
                    "grade)")
    speed: float | None = Field(None, gt=0.0, le=150.0,
                                description="initial speed, m/s (required but by "
                                            "traction_start, which starts at rest)")
    duration: float = Field(gt=0.0, le=3600.0, description="simulated time, s")
    at: float = Field(2.0, ge=0.0, le=3600.0,
                      description="when the brake handle moves, or the traction or dynamic "
                                  "brake starts to ramp, s")
    grade: float = Field(0.0, ge=-0.1, le=0.1,
                         description="grade, + uphill (crest, sag: the grade's magnitude on "
                                     "either side of the change, default 0.01), -")
    force: float | None = Field(None, gt=0.0, le=1e8,
                                description="traction_start, dynamic_brake: the force "
                                            "demanded at the end of the ramp, N (none: "
                                            "every consist's max_force)")
    ramp: float = Field(10.0, ge=0.0, le=600.0,
                        description="traction_start, dynamic_brake: time the demand takes "
                                    "to rise from 0, s")
    couplers: Literal["neutral", "stretched", "bunched"] | None = Field(
        None, description="initial state of the couplers (none: bunched for "
                          "traction_start, the base scenario's otherwise)")
    overrides: dict[str, Any] = Field({}, description="more dotted-key overrides of the "
                                                      "scenario for this manoeuvre")

    _name = field_validator("name")(lambda v: _plain_name(v))

    @model_validator(mode="after")
    def _needs(self):
        if self.kind in MOVING and self.speed is None:
            raise ValueError(f"speed: required by kind {self.kind!r} (m/s, above 0)")
        if self.kind == "traction_start" and self.speed is not None:
            raise ValueError("speed: traction_start starts at rest; leave speed out")
        if self.at >= self.duration:
            raise ValueError(f"at ({self.at:g} s) must be before the end of the run "
                             f"(duration {self.duration:g} s)")
        if self.kind in ("crest", "sag") and self.grade < 0.0:
            raise ValueError(f"grade: the magnitude of the grades either side of the "
                             f"{self.kind} (0-0.1), got {self.grade:g}")
        return self


class StudyFile(_Strict):
    """A make-up study file's keys."""

    name: str = Field("makeup", description="free text, the page's title")
    description: str = Field("", description="free text")
    scenario: str = Field(description="base scenario file, relative to the study file")
    case: str | None = Field(None, description="a named case of the base scenario to start "
                                               "from")
    makeups: int = Field(ge=1, le=MAX_MAKEUPS, description="make-ups to draw, -")
    seed: int = Field(ge=0, description="seed of the draws: the same seed, the same "
                                        "population")
    wagons: int | None = Field(None, ge=1, le=MAX_VEHICLES,
                               description="wagons in each make-up (none: the base "
                                           "scenario's unpowered vehicles)")
    block: int = Field(1, ge=1, le=MAX_VEHICLES,
                       description="wagons come in blocks of this many alike (same type and "
                                   "state); wagons a whole number of blocks, -")
    empties_behind: int = Field(0, ge=0, le=MAX_VEHICLES,
                                description="empties only behind this wagon position "
                                            "(wagons counted from 1 behind the lead "
                                            "consist; 0: anywhere), -")
    remote_after: list[Union[int, IntRange]] = Field(
        [], description="one per remote consist of the base scenario, front to rear: the "
                        "wagon position it stands behind, or [low, high] drawn for each "
                        "make-up")
    types: list[WagonType] = Field(min_length=1, description="the wagon types")
    mix: list[MixEntry] = Field(min_length=1, description="counts or shares of each type "
                                                          "and state")
    manoeuvres: list[Manoeuvre] = Field(min_length=1, description="what each make-up runs")
    limits: LimitTable | None = Field(None, description="limits of every coupler whose "
                                                        "wagons' types give none, N")
    confidence: float = Field(0.95, gt=0.5, lt=1.0,
                              description="confidence level of the exceedance "
                                          "probabilities' intervals, -")

    @model_validator(mode="after")
    def _relations(self):
        names = [t.name for t in self.types]
        if len(set(names)) != len(names):
            raise ValueError(f"types: names must differ, got {names}")
        names = [m.name for m in self.manoeuvres]
        if len(set(names)) != len(names):
            raise ValueError(f"manoeuvres: names must differ, got {names}")
        known = {t.name for t in self.types}
        seen = set()
        for k, e in enumerate(self.mix):
            if e.type not in known:
                raise ValueError(f"mix.{k}.type: {e.type!r} is not a type; the types: "
                                 f"{', '.join(sorted(known))}")
            if (e.type, e.state) in seen:
                raise ValueError(f"mix.{k}: {e.type} {e.state} is given twice")
            seen.add((e.type, e.state))
            if e.count is not None and e.count % self.block:
                raise ValueError(f"mix.{k}.count: {e.count} is not a whole number of blocks "
                                 f"of {self.block} wagons")
        rest = [k for k, e in enumerate(self.mix) if e.count is None and e.share is None]
        if len(rest) > 1:
            raise ValueError(f"mix: entries {', '.join(str(k) for k in rest)} give neither "
                             "count nor share; only one entry may take the rest")
        if not rest and any(isinstance(e.share, tuple) for e in self.mix):
            raise ValueError("mix: a share drawn from a range needs one entry with neither "
                             "count nor share to take the rest")
        return self


@dataclass
class Study:
    """A loaded make-up study: the file's keys, the base scenario, and what follows
    from them: the wagons per make-up, the base vehicle of each type (its keys as a
    dictionary), the consists (lead first, base vehicle indices) and the couplers'
    limits of each type (N, NaN where none)."""

    spec: StudyFile
    base: Scenario
    source: str
    wagons: int
    templates: dict[str, dict]
    consists: list[list[int]]
    limits: dict[tuple[str, str], tuple[float, float]] = field(default_factory=dict)

    @property
    def seed(self) -> int:
        return self.spec.seed


#: a key a validator's message starts with ("speed: required ..."), below its table
_LEADING_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_.]*): (.*)$", re.S)


def study_problems(exc: ValidationError) -> list[tuple[str, str]]:
    """The problems of a study file's ``ValidationError`` as ``(dotted key, message)``
    (:func:`ltdsim.scenario.messages._problems`), a validator's message that names a
    key of its table ("speed: required ...") given under that key."""
    out = []
    for key, msg in _problems(exc, StudyFile):
        m = _LEADING_KEY.match(msg)
        if m and not m.group(2).startswith(" "):
            key = f"{key}.{m.group(1)}" if key else m.group(1)
            msg = m.group(2)
        out.append((key, msg))
    return out


def _fail(source: str, key: str, msg: str):
    raise ScenarioError(source, [(key, msg)])


def load_study(path: str | Path) -> Study:
    """Read and validate make-up study file ``path`` and its base scenario.

    Raises ScenarioError naming the file, the key and what is allowed.
    """
    path = Path(path)
    source = str(path)
    data = read_toml(path, "make-up study file")
    try:
        spec = StudyFile.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(source, study_problems(exc)) from None
    target = path.parent / spec.scenario
    if target.resolve() == path.resolve():
        _fail(source, "scenario", "names this study file; give the scenario the make-ups "
                                  "start from")
    base = load_scenario(target, case=spec.case)
    if base.initial.velocities is not None:
        _fail(source, "scenario", f"{target}: initial.velocities gives one speed per vehicle "
                                  "of the base train; a make-up has its own vehicles: leave "
                                  "it out")
    consists = _consists(source, base)
    powered = {i for c in consists for i in c}
    unpowered = [i for i in range(base.n_vehicles) if i not in powered]
    wagons = spec.wagons if spec.wagons is not None else len(unpowered)
    if wagons < 1:
        _fail(source, "wagons", "the base scenario has no unpowered vehicle: give wagons")
    if len(consists) - 1 != len(spec.remote_after):
        _fail(source, "remote_after", f"give one position per remote consist of the base "
                                      f"scenario: it has {len(consists) - 1} (got "
                                      f"{len(spec.remote_after)})")
    _check_rules(source, spec, wagons)
    templates = {}
    names = [v.name for v in base.vehicles]
    for k, t in enumerate(spec.types):
        if t.vehicle is None:
            if not unpowered:
                _fail(source, f"types.{k}.vehicle", "the base scenario has no unpowered "
                                                    "vehicle: name one to start from")
            i = unpowered[0]
        elif t.vehicle in names:
            i = names.index(t.vehicle)
        else:
            _fail(source, f"types.{k}.vehicle", f"{t.vehicle!r} is no vehicle of the base "
                                                f"scenario; its vehicles: "
                                                f"{', '.join(dict.fromkeys(names))}")
        if base.vehicles[i].powered:
            _fail(source, f"types.{k}.vehicle", f"{t.vehicle!r} is powered (a locomotive); "
                                                "a wagon type starts from a wagon")
        templates[t.name] = base.vehicles[i].model_dump(mode="json", exclude={"count"})
    study = Study(spec, base, source, wagons, templates, consists)
    for t in spec.types:
        for state in ("loaded", "empty"):
            study.limits[(t.name, state)] = limits_of(spec, t, state)
    # every make-up's vehicles, one per state of each type, must be valid vehicles
    from ltdsim.scenario import Vehicle

    for k, t in enumerate(spec.types):
        for state in ("loaded", "empty"):
            try:
                Vehicle.model_validate(vehicle_dict(study, t.name, state))
            except ValidationError as exc:
                raise ScenarioError(source, [(f"types.{k}.{state}" + (f".{key}" if key else ""),
                                              msg) for key, msg in _problems(exc)]) from None
    return study


def vehicle_dict(study: Study, type_name: str, state: str) -> dict:
    """The ``[[vehicles]]`` table of a wagon of ``type_name`` in ``state``: the base
    vehicle's keys with the type's over them; named ``<type>-<state>``."""
    t = next(t for t in study.spec.types if t.name == type_name)
    v = copy.deepcopy(study.templates[type_name])
    v["name"] = f"{type_name}-{state}"
    if t.length is not None:
        v["length"] = t.length
    given = getattr(t, state).vehicle_keys()
    if "mass" in given and "static_mass" not in given:
        v["static_mass"] = None  # (the base's static mass belongs to its own mass)
    v.update(given)
    return v


def limits_of(spec: StudyFile, t: WagonType, state: str) -> tuple[float, float]:
    """The LCF and LTF limits of a wagon of type ``t`` in ``state``, N (NaN: none): the
    state's limits, else the type's, else the study's ``[limits]``, key by key."""
    out = []
    for key in ("lcf", "ltf"):
        value = None
        for lim in (getattr(t, state).limits, t.limits, spec.limits):
            table = limit_table(lim)
            if table is not None and getattr(table, key) is not None:
                value = getattr(table, key)
                break
        out.append(math.nan if value is None else float(value))
    return out[0], out[1]


def _consists(source: str, base: Scenario) -> list[list[int]]:
    """The base scenario's locomotive consists (base vehicle indices, lead first), each
    a block of neighbouring vehicles, the lead's at the front."""
    out = []
    for k, loco in enumerate(base.consists()):
        idx = sorted(loco.vehicles)
        if idx != list(range(idx[0], idx[0] + len(idx))):
            _fail(source, "scenario", f"the base scenario's consist {loco.name!r} (vehicles "
                                      f"{[i + 1 for i in idx]}) is not one block of "
                                      "neighbouring vehicles: a make-up moves each consist "
                                      "whole")
        out.append(idx)
    if out[0][0] != 0:
        _fail(source, "scenario", "the base scenario's lead consist is not at the front: a "
                                  "make-up puts its wagons behind the lead consist")
    return out


def _blocks(e: MixEntry, nb: int, high: bool) -> int:
    """Blocks of entry ``e`` at its largest (``high``) or least share, of ``nb``."""
    if e.count is not None:
        return e.count
    share = e.share[1 if high else 0] if isinstance(e.share, tuple) else e.share
    return math.floor(share * nb + 0.5)


def _check_rules(source: str, spec: StudyFile, wagons: int) -> None:
    """The rules can always be met: whole blocks, the counts within the wagons, room for
    the empties behind ``empties_behind``, remote positions in order within the train."""
    n = spec.block
    if wagons % n:
        _fail(source, "block", f"{wagons} wagons are not a whole number of blocks of {n}")
    nb = wagons // n
    rest = [e for e in spec.mix if e.count is None and e.share is None]
    given = [e for e in spec.mix if not (e.count is None and e.share is None)]
    top = sum(_blocks(e, nb, True) if e.share is not None else e.count // n for e in given)
    if rest and top > nb:
        _fail(source, "mix", f"the counts and largest shares take up to {top * n} wagons, more "
                             f"than the {wagons} of a make-up")
    if not rest:
        total = sum(e.count / n if e.count is not None else e.share * nb for e in given)
        if abs(total - nb) > 1e-9 * nb:
            _fail(source, "mix", f"the counts and shares add up to {total * n:g} wagons, not "
                                 f"the {wagons} of a make-up: give one entry neither count nor "
                                 "share to take the rest")
    low = {id(e): (_blocks(e, nb, False) if e.share is not None else e.count // n)
           for e in given}
    most_empty = 0
    for e in spec.mix:
        if e.state != "empty":
            continue
        if e in rest:
            most_empty += nb - sum(low.values())
        else:
            most_empty += _blocks(e, nb, True) if e.share is not None else e.count // n
    front = math.ceil(spec.empties_behind / n)
    if spec.empties_behind > wagons:
        _fail(source, "empties_behind", f"must be at most the {wagons} wagons of a make-up, "
                                        f"got {spec.empties_behind}")
    if most_empty * n > wagons - front * n:
        _fail(source, "empties_behind", f"up to {most_empty * n} empties must stand behind "
                                        f"wagon {spec.empties_behind} (in whole blocks, behind "
                                        f"wagon {front * n}), but only {wagons - front * n} "
                                        "places are there: allow fewer empties or more places")
    prev = 0
    for k, r in enumerate(spec.remote_after):
        lo, hi = (r, r) if isinstance(r, int) else r
        if not 1 <= lo <= hi <= wagons:
            _fail(source, f"remote_after.{k}", f"wagon positions from 1 to {wagons} with low <= "
                                               f"high, got {list(r) if not isinstance(r, int) else r}")
        if lo <= prev:
            _fail(source, f"remote_after.{k}", f"must lie behind the previous remote consist's "
                                               f"positions (above {prev}), got {lo}")
        prev = hi
