"""Scenario files: TOML in, a validated :class:`Scenario` out.

Every key is documented with its unit in ``docs/scenario.md``, whose key tables
:mod:`ltdsim.scenario.doc` generates from the fields below: write each description as
``"meaning, UNIT"`` (``-`` for dimensionless; an array of points opens with its columns,
``"[t s, v m/s] ..."``), and ranges a validator checks in the meaning. Validation happens at
load time: an unknown key, a value out of range, a NaN, an empty train, an output
interval that is not a whole multiple of the step, an override that points nowhere or
an unknown case raises one :class:`~ltdsim.errors.ScenarioError` naming the file, the
dotted key and the allowed values.
"""

from __future__ import annotations

import copy
import functools
import math
import tomllib
import types
import typing
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    TypeAdapter,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)

from ltdsim.scenario.creep import Creep, wheelset_row
from ltdsim.errors import ScenarioError, _printable
from ltdsim.engine.layout import DRIVE_SIGNALS, ENERGY_TERMS

# Physical sanity bounds used in validation (documented in docs/scenario.md).
MAX_MASS = 1.0e6  # kg, one vehicle
MAX_LENGTH = 100.0  # m, one vehicle
MAX_VEHICLES = 20_000


class _Strict(BaseModel):
    # strict types: a number must be a TOML number (integer or float; never a string or a
    # boolean), an integer a TOML integer, a flag a TOML boolean, a name a string, so that
    # ``mass = true`` or ``dt = "1e-4"`` is refused instead of read as 1 kg or 1e-4 s
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True,
                              strict=True)


def _array_to_tuple(v):
    """TOML (and JSON) give arrays as lists; a table row is validated as a tuple."""
    return tuple(v) if isinstance(v, list) else v


Pair = Annotated[tuple[float, float], BeforeValidator(_array_to_tuple)]
Triple = Annotated[tuple[float, float, float], BeforeValidator(_array_to_tuple)]
Points = list[Pair]


def _check_table(points: Points, what: str, ok, allowed: str) -> Points:
    """A piecewise table: at least one point, first column strictly increasing, every
    value in the second column passing ``ok`` (described by ``allowed``)."""
    if len(points) == 0:
        raise ValueError("needs at least one [x, y] point")
    xs = [p[0] for p in points]
    if any(b <= a for a, b in zip(xs, xs[1:])):
        raise ValueError(f"the first column ({what}) must be strictly increasing, got {xs}")
    bad = [p[1] for p in points if not ok(p[1])]
    if bad:
        raise ValueError(f"the second column must be {allowed}, got {bad}")
    return points


#: the energy balance's result variables (``solver.energy = true``), J: the work terms
#: (:data:`ltdsim.engine.layout.ENERGY_TERMS`), each coupler's net work, the train's kinetic
#: energy, and what the balance leaves unaccounted
ENERGY_VARIABLES = (*ENERGY_TERMS, "coupler_energy", "kinetic_energy",
                    "energy_balance_error")
#: result variables a run can leave out of its recording (``solver.record``)
RECORDABLE = ("position", "velocity", "acceleration", "coupler_deflection", "coupler_force",
              "brake_force", "brake_cylinder", "locomotive_force", "brake_pipe_pressure",
              "auxiliary_reservoir_pressure", "brake_cylinder_pressure", "air_exhausted",
              *DRIVE_SIGNALS, *ENERGY_VARIABLES)


class Solver(_Strict):
    """Integration settings."""

    method: Literal["euler", "heun", "ode3", "rk4", "bs23"] = Field(
        "ode3", description="explicit Runge-Kutta method with a fixed step (ode3: "
                            "Bogacki-Shampine, third order); bs23: the same pair with error "
                            "control and adaptive steps")
    dt: float = Field(1e-4, gt=0.0, le=1.0,
                      description="step of the fixed-step methods; for bs23 the first step, s")
    t_end: float = Field(gt=0.0, le=1e7, description="end time, rounded down to a whole "
                                                     "number of output intervals, s")
    output_interval: float = Field(
        1e-3, gt=0.0, description="spacing of the recorded samples: a whole multiple of dt, "
                                  "at most t_end, s")
    record: Optional[list[Literal[RECORDABLE]]] = Field(  # type: ignore[valid-type]
        None, description="the time series to record, by result-variable name; left out, "
                          "every one. Always kept: the train's signals (traction_force, "
                          "speed_reference, ...) and the peak coupler forces over every "
                          "step. relative_position comes with position, relative_velocity "
                          "and speed_error with velocity; naming one induction-drive "
                          "signal records all of them. A selection saves memory and time "
                          "when only some results matter (many cases)")
    # adaptive Bogacki-Shampine 3(2) (method = "bs23")
    rtol: float = Field(1e-5, gt=0.0, le=0.1,
                        description="bs23: relative tolerance (not applied to positions, "
                                    "whose size is arbitrary), -")
    atol: float = Field(1e-6, gt=0.0, le=1.0,
                        description="bs23: absolute tolerance on displacements, plate "
                                    "travel, brake fill and the fluid brake's valve "
                                    "positions, m and m/s (vehicle speeds use atol x 10: "
                                    "1e-4 means 1 mm/s; force states atol x 1e6 N/m: "
                                    "1e-6 means 1 N, a draft gear's internal force atol x "
                                    "1e7 N/m on the force it exerts; the fluid brake's "
                                    "pressures atol x 1e6 "
                                    "Pa/m, 1 Pa, and pipe flows atol x 10 kg/(s m), 1e-5 "
                                    "kg/s)")
    max_step: float = Field(0.05, gt=0.0, le=10.0, description="bs23: largest step, s")
    air_max_step: float = Field(
        1.0, gt=0.0, le=100.0,
        description="bs23 with brake.model = \"fluid\": largest step of the brake's "
                    "pneumatic states, which take their own error-controlled steps (a "
                    "mechanical step spans at most two of them), s")
    energy: bool = Field(
        False, description="account for the energy: the work of traction, brakes and "
                           "resistances, each coupler's work and the kinetic energy, "
                           "integrated with the motion (result variables "
                           "traction_energy ... energy_balance_error, J); off, the run "
                           "computes none of it")
    stability_check: bool = Field(
        True, description="refuse a fixed step above the method's largest stable step for "
                          "the train (ltdsim.engine.preflight); false runs it anyway (the run stops "
                          "at the first record with a non-finite state)")

    @property
    def adaptive(self) -> bool:
        """True for an error-controlled method."""
        return self.method == "bs23"

    @model_validator(mode="after")
    def _multiples(self):
        ratio = self.output_interval / self.dt
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio:
            raise ValueError(
                f"output_interval ({self.output_interval:g} s) must be a whole multiple "
                f"of dt ({self.dt:g} s)"
            )
        if self.t_end < self.output_interval:
            raise ValueError(f"t_end ({self.t_end:g} s) must be at least output_interval "
                             f"({self.output_interval:g} s)")
        return self

    @model_validator(mode="after")
    def _energy_recorded(self):
        named = sorted(set(self.record or ()) & set(ENERGY_VARIABLES))
        if named and not self.energy:
            raise ValueError(f"record names {', '.join(named)}, which only a run with "
                             "energy = true computes: set solver.energy = true or leave "
                             "them out")
        return self

    @property
    def record_every(self) -> int:
        """Steps between two recorded samples."""
        return int(round(self.output_interval / self.dt))

    @property
    def n_steps(self) -> int:
        """Number of steps: t_end rounded down to a whole number of output intervals."""
        n_rec = int(math.floor(self.t_end / self.output_interval + 1e-9))
        return n_rec * self.record_every


class Davis(_Strict):
    """Davis resistance coefficients ``F = a + b v + c v^2``."""

    a: float = Field(0.0, ge=0.0, le=1e6, description="constant term, opposing motion, N")
    b: float = Field(0.0, ge=0.0, le=1e6, description="term proportional to speed, N s/m")
    c: float = Field(0.0, ge=0.0, le=1e5,
                     description="term proportional to the square of speed, N s^2/m^2")
    v0: float = Field(0.01, ge=0.0, le=1.0,
                      description="standstill speed: below it the constant term fades "
                                  "linearly to 0 (no chatter at rest), m/s")


class VehicleBrake(_Strict):
    """Tread brake of one vehicle: retarding force = cylinder force x rigging ratio x
    shoe friction coefficient. Lumped brake (``brake.model = "lumped"``): the cylinder
    force is ``cylinder_force`` scaled by the cylinder's fill (0-1). Fluid brake: it is
    ``max(0, p x piston_area - return_spring) x efficiency``, ``p`` the cylinder's
    gauge pressure."""

    cylinder_force: float | None = Field(
        None, gt=0.0, le=1e6,
        description="piston force at full application (pressure x area x efficiency); "
                    "required by the lumped brake; fluid brake: the force a full service "
                    "gives, from which piston_area is derived when that is left out, N")
    rigging_ratio: float = Field(gt=0.0, le=100.0,
                                 description="total shoe force / piston force, -")
    shoes: int = Field(8, ge=1, le=64, description="number of shoes sharing the shoe force "
                                                   "(for the force K on one shoe)")
    friction: Union[Literal["karwatzki"], Annotated[float, Field(gt=0.0, le=1.0)]] = Field(
        "karwatzki", description="shoe friction coefficient mu: 'karwatzki' (Karwatzki's "
                                 "cast-iron law 0.6 (16K+100)/(80K+100) (V+100)/(5V+100) with "
                                 "K in kN per shoe and V in km/h) or a constant, -")
    friction_table: Points | None = Field(
        None, description="[speed m/s, mu -] points, linear between, constant outside; speeds "
                          "strictly increasing, mu in [0, 1]; replaces friction")
    piston_area: float | None = Field(
        None, gt=0.0, le=1.0,
        description="fluid brake: brake-cylinder piston area, m^2 (none: derived so that the "
                    "valve preset's full-service cylinder pressure gives cylinder_force: "
                    "(cylinder_force / efficiency + return_spring) / pressure)")
    return_spring: float = Field(0.0, ge=0.0, le=1e5,
                                 description="fluid brake: force of the piston's return "
                                             "spring, subtracted from pressure x area, N")
    efficiency: float = Field(1.0, gt=0.0, le=1.0,
                              description="fluid brake: rigging efficiency (piston force "
                                          "reaching the rigging / pressure x area less the "
                                          "spring), -")

    @field_validator("friction_table")
    @classmethod
    def _mu_table(cls, v):
        if v is None:
            return v
        return _check_table(v, "speeds, m/s", lambda m: 0.0 <= m <= 1.0, "in [0, 1]")

    @model_validator(mode="after")
    def _force_or_area(self):
        if self.cylinder_force is None and self.piston_area is None:
            raise ValueError("give cylinder_force (N) or, for the fluid brake, piston_area "
                             "(m^2)")
        return self

#: Representative geometry of the two kinds of vehicle, used where a vehicle gives no
#: ``geometry`` table (docs/curving.md gives the sources): a four-axle bogie freight wagon
#: and a six-axle locomotive, each with AAR couplers. The bogie spacing follows from the
#: length over couplers: ``length - 2 (pivot_overhang + coupler_length)``.
GEOMETRY_DEFAULTS = {
    "wagon": {"pivot_overhang": 1.0, "coupler_length": 0.9, "coupler_height": 0.876,
              "cg_height": 2.0, "axles": 4},
    "locomotive": {"pivot_overhang": 2.0, "coupler_length": 0.9, "coupler_height": 0.876,
                   "cg_height": 1.8, "axles": 6},
}


class VehicleGeometry(_Strict):
    """Plan and height geometry of a vehicle for the curving indicators (ltdsim.results.curving);
    a key left out takes the wagon's or (powered vehicles) the locomotive's default."""

    bogie_spacing: float | None = Field(None, gt=0.0, le=MAX_LENGTH,
                                        description="distance between the bogie centres "
                                                    "(none: length - 2 (pivot_overhang + "
                                                    "coupler_length)), m")
    pivot_overhang: float | None = Field(None, ge=0.0, le=20.0,
                                         description="distance from a bogie centre to the "
                                                     "coupler pivot beyond it, m")
    coupler_length: float | None = Field(None, ge=0.0, le=5.0,
                                         description="coupler of one vehicle end from its "
                                                     "pivot to the coupling line, m")
    coupler_height: float | None = Field(None, ge=0.2, le=2.0,
                                         description="coupler centre line above the rail, m")
    cg_height: float | None = Field(None, ge=0.2, le=5.0,
                                    description="centre of gravity of the loaded vehicle "
                                                "above the rail, m")
    axles: int | None = Field(None, ge=2, le=16, description="number of axles, half of them "
                                                             "in each of the two bogies, -")


class ResolvedGeometry(typing.NamedTuple):
    """A vehicle's geometry with the defaults filled in (SI: m, -)."""

    bogie_spacing: float
    pivot_overhang: float
    coupler_length: float
    coupler_height: float
    cg_height: float
    axles: int


class Vehicle(_Strict):
    """One vehicle, or ``count`` identical ones, front to rear."""

    name: str = Field(min_length=1, description="label in results")
    count: int = Field(1, ge=1, le=MAX_VEHICLES,
                       description="repeat this vehicle: the number of identical vehicles "
                                   "the table stands for")
    mass: float = Field(gt=0.0, le=MAX_MASS, description="dynamic mass (includes rotating "
                                                         "inertia) used in m a = F, kg")
    static_mass: float | None = Field(None, gt=0.0, le=MAX_MASS,
                                      description="mass whose weight acts on grades and "
                                                  "curves (none: mass), kg")
    length: float = Field(gt=0.0, le=MAX_LENGTH, description="length over couplers, m")
    davis: Davis = Field(Davis(), description="Davis resistance a + b v + c v^2, opposing "
                                              "motion")
    powered: bool = Field(False, description="takes an equal share of its locomotive "
                                             "consist's force; at least one vehicle must be "
                                             "powered")
    brake: VehicleBrake | None = Field(None, description="air (tread) brake of this vehicle: "
                                                         "retarding force = fill x "
                                                         "cylinder_force x rigging_ratio x "
                                                         "mu(v, K); none: unbraked")
    geometry: VehicleGeometry = Field(VehicleGeometry(),
                                      description="bogie and coupler geometry for the "
                                                  "curving indicators ([curving]); "
                                                  "defaults by kind (docs/curving.md)")

    @property
    def weight_mass(self) -> float:
        """Mass used for grade and curve resistance, kg."""
        return self.mass if self.static_mass is None else self.static_mass

    def resolved_geometry(self) -> ResolvedGeometry:
        """:attr:`geometry` with each missing key taken from the wagon's or (powered) the
        locomotive's default, and the bogie spacing from the length over couplers."""
        base = GEOMETRY_DEFAULTS["locomotive" if self.powered else "wagon"]
        g = self.geometry
        pick = {k: (getattr(g, k) if getattr(g, k) is not None else base[k]) for k in base}
        b = g.bogie_spacing
        if b is None:
            b = self.length - 2.0 * (pick["pivot_overhang"] + pick["coupler_length"])
        return ResolvedGeometry(bogie_spacing=float(b), **pick)

    def geometry_problem(self) -> str | None:
        """What is wrong with the resolved geometry for the curving indicators, or None."""
        g = self.resolved_geometry()
        if g.bogie_spacing <= 0.0:
            return (f"geometry: length ({self.length:g} m) less 2 (pivot_overhang + "
                    f"coupler_length) leaves no room between the bogies; give "
                    f"geometry.bogie_spacing or shorter overhangs")
        if g.bogie_spacing + 2.0 * g.pivot_overhang > self.length + 1e-9:
            return (f"geometry: bogie_spacing + 2 pivot_overhang = "
                    f"{g.bogie_spacing + 2.0 * g.pivot_overhang:g} m exceeds the "
                    f"length over couplers ({self.length:g} m)")
        return None


def _gear_dir():
    """The shipped gear presets, ``ltdsim/data/gears/*.toml`` (package data, found through
    importlib.resources so that an installed wheel finds them as a source tree does)."""
    return resources.files("ltdsim.data").joinpath("gears")


def gear_presets() -> list[str]:
    """Names of the shipped draft-gear parameter sets (``preset = NAME`` in a coupler)."""
    folder = _gear_dir()
    if not folder.is_dir():  # an install without its package data: no presets, no traceback
        return []
    return sorted(p.name.removesuffix(".toml") for p in folder.iterdir()
                  if p.name.endswith(".toml") and p.is_file())


def load_gear_preset(name: str) -> dict:
    """The keys of gear parameter set ``name`` (see :func:`gear_presets`)."""
    names = _preset_names()
    if not isinstance(name, str) or name not in names:
        raise ValueError(f"unknown preset {name!r}; available: "
                         f"{', '.join(names) or 'none (this install lacks its package data)'}")
    return copy.deepcopy(_read_preset(name))


@functools.lru_cache(maxsize=1)
def _preset_names() -> tuple[str, ...]:
    return tuple(gear_presets())


@functools.cache
def _read_preset(name: str) -> dict:
    # read once per process: a train of 200 preset gears validates each coupler
    return tomllib.loads(_gear_dir().joinpath(f"{name}.toml").read_text(encoding="utf-8"))


class STable(_Strict):
    """Lubrication factor S(impact speed, deflection) as a 2-D table (paper Eq. 2)."""

    velocity: list[float] = Field(min_length=1, description="impact speeds, m/s")
    deflection: list[float] = Field(min_length=1, description="gear deflections, m")
    values: list[list[float]] = Field(min_length=1, description="S, one row per speed, -")

    @model_validator(mode="after")
    def _shape(self):
        for name in ("velocity", "deflection"):
            xs = getattr(self, name)
            if any(b <= a for a, b in zip(xs, xs[1:])):
                raise ValueError(f"{name} must be strictly increasing, got {xs}")
        if len(self.values) != len(self.velocity) or any(
                len(r) != len(self.deflection) for r in self.values):
            raise ValueError(f"values must be {len(self.velocity)} rows (speeds) of "
                             f"{len(self.deflection)} numbers (deflections)")
        if any(not 0.0 <= v <= 10.0 for r in self.values for v in r):
            raise ValueError("S values must lie in [0, 10]")
        return self


#: the model a coupler without a ``model`` key (and without a preset naming one) takes
DEFAULT_COUPLER_MODEL = "simplified"


class _CouplerBase(_Strict):
    """Keys every coupler model has: its preset, model, slack and solid closure.

    Each model is one class below, a member of the discriminated union :data:`Coupler`
    on ``model``: a key of another model is refused. Keys a model needs but that have
    no default are checked together (one line naming all missing keys).
    """

    #: keys the model needs (None is not allowed once presets are merged)
    _required: typing.ClassVar[tuple[str, ...]] = ()

    preset: str | None = Field(None, description="named gear parameter set to start from "
                                                 "(its keys under the ones given)")
    model: str = Field(DEFAULT_COUPLER_MODEL, description="coupler model")
    slack: float = Field(0.0, ge=0.0, le=1.0, description="total free play of the coupling, m")
    # a coupling between two vehicles has a draft gear in each vehicle's end: with 2, the
    # model's parameters describe one gear and two alike act in series (same force, each
    # deflects by half the coupling's deflection beyond the slack); with 1 they describe
    # the whole coupling (coupler_models.COMMON_COLUMNS, docs/model.md#one-coupling)
    gears: int = Field(1, ge=1, le=2, description="gears in series in the coupling, each "
                                                  "described by the model's keys, -")
    # gear travel beyond the slack to solid closure (optional for linear and simplified,
    # required for friction_wedge, table: its last point) and the solid gear's stiffness
    # (physics.couplers.solid_closure)
    travel: float | None = Field(None, gt=0.0, le=1.0,
                                 description="gear travel beyond the slack to solid "
                                             "closure, m (none: never closes)")
    solid_stiffness: float = Field(1.0e9, gt=0.0, le=1e12,
                                   description="stiffness of the gear closed solid, beyond "
                                               "travel, N/m")

    @model_validator(mode="after")
    def _complete(self):
        missing = [k for k in self._required if getattr(self, k) is None]
        missing += self._missing_extra()
        if missing:
            raise ValueError(f"model {self.model!r} needs {', '.join(missing)}")
        self._check()
        return self

    def _missing_extra(self) -> list[str]:
        return []

    def _check(self) -> None:
        """Model-specific consistency checks (ValueError with one line)."""


#: the keys every coupler model has, besides preset and model (an override that
#: changes the model keeps the default's values of these)
SHARED_COUPLER_KEYS = tuple(k for k in _CouplerBase.model_fields if k not in ("preset",
                                                                              "model"))


class LinearCoupler(_CouplerBase):
    """Linear spring-damper coupler with slack (physics.couplers.coupler_linear)."""

    _required = ("stiffness",)

    model: Literal["linear"] = Field("linear", description="coupler model")
    stiffness: float | None = Field(None, gt=0.0, le=1e12, description="spring stiffness, N/m")
    damping: float = Field(0.0, ge=0.0, le=1e9, description="viscous damping, N s/m")


class SimplifiedCoupler(_CouplerBase):
    """The study's simplified nonlinear coupler (paper Eq. 9,
    physics.couplers.coupler_simplified)."""

    _required = ("k1", "k3", "v_c")

    model: Literal["simplified"] = Field("simplified", description="coupler model")
    preload: float = Field(0.0, ge=0.0, le=1e7, description="gear preload P, N")
    damping: float = Field(0.0, ge=0.0, le=1e9, description="damping b, N s/m")
    k1: float | None = Field(None, gt=0.0, le=1e12, description="recoil (buff) stiffness, N/m")
    k2: float = Field(0.0, ge=0.0, le=1e12, description="nonlinear (draft) stiffness, N/m")
    k3: float | None = Field(None, gt=0.0, le=1e12, description="linear (draft) stiffness, N/m")
    # how the nonlinear stiffness k2 fades (docs/model.md#simplified-coupler): with the
    # gear's deflection, as Eq. 9 prints it (passive), or with its deflection rate (an
    # earlier reading, which returns energy when a gear loads fast and unloads slowly)
    fade: Literal["deflection", "rate"] = Field(
        "deflection", description="what k2 fades with: the gear deflection "
                                  "(exp(-e/v_c), v_c in m) or its rate (exp(-|de/dt|/v_c), "
                                  "v_c in m/s)")
    v_c: float | None = Field(None, gt=0.0, le=1e3, description="fade constant of k2: a "
                                                               "deflection, m, or with fade "
                                                               "= rate a critical velocity, "
                                                               "m/s")


class _HystereticGear(_CouplerBase):
    """Keys every hysteretic draft gear has (physics.draftgear)."""

    k_locked: float | None = Field(None, gt=0.0, le=1e11,
                                   description="stiffness of the locked gear, N/m")
    # the time the gear takes to pass between sliding on a curve and locked (the internal
    # force's relaxation onto its curve): a property of the gear, the same for every
    # solver and step; 0.4 ms, the time scale of the gear's own parts (docs/draftgear.md)
    tracking_time: float = Field(4e-4, gt=0.0, le=1.0,
                                 description="time constant of the internal states, s")

    @property
    def damping(self) -> float:
        """Viscous damping, N s/m: none (a friction gear dissipates through its
        hysteresis)."""
        return 0.0


class FrictionWedgeGear(_HystereticGear):
    """The study's four-stage friction-wedge draft gear (paper Eq. 1-7)."""

    _required = ("alpha_deg", "beta_deg", "gamma_deg", "h1", "h2", "h3", "k_locked", "k_m",
                 "k_r", "x_m0", "x_r0", "plate_gap", "travel")

    model: Literal["friction_wedge"] = Field("friction_wedge", description="coupler model")
    alpha_deg: float | None = Field(None, gt=0.0, lt=89.0, description="wedge angle alpha, deg")
    beta_deg: float | None = Field(None, ge=0.0, lt=89.0, description="wedge angle beta, deg")
    gamma_deg: float | None = Field(None, gt=0.0, lt=89.0, description="wedge angle gamma, deg")
    h1: float | None = Field(None, ge=0.0, le=1.0, description="kinetic friction coefficient, -")
    h2: float | None = Field(None, ge=0.0, le=1.0,
                             description="static excess of the friction coefficient, -")
    h3: float | None = Field(None, ge=0.0, le=100.0, description="friction decay with speed, s/m")
    S: float | None = Field(None, ge=0.0, le=10.0, description="lubrication factor, -")
    S_table: STable | None = Field(None, description="lubrication factor S(impact speed m/s, "
                                                     "deflection m), - (instead of S)")
    k_m: float | None = Field(None, gt=0.0, le=1e10, description="main spring stiffness, N/m")
    k_r: float | None = Field(None, ge=0.0, le=1e10, description="release spring stiffness, N/m")
    x_m0: float | None = Field(None, ge=0.0, le=1.0, description="main spring pre-deflection, m")
    x_r0: float | None = Field(None, ge=0.0, le=1.0,
                               description="release spring pre-deflection, m")
    plate_gap: float | None = Field(None, ge=0.0, le=1.0,
                                    description="travel before the movable plates engage, m")
    plate_backlash: float = Field(0.003, ge=0.0, le=1.0,
                                  description="backlash of the movable plates, m")

    def _missing_extra(self) -> list[str]:
        return ["S or S_table"] if self.S is None and self.S_table is None else []

    def _check(self) -> None:
        if self.alpha_deg + self.gamma_deg >= 85.0:
            raise ValueError("alpha_deg + gamma_deg must stay below 85 deg (the wedge locks)")
        # psi_1's denominator must stay positive at the largest friction coefficient
        mu = self.h1 + self.h2
        a, g = math.radians(self.alpha_deg), math.radians(self.gamma_deg)
        if math.tan(a + math.atan(mu)) * math.tan(g + math.atan(mu)) >= 1.0:
            raise ValueError("wedge angles too steep for the friction: the gear would lock "
                             "(tan(alpha + atan mu) tan(gamma + atan mu) >= 1)")
        if self.k_m * self.x_m0 < self.k_r * self.x_r0:
            raise ValueError("k_m x_m0 must be at least k_r x_r0, or unloading would lie "
                             "above loading")


class TableGear(_HystereticGear):
    """A hysteretic gear given by measured loading and unloading curves."""

    _required = ("loading", "unloading", "k_locked")

    model: Literal["table"] = Field("table", description="coupler model")
    loading: Points | None = Field(None, description="[deflection m, force N] loading curve")
    unloading: Points | None = Field(None,
                                     description="[deflection m, force N] unloading curve")

    def _check(self) -> None:
        for name in ("loading", "unloading"):
            pts = getattr(self, name)
            _check_table(pts, f"{name} deflections, m", lambda f: 0.0 <= f <= 1e8,
                         "forces in [0, 1e8] N")
            if pts[0][0] != 0.0:
                raise ValueError(f"{name} must start at deflection 0")
        # a gear resists more the further it is closed: a loading curve never falls
        for (x0, f0), (x1, f1) in zip(self.loading, self.loading[1:]):
            if f1 < f0:
                raise ValueError(f"loading: the force must not decrease with deflection "
                                 f"(a loading curve is monotone non-decreasing); it falls "
                                 f"from {f0:g} N at {x0:g} m to {f1:g} N at {x1:g} m")
        xs = sorted({p[0] for p in self.loading} | {p[0] for p in self.unloading})
        import numpy as np

        fl = np.interp(xs, *zip(*self.loading))
        fu = np.interp(xs, *zip(*self.unloading))
        if np.any(fu > fl + 1e-9 * fl.max()):
            raise ValueError("the unloading curve must not lie above the loading curve")


class PolymerGear(_HystereticGear):
    """Polymer (elastomer) draft gear: a static curve stiffened by a rate factor of the
    closing speed, with hysteresis (physics.polymer, docs/draftgear.md)."""

    _required = ("preload", "initial_stiffness", "force_at_travel", "travel", "exponent",
                 "return_ratio", "gain_loading", "gain_unloading", "rate_speed", "k_locked")

    model: Literal["polymer"] = Field("polymer", description="coupler model")
    preload: float | None = Field(None, ge=0.0, le=1e7,
                                  description="static force at zero deflection, N")
    initial_stiffness: float | None = Field(None, ge=0.0, le=1e10,
                                            description="static slope at zero deflection, N/m")
    force_at_travel: float | None = Field(None, gt=0.0, le=1e8,
                                          description="static loading force at the travel, N")
    exponent: float | None = Field(None, ge=1.0, le=20.0,
                                   description="stiffening exponent of the static curve, -")
    return_ratio: float | None = Field(None, gt=0.0, le=1.0,
                                       description="static unloading / loading force, -")
    gain_loading: float | None = Field(None, ge=0.0, le=100.0,
                                       description="relative rise of the loading curve at "
                                                   "high closing speed, -")
    gain_unloading: float | None = Field(None, ge=0.0, le=100.0,
                                         description="relative rise of the unloading curve "
                                                     "at high closing speed, -")
    rate_speed: float | None = Field(None, gt=0.0, le=100.0,
                                     description="closing-speed scale of the rise, m/s")

    def _check(self) -> None:
        if self.force_at_travel < self.preload + self.initial_stiffness * self.travel:
            raise ValueError("force_at_travel must be at least preload + initial_stiffness "
                             "* travel (the static curve never falls)")
        if self.return_ratio * self.gain_unloading > self.gain_loading:
            raise ValueError("return_ratio * gain_unloading must not exceed gain_loading, "
                             "or unloading would lie above loading at speed")


#: the coupler models' schema classes by ``model`` name (the order of
#: ``ltdsim.engine.couplers.MODEL_NAMES``)
COUPLER_CLASSES: dict[str, type[_CouplerBase]] = {
    "linear": LinearCoupler, "simplified": SimplifiedCoupler,
    "friction_wedge": FrictionWedgeGear, "table": TableGear, "polymer": PolymerGear}


class _UnknownCoupler(_Strict):
    """Stand-in member of the coupler union for an unknown ``model``: its only check
    refuses the name, listing the models (as a Literal does)."""

    model_config = ConfigDict(extra="ignore", strict=True)
    model: Literal[tuple(COUPLER_CLASSES)]  # type: ignore[valid-type]


#: union tags (bracketed so that error locations leave them out, see _is_internal)
_TAGS = {f"[{name}]": cls for name, cls in COUPLER_CLASSES.items()}
_UNKNOWN_TAG = "[unknown model]"


def _merge_preset(data):
    """``preset = NAME``: the preset's keys under the ones given (None values dropped)."""
    if isinstance(data, dict) and data.get("preset"):
        base = load_gear_preset(data["preset"])
        base.update({k: v for k, v in data.items() if v is not None})
        return base
    return data


def _coupler_tag(data) -> str:
    model = data.get("model", DEFAULT_COUPLER_MODEL) if isinstance(data, dict) else \
        getattr(data, "model", None)
    tag = f"[{model}]" if isinstance(model, str) else None
    return tag if tag in _TAGS else _UNKNOWN_TAG


#: parameters of one coupler (draft gear and slack): one of the model classes, chosen by
#: ``model`` (default "simplified"), after merging a ``preset``
Coupler = Annotated[
    Union[tuple(Annotated[cls, Tag(tag)] for tag, cls in _TAGS.items())
          + (Annotated[_UnknownCoupler, Tag(_UNKNOWN_TAG)],)],  # type: ignore[valid-type]
    Discriminator(_coupler_tag),
    BeforeValidator(_merge_preset),
]
_COUPLER_ADAPTER = TypeAdapter(Coupler)


def CouplerParams(**keys) -> _CouplerBase:  # noqa: N802 (reads as the class it was)
    """Validate the keys of one coupler (as in ``[couplers.default]``) into its model's
    class; raises pydantic's ``ValidationError``."""
    return _COUPLER_ADAPTER.validate_python(keys)


def _override_fields() -> dict:
    """Every key of every coupler model, optional (default None), same ranges: an override
    may change the model, so it accepts any model's keys; the merged coupler is then
    validated against its model's class."""
    fields: dict = {}
    for cls in COUPLER_CLASSES.values():
        for key, f in cls.model_fields.items():
            if key in fields:
                continue
            kind = f.annotation
            if key == "model":
                kind = Literal[tuple(COUPLER_CLASSES)]  # type: ignore[valid-type]
            kind = Optional[kind]  # noqa: UP007 (needed for Annotated metadata)
            if f.metadata:
                kind = Annotated[kind, *f.metadata]
            fields[key] = (kind, Field(None, description=f.description))
    return fields


CouplerOverride = create_model(
    "CouplerOverride", __base__=_Strict,
    __doc__="Keys of coupler ``index`` that differ from the default.",
    index=(int, Field(ge=0, description="coupler index, 0 joins vehicles 0 and 1, -")),
    **_override_fields())


class Couplers(_Strict):
    """``[couplers.default]`` and its ``[[couplers.override]]`` tables.

    An override changes the keys it gives for coupler ``index``. An override with a
    ``model`` other than the default's keeps only the default's keys that every model
    shares (:data:`SHARED_COUPLER_KEYS`: slack, gears, travel, solid stiffness) and takes the
    new model's own keys from itself, so the default's keys of its own model never
    reach a coupler of another model. An override that names a ``preset`` describes
    another gear: it keeps only the default's ``slack`` and ``gears`` (the coupling's free
    play and how many gears it holds, not the gear's own keys) and takes every other key
    from itself and its preset.
    """

    default: Coupler
    override: list[CouplerOverride] = []


class Track(_Strict):
    """Track as piecewise-constant functions of position along the line."""

    gradient: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                             description="[start position m, grade -] pieces, grade = rise/run, "
                                         "+ uphill in the direction of travel; starts strictly "
                                         "increasing, grades in [-0.1, 0.1]; the first piece "
                                         "also covers everything before it")
    curve: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                          description="[start position m, radius m] pieces; starts strictly "
                                      "increasing, radius 0 (straight) or 20 to 1e6, + "
                                      "turning left, - turning right (the side matters to "
                                      "the curving indicators only)")
    transitions: Points = Field([], description="[position m, length m] clothoids: the "
                                                "curvature step of `curve` at that position "
                                                "becomes a ramp, linear in distance, from "
                                                "there over the length (each position a "
                                                "break of `curve`; the ramp ends before the "
                                                "next break)")
    cant: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                         description="[position m, cant m] height of the outer rail over the "
                                     "inner, linear between the points and constant beyond "
                                     "them, 0 to 0.2 m; it leans towards the centre of the "
                                     "curve at each place")
    profile_file: str | None = Field(None, description="CSV of chainage m, curvature 1/m "
                                                       "(+ left), cant m, one point a line, "
                                                       "linear between points; replaces "
                                                       "curve, transitions and cant (a path "
                                                       "relative to the scenario file)")
    profile: list[Triple] = Field([], description="[chainage m, curvature 1/m, cant m] "
                                                  "points as profile_file gives them (filled "
                                                  "from it at load time)")
    rail_spacing: float = Field(1.5, ge=0.9, le=2.0,
                                description="distance between the wheel-rail contact points "
                                            "of a wheelset (1.5 for standard gauge), m")
    curve_h: float = Field(540.0, ge=0.0, le=5000.0,
                           description="curve resistance constant h: h / R newtons per "
                                       "kilonewton of weight, R the radius in m, N m/kN")
    gravity: float = Field(9.81, ge=9.7, le=9.9, description="gravitational acceleration, "
                                                             "m/s^2")

    @field_validator("gradient")
    @classmethod
    def _grades(cls, v):
        return _check_table(v, "start positions, m", lambda g: abs(g) <= 0.1, "in [-0.1, 0.1] (rise/run)")

    @field_validator("curve")
    @classmethod
    def _curves(cls, v):
        return _check_table(v, "start positions, m", lambda r: r == 0.0 or 20.0 <= abs(r) <= 1e6,
                            "0 (straight) or radii of 20-1e6 m")

    @field_validator("cant")
    @classmethod
    def _cants(cls, v):
        return _check_table(v, "positions, m", lambda h: 0.0 <= h <= 0.2, "in [0, 0.2] m")

    @field_validator("profile")
    @classmethod
    def _profile(cls, v):
        xs = [p[0] for p in v]
        if any(b <= a for a, b in zip(xs, xs[1:])):
            raise ValueError("chainages must be strictly increasing")
        bad = [p[1] for p in v if abs(p[1]) > 0.05]
        if bad:
            raise ValueError(f"curvatures must be within +-0.05 1/m (radius >= 20 m), got "
                             f"{bad[:3]}")
        bad = [p[2] for p in v if not 0.0 <= p[2] <= 0.2]
        if bad:
            raise ValueError(f"cant must be in [0, 0.2] m, got {bad[:3]}")
        return v

    @model_validator(mode="after")
    def _alignment(self):
        breaks = [p[0] for p in self.curve]
        ends = []
        for k, (pos, length) in enumerate(self.transitions):
            if pos not in breaks:
                raise ValueError(f"transitions.{k}: position {pos:g} m is not a break of "
                                 f"curve (its starts: {breaks})")
            if not 0.0 < length <= 2000.0:
                raise ValueError(f"transitions.{k}: length must be in (0, 2000] m, got "
                                 f"{length:g}")
            nxt = [b for b in breaks if b > pos]
            if nxt and pos + length > nxt[0]:
                raise ValueError(f"transitions.{k}: the ramp from {pos:g} m over {length:g} m "
                                 f"runs past the next break of curve at {nxt[0]:g} m")
            ends.append(pos)
        if len(set(ends)) != len(ends):
            raise ValueError("transitions: two transitions at one break")
        if self.profile_file is not None and not self.profile:
            raise ValueError(f"profile_file ({self.profile_file!r}) is read when the scenario "
                             "file is loaded (ltdsim.load_scenario); give it in the file, or "
                             "the points as track.profile")
        if self.profile and (self.transitions or self.cant != [(0.0, 0.0)]
                             or self.curve != [(0.0, 0.0)]):
            raise ValueError("profile (profile_file) replaces curve, transitions and cant: "
                             "leave those out")
        return self

    def resistance_curve(self) -> Points:
        """The ``curve`` table the kernel's curve resistance reads: ``curve`` itself when
        the alignment has no transitions or profile, otherwise the alignment's curvature
        averaged over steps of at most 5 m (the ramps keep their integral of curvature,
        so the curve resistance summed over them is that of the alignment), m and m."""
        if not self.transitions and not self.profile:
            return self.curve
        from ltdsim.results.curving import alignment_of

        return alignment_of(self).step_table(5.0)


class Curving(_Strict):
    """Curving-safety indicators computed after the run (ltdsim.results.curving): coupler angles,
    lateral coupler forces, wheel L/V and wheelset lateral forces."""

    flange_angle: float = Field(75.0, gt=45.0, lt=89.0,
                                description="maximum flange contact angle for Nadal's "
                                            "limit, deg")
    flange_friction: float = Field(0.5, ge=0.0, le=1.0,
                                   description="wheel-rail friction at the flange for Nadal's "
                                               "limit, -")
    prudhomme_alpha: float = Field(0.85, gt=0.0, le=1.0,
                                   description="factor of Prud'homme's wheelset lateral-force "
                                               "limit alpha (10 kN + P/3), - (0.85: freight "
                                               "wagons, EN 14363)")
    leading_share: float = Field(1.0, ge=0.5, le=1.0,
                                 description="share of a bogie's lateral force taken by its "
                                             "leading wheelset, - (1: all of it, the bound)")
    coupler_angle_limit: float | None = Field(None, gt=0.0, le=0.5,
                                              description="angle at which the coupler "
                                                          "reaches its stops (reported, not "
                                                          "enforced); none: no stops, rad")


class TractionMotor(BaseModel):
    """The induction drive's motors: a shipped motor preset (data/motors/*.toml) with any
    of its keys overridden here, and how many a locomotive carries (one per driven
    wheelset)."""

    model_config = ConfigDict(extra="allow", allow_inf_nan=False, validate_default=True,
                              strict=True)

    preset: str = Field("study-850kw", description="shipped motor parameter set "
                                                   "(data/motors/*.toml); other keys of "
                                                   "this table replace the preset's")
    per_locomotive: int = Field(6, ge=1, le=12, description="motors per locomotive, each "
                                                            "driving one wheelset, -")

    @model_validator(mode="after")
    def _motor(self):
        self.motor()  # raises a one-line ValueError for an unknown preset or a bad key
        return self

    def motor(self):
        """The :class:`ltdsim.scenario.motor.Motor` of the preset with the overrides."""
        from ltdsim.scenario.motor import Motor, load_motor, motor_presets

        if self.preset not in motor_presets():
            raise ValueError(f"unknown motor preset {self.preset!r}; available: "
                             f"{', '.join(motor_presets()) or 'none'}")
        base = load_motor(self.preset).model_dump()
        extra = dict(self.model_extra or {})
        unknown = sorted(set(extra) - set(base))
        if unknown:
            raise ValueError(f"unknown key {unknown[0]!r}; allowed: preset, per_locomotive, "
                             f"{', '.join(base)}")
        try:
            return Motor(**{**base, **extra})
        except ValidationError as exc:
            err = exc.errors()[0]
            key = ".".join(str(x) for x in err["loc"]) or "(table)"
            raise ValueError(f"{key}: {err['msg']}") from None


class Traction(_Strict):
    """Traction curve and acceleration limits of the driving locomotives (together)."""

    max_force: float = Field(gt=0.0, le=1e8, description="force limit F_max, N")
    max_power: float = Field(gt=0.0, le=1e9,
                             description="power limit P_max (force at most P_max / v), W")
    adhesion_mass: float = Field(gt=0.0, le=1e8,
                                 description="mass on the driven wheels, for the "
                                             "Curtius-Kniffler adhesion limit, kg")
    max_accel: float = Field(0.976, gt=0.0, le=10.0,
                             description="upper limit of the speed controller's demand as an "
                                         "acceleration of the whole train (the demanded force "
                                         "less the feed-forward stays within max_accel x "
                                         "train mass), m/s^2")
    max_decel: float = Field(0.976, gt=0.0, le=10.0,
                             description="lower limit of the demand, as a positive number, "
                                         "the same way, m/s^2")
    feedforward: bool = Field(True, description="add the train's total running resistance "
                                                "to the demanded force")
    time_constant: float = Field(0.0, ge=0.0, le=60.0,
                                 description="motor and inverter response: the force follows "
                                             "the curve-limited demand through a first-order "
                                             "lag, s (0 = at once)")
    jerk_limit: float = Field(0.0, ge=0.0, le=100.0,
                              description="caps the lagged force's rate at jerk_limit x train "
                                          "mass x consist share (its max_force over the sum); "
                                          "needs time_constant > 0, m/s^3 (0 = none)")
    dynamic_brake_fade: float = Field(
        0.0, ge=0.0, le=30.0,
        description="speed below which dynamic braking fades linearly to 0, as motors give "
                    "no braking at standstill, m/s (0 = the study's mirrored curve down to 0)")
    drive: Literal["curve", "induction"] = Field(
        "curve", description="what turns the demand into force: the traction curve and its "
                             "lag (curve), or induction motors under field-oriented control "
                             "driving wheelsets through the wheel-rail creep law (induction; "
                             "docs/induction-drive.md, docs/creep.md); per consist in "
                             "[[locomotives]]")
    motor: TractionMotor = Field(default_factory=lambda: TractionMotor(),
                                 description="the induction drive's motors (drive = "
                                             "\"induction\")")
    creep: Creep = Field(default_factory=lambda: Creep(),
                         description="the induction drive's wheel-rail contact, wheelsets "
                                     "and slip control (drive = \"induction\")")

    @model_validator(mode="after")
    def _lag(self):
        if self.jerk_limit > 0.0 and self.time_constant == 0.0:
            raise ValueError("jerk_limit acts on the lagged force: give time_constant > 0")
        return self


def _check_notches(v):
    if v is None:
        return v
    return _check_table(v, "times, s", lambda q: q == int(q) and -8 <= q <= 8,
                        "whole notches in [-8, 8] (negative = dynamic brake)")


class Locomotive(_Strict):
    """A locomotive consist: powered vehicles with their own traction curve and, under
    distributed power, their own commands and brake-control point. Keys left out take
    the ``[traction]`` value."""

    name: str = Field(min_length=1,
                      description="label (locomotive coordinate of locomotive_force)")
    vehicles: list[Annotated[int, Field(ge=0)]] = Field(
        min_length=1, description="indices of its powered vehicles after count expansion "
                                  "(lead = 0), each in one consist")
    max_force: float | None = Field(None, gt=0.0, le=1e8,
                                    description="force limit (none: [traction]), N")
    max_power: float | None = Field(None, gt=0.0, le=1e9,
                                    description="power limit (none: [traction]), W")
    adhesion_mass: float | None = Field(None, gt=0.0, le=1e8,
                                        description="mass on the driven wheels (none: "
                                                    "[traction]), kg")
    time_constant: float | None = Field(None, ge=0.0, le=60.0,
                                        description="force lag (none: [traction]), s")
    jerk_limit: float | None = Field(None, ge=0.0, le=100.0,
                                     description="force rate cap (none: [traction]), m/s^3")
    notch_profile: Points | None = Field(
        None, description="[t s, notch -] its own throttle, held until the next point "
                          "(independent distributed power); whole notches in [-8, 8]; not on "
                          "the lead consist; none: the consist follows the driver")
    drive: Literal["curve", "induction"] | None = Field(
        None, description="its drive (none: [traction] drive)")
    brake_control: bool = Field(True, description="also a brake-control point: under "
                                                  "distributed power the remote units vent "
                                                  "and charge the brake pipe with the lead")

    @field_validator("notch_profile")
    @classmethod
    def _notch(cls, v):
        return _check_notches(v)



def _brake_presets() -> list[str]:
    """Names of the shipped valve presets of the fluid brake (``data/brakes/*.toml``)."""
    from ltdsim.physics.air.brakevalves import brake_presets

    return brake_presets()


@functools.cache
def _read_brake_preset(name: str) -> dict:
    from ltdsim.physics.air.brakevalves import load_brake_preset

    return load_brake_preset(name)


def valve_tables(fluid: "FluidBrake") -> tuple[dict, dict]:
    """The ``[control_valve]`` and ``[driver_valve]`` tables of ``brake.fluid.valve``: a
    preset's, or an inline table's keys over its ``preset`` (if any); each checked by
    the valves' row builders. Raises ``ValueError`` in one line naming the key."""
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
        names = _brake_presets()
        if not isinstance(name, str) or name not in names:
            raise ValueError(f"brake.fluid.valve: unknown preset {name!r}; available: "
                             f"{', '.join(names) or 'none (this install lacks its package data)'}")
        base = copy.deepcopy(_read_brake_preset(name))
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
    try:
        control_valve_row(cv)
    except ValueError as exc:
        raise ValueError(f"brake.fluid.valve: {exc}") from None
    try:
        driver_valve_row(dv)
    except ValueError as exc:
        raise ValueError(f"brake.fluid.valve: {exc}") from None
    return cv, dv


#: handle positions of ``driver.brake_commands``
HANDLES = ("release", "minimum", "full", "emergency")


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
                                 f"{', '.join(_brake_presets()) or 'none installed'}; or a "
                                 "table)")
            valve_tables(self.fluid)  # names and keys checked here (one line)
        return self


class PID(_Strict):
    """Discrete PID in parallel form; output = demanded acceleration."""

    kp: float = Field(ge=0.0, le=1e6,
                      description="proportional gain (m/s^2 of demand per m/s of error), 1/s")
    ki: float = Field(0.0, ge=0.0, le=1e6, description="integral gain, 1/s^2")
    kd: float = Field(0.0, ge=0.0, le=1e6, description="derivative gain, -")
    n: float = Field(100.0, gt=0.0, le=1e6, description="derivative filter coefficient, 1/s")
    ts: float = Field(1e-4, gt=0.0, le=10.0,
                      description="sample time, a whole multiple of solver.dt, s")
    integrator: Literal["forward_euler", "backward_euler"] = Field(
        "forward_euler", description="discretisation of the integrator: Ts/(z-1) "
                                     "(forward_euler) or Ts z/(z-1) (backward_euler)")
    filter: Literal["forward_euler", "backward_euler"] = Field(
        "backward_euler", description="discretisation of the derivative filter")
    anti_windup: bool = Field(False, description="conditional integration: the integrator "
                                                 "holds while the demand is clipped or the "
                                                 "drives are at their traction curves, in the "
                                                 "direction the error pushes (false: the "
                                                 "study's Simulink block)")
    acceleration_of: Literal["train", "locomotive"] = Field(
        "train", description="whose acceleration the output demands: the force is the "
                             "output times the train's or the lead locomotive's mass")


#: profile points ``[t, v]``, or ``[t, v, jerk_time]`` to round the corner at that point
SpeedPoints = list[Union[Pair, Triple]]


class Driver(_Strict):
    """The driver's commands: speed, force or notch control, and air-brake commands."""

    mode: Literal["speed", "force", "notch"] = Field(
        "speed", description="speed: the PID tracks speed_profile; force: force_profile is "
                             "the demanded force; notch: notch_profile")
    speed_profile: SpeedPoints = Field(
        default_factory=lambda: [(0.0, 0.0)],
        description="[t s, v m/s] or [t s, v m/s, jerk time s] reference speed, linear "
                    "between points, constant after the last; times strictly increasing, "
                    "speeds in [0, 150]; a jerk time (interior points, in [0, 600], "
                    "neighbouring roundings not overlapping) rounds the corner at that point: "
                    "over that time, centred on it, the acceleration changes linearly")
    pid: PID | None = Field(None, description="the speed controller, required in speed "
                                              "mode: the study's discrete PID in parallel "
                                              "form, whose output is a demanded acceleration")
    force_profile: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                                  description="[t s, force N] demanded traction (+) or dynamic "
                                              "brake (-), linear between points; times "
                                              "strictly increasing, forces in [-1e8, 1e8]")
    notch_profile: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                                  description="[t s, notch -] throttle notch, held until the "
                                              "next point; whole notches in [-8, 8]; notch q "
                                              "demands q/8 of each consist's traction curve "
                                              "(negative: dynamic brake)")
    brake_profile: Points | None = Field(
        None, description="[t s, brake level -] air-brake commands at given times; levels in "
                          "[0, 1] (1 = full application, 0 = release); needs a braked vehicle")
    brake_positions: Points | None = Field(
        None, description="[lead position m, brake level -] commands issued when the lead "
                          "vehicle's centre passes the position; levels in [0, 1]")
    brake_controller: bool = Field(False, description="speed mode: the controller applies "
                                                      "the air brake when its demanded "
                                                      "braking exceeds what the dynamic "
                                                      "brakes give, in brake.level_step steps")
    brake_commands: list[BrakeCommand] | None = Field(
        None, description="[[driver.brake_commands]] tables: {time s or position m, handle "
                          "or reduction Pa}, beside brake_profile and brake_positions (a "
                          "level L there is a service reduction of L x the full-service "
                          "one in the fluid brake); times strictly increasing, positions "
                          "strictly increasing")

    @field_validator("speed_profile")
    @classmethod
    def _speeds(cls, v):
        _check_table(v, "times, s", lambda s: 0.0 <= s <= 150.0, "in [0, 150] m/s")
        blend = [p[2] if len(p) == 3 else 0.0 for p in v]
        for k, b in enumerate(blend):
            if not 0.0 <= b <= 600.0:
                raise ValueError(f"point {k}: the jerk time (third number) must lie in "
                                 f"[0, 600] s, got {b}")
            if b > 0.0 and k in (0, len(v) - 1):
                raise ValueError(f"point {k}: the first and last points cannot round a "
                                 "corner (give a jerk time on interior points only)")
        for k in range(len(v) - 1):
            gap = v[k + 1][0] - v[k][0]
            if 0.5 * (blend[k] + blend[k + 1]) > gap + 1e-9:
                raise ValueError(f"points {k} and {k + 1}: their rounded corners overlap "
                                 f"(half jerk times {0.5 * blend[k]:g} s + "
                                 f"{0.5 * blend[k + 1]:g} s exceed the {gap:g} s between them)")
        return v

    @field_validator("force_profile")
    @classmethod
    def _forces(cls, v):
        return _check_table(v, "times, s", lambda f: abs(f) <= 1e8, "in [-1e8, 1e8] N")

    @field_validator("notch_profile")
    @classmethod
    def _notch(cls, v):
        return _check_notches(v)

    @field_validator("brake_profile", "brake_positions")
    @classmethod
    def _levels(cls, v):
        if v is None:
            return v
        return _check_table(v, "times or positions", lambda q: 0.0 <= q <= 1.0,
                            "brake levels in [0, 1]")

    @model_validator(mode="after")
    def _pid_needed(self):
        if self.mode == "speed" and self.pid is None:
            raise ValueError("mode 'speed' needs a [driver.pid] table (kp, ki, kd, n, ts)")
        if self.brake_controller and self.mode != "speed":
            raise ValueError("brake_controller needs mode = 'speed'")
        return self

    @field_validator("brake_commands")
    @classmethod
    def _commands(cls, v):
        if v is None:
            return v
        for what in ("time", "position"):
            xs = [getattr(c, what) for c in v if getattr(c, what) is not None]
            if any(b <= a for a, b in zip(xs, xs[1:])):
                raise ValueError(f"the commands' {what}s must be strictly increasing, got {xs}")
        return v

    @property
    def brakes_commanded(self) -> bool:
        return bool(self.brake_profile or self.brake_positions or self.brake_controller
                    or self.brake_commands)


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
                    text = "; ".join(m for _, m in _problems(exc))
                    raise ValueError(f"coupler {i + 1} (index {i}; default merged with "
                                     f"overrides): {text}") from None
        if self.solver.stability_check and not self.solver.adaptive:
            from ltdsim.engine.preflight import refusal, step_limit

            lim = step_limit(self, merged)
            if lim.share > 1.0:
                raise ValueError(refusal(lim))
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
                if self.vehicles[i].weight_mass * 9.81 / (2 * axles) > 2.5e5:
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
                # slack and how many gears it holds) carry over
                params = {"slack": params["slack"], "gears": params["gears"]}
            elif changed.get("model", params["model"]) != params["model"]:
                # another model: the keys every model shares carry over, not the old
                # model's own
                params = {k: params[k] for k in SHARED_COUPLER_KEYS}
            params.update(changed)
        return _COUPLER_ADAPTER.validate_python(params)

    @classmethod
    def from_dict(cls, data: dict, source: str = "<dict>") -> "Scenario":
        """Validate a plain dictionary (as read from TOML) into a Scenario."""
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            raise ScenarioError(source, _problems(exc)) from None

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
        ``"vehicles.3.mass"`` (vehicle 3, lead = 0), ``"driver.pid.kp"``.
        """
        data = self.to_dict()
        for key, value in overrides.items():
            _set_dotted(data, key, value, source)
        return Scenario.from_dict(data, source)

    def with_case(self, name: str, source: str = "scenario") -> "Scenario":
        """Return a copy with the named case's overrides applied."""
        if name not in self.cases:
            avail = ", ".join(sorted(self.cases)) or "none defined"
            raise ScenarioError(source, [("case", f"unknown case {name!r}; available: {avail}")])
        out = self.with_overrides(self.cases[name], source=f"{source} [cases.{name}]")
        return out.model_copy(update={"case": name})


# ---------------------------------------------------------------------- loading
def load_scenario(path: str | Path, case: str | None = None) -> Scenario:
    """Read, validate and return the scenario in TOML file ``path``.

    Every named case under ``[cases.*]`` is validated too, so a bad case key fails at
    load time. With ``case`` given, that case's overrides are applied.

    Raises
    ------
    ScenarioError
        With the file name, the dotted key and the allowed range for each problem.
    """
    path = Path(path)
    data = read_toml(path)
    track = data.get("track")
    if isinstance(track, dict) and isinstance(track.get("profile_file"), str):
        track["profile"] = read_profile(path.parent / track["profile_file"], str(path))
    return scenario_from_data(data, str(path), case)


def read_profile(path: str | Path, source: str) -> list[list[float]]:
    """The rows [chainage m, curvature 1/m, cant m] of the alignment CSV ``path`` (a header
    line of text is skipped), or a :class:`ScenarioError` in one line naming the file
    and the line. ``source`` is the scenario file that names it."""
    import csv

    path = Path(path)
    key = "track.profile_file"
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = "file not found" if isinstance(exc, FileNotFoundError) else f"cannot read: {exc}"
        raise ScenarioError(source, [(key, f"{path}: {why}")]) from None
    rows = []
    for k, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        try:
            vals = [float(c) for c in row]
        except ValueError:
            if not rows and k == 1:
                continue  # header
            raise ScenarioError(source, [(key, f"{path} line {k}: not three numbers "
                                               f"(chainage m, curvature 1/m, cant m): "
                                               f"{','.join(row)!r}")]) from None
        if len(vals) != 3:
            raise ScenarioError(source, [(key, f"{path} line {k}: {len(vals)} columns, "
                                               "expected 3 (chainage m, curvature 1/m, "
                                               "cant m)")])
        rows.append(vals)
    if not rows:
        raise ScenarioError(source, [(key, f"{path}: no data rows")])
    return rows


def scenario_from_data(data: dict, source: str, case: str | None = None) -> Scenario:
    """:func:`load_scenario` of a table already read (``source`` names it in messages):
    the scenario and every case validated, ``case`` applied."""
    scenario = Scenario.from_dict(data, source)
    for name in scenario.cases:
        scenario.with_case(name, source)
    if case is not None:
        scenario = scenario.with_case(case, source)
    return scenario


def read_toml(path: str | Path, what: str = "scenario file") -> dict:
    """The table in TOML file ``path``, or a :class:`ScenarioError` in one line naming the
    file and what is wrong with it: missing, a folder, unreadable (permissions), not UTF-8
    text (a binary file, or a byte of another encoding in a string or comment; the line
    and column are given), or not valid TOML."""
    path = Path(path)
    source = str(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError(source, [("", "file not found")]) from None
    except IsADirectoryError:
        raise ScenarioError(source, [("", f"is a folder, not a {what} (give the .toml "
                                          "file)")]) from None
    except PermissionError:
        raise ScenarioError(source, [("", "cannot read the file: permission denied")]) from None
    except OSError as exc:
        raise ScenarioError(source, [("", f"cannot read the file: "
                                          f"{exc.strerror or exc}")]) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        kind = ("a binary file, not TOML text" if b"\0" in raw[:8192] else
                "not UTF-8 text")
        raise ScenarioError(source, [("", f"{kind}: byte 0x{raw[exc.start]:02x} at line "
                                          f"{line}, column {col} (TOML files are UTF-8: "
                                          "save the file as UTF-8)")]) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        kind = "a binary file, not TOML text" if "\0" in text[:8192] else "not valid TOML"
        raise ScenarioError(source, [("", f"{kind}: {exc}")]) from None


def _set_dotted(data: dict, key: str, value: Any, source: str) -> None:
    parts = key.split(".")
    node: Any = data
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        where = ".".join(parts[: depth + 1])
        if isinstance(node, list):
            if not part.lstrip("-").isdigit():
                raise ScenarioError(source, [(key, f"{where!r}: expected an index 0-{len(node) - 1}")])
            idx = int(part)
            if not 0 <= idx < len(node):
                raise ScenarioError(source, [(key, f"index {idx} out of range 0-{len(node) - 1}")])
            if last:
                node[idx] = value
            else:
                node = node[idx]
        elif isinstance(node, dict):
            if last:
                node[part] = value  # unknown keys are caught by validation
            else:
                if node.get(part) is None:
                    node[part] = {}
                node = node[part]
        else:
            raise ScenarioError(source, [(key, f"{'.'.join(parts[:depth])!r} is a value, not a table")])


# ------------------------------------------------------------------ error text
#: what a value of the wrong TOML type is told (strict types, see ``_Strict``)
_TYPE_MESSAGES = {
    "float_type": "must be a number (a TOML integer or float: not in quotes, not true/false)",
    "int_type": "must be a whole number (a TOML integer such as 4: no decimal point, not in "
                "quotes, not true/false)",
    "bool_type": "must be true or false (a TOML boolean: not in quotes, not 0/1)",
    "string_type": "must be a string (in quotes)",
    "list_type": "must be an array [...]",
    "tuple_type": "must be an array [...]",
    "model_type": "must be a table",
    "dict_type": "must be a table",
}


def _problems(exc: ValidationError) -> list[tuple[str, str]]:
    out: list[tuple[str, str]] = []
    for err in exc.errors():
        loc = [str(p) for p in err["loc"] if not _is_internal(p)]
        if err["type"] == "extra_forbidden":  # the last part is the file's key, as it is
            loc = [str(p) for p in err["loc"][:-1] if not _is_internal(p)] + [
                str(err["loc"][-1])]
        key = ".".join(loc)
        msg = err["msg"]
        if err["type"] in _TYPE_MESSAGES:
            msg = _TYPE_MESSAGES[err["type"]]
        if err["type"] == "extra_forbidden":
            allowed = _allowed_keys(err["loc"][:-1])
            msg = f"unknown key '{loc[-1]}'" + _other_model(err["loc"]) + (
                f"; allowed: {', '.join(allowed)}" if allowed else "")
        elif err["type"] == "missing":
            msg = "required key is missing"
        elif msg.startswith("Value error, "):
            msg = msg[len("Value error, "):]
        if err["type"] in ("finite_number",):
            msg = "must be a finite number (NaN and inf are not allowed)"
        if "input" in err and err["type"] not in ("missing", "extra_forbidden") and not isinstance(
                err["input"], (dict, list)):
            msg += f" (got {_toml(err['input'])})"
        same = [i for i, (k, _) in enumerate(out) if k == key]
        if same:  # the members of a union (e.g. 'karwatzki' or a number): one line
            i = same[0]
            out[i] = (key, f"{out[i][1]}; or {msg}")
        else:
            out.append((key, msg))
    return out


def _other_model(loc) -> str:
    """For a coupler key refused because it belongs to another model: which models it
    belongs to (empty otherwise)."""
    tags = [p for p in loc if p in _TAGS]
    if not tags:
        return ""
    key = loc[-1]
    owners = [name for name, cls in COUPLER_CLASSES.items() if key in cls.model_fields]
    if not owners:
        return ""
    model = tags[-1].strip("[]")
    return (f" for model '{model}' (a key of model {' and '.join(repr(o) for o in owners)}; "
            "set model, or drop the key)")


def _toml(value) -> str:
    """A value as it reads in a TOML file (true, "text", 1.5)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + _printable(value.replace("\\", "\\\\").replace('"', '\\"')) + '"'
    return repr(value)


def _is_internal(part) -> bool:
    # pydantic adds the names of union members / tagged types to locations
    return isinstance(part, str) and ("[" in part or part.startswith("function-"))


def _model_of(annotation):
    """The BaseModel class inside an annotation (through Optional, list, dict)."""
    origin = typing.get_origin(annotation)
    if origin is Annotated:
        return _model_of(typing.get_args(annotation)[0])
    if origin in (Union, types.UnionType, list, dict):
        for arg in typing.get_args(annotation):
            m = _model_of(arg)
            if m is not None:
                return m
        return None
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return None


def _allowed_keys(loc) -> list[str]:
    cls: Any = Scenario
    for part in loc:
        if part in _TAGS:  # the member of the coupler union that was validated
            cls = _TAGS[part]
            continue
        if isinstance(part, int) or _is_internal(part):
            continue
        if cls is None or part not in cls.model_fields:
            return []
        cls = _model_of(cls.model_fields[part].annotation)
    if cls is None:
        return []
    return [k for k in cls.model_fields if k != "case"]
