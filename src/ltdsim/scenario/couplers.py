"""``[couplers]``: one schema class per coupler model (a discriminated union on ``model``),
gear presets merged before validation, the shared keys of a coupling (its slack and
gears), and the per-coupler overrides.
"""

from __future__ import annotations

import math
import typing
from typing import Annotated, Literal, Optional, Union

from pydantic import (
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    TypeAdapter,
    create_model,
    field_validator,
    model_validator,
)

from ltdsim.data import load_preset, preset_names

from ltdsim.scenario._base import Points, _Strict, _check_table


def gear_presets() -> tuple[str, ...]:
    """Names of the shipped draft-gear parameter sets (``preset = NAME`` in a coupler)."""
    return preset_names("gears")


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


def strength_grades() -> tuple[str, ...]:
    """Names of the shipped coupler strength grades (``strength = NAME`` in a coupler:
    ``ltdsim/data/strength``, docs/strength.md)."""
    return preset_names("strength")


#: the limits of a strength grade, N: proof (no permanent deformation above it, the
#: coupling yields) and ultimate (it breaks), in draft (tension) and buff (compression)
STRENGTH_KEYS = ("draft_proof", "draft_ultimate", "buff_proof", "buff_ultimate")


class CouplerStrength(_Strict):
    """Proof and ultimate loads of a coupling (docs/strength.md), N: any of the four,
    at least one. A grade of ``ltdsim/data/strength`` or a table given inline."""

    draft_proof: float | None = Field(None, gt=0.0, le=1e9,
                                      description="proof (yield) load in draft, N")
    draft_ultimate: float | None = Field(None, gt=0.0, le=1e9,
                                         description="ultimate (breaking) load in draft, N")
    buff_proof: float | None = Field(None, gt=0.0, le=1e9,
                                     description="proof (yield) load in buff, N")
    buff_ultimate: float | None = Field(None, gt=0.0, le=1e9,
                                        description="ultimate (breaking) load in buff, N")

    @model_validator(mode="after")
    def _consistent(self):
        if all(getattr(self, k) is None for k in STRENGTH_KEYS):
            raise ValueError(f"a strength table needs at least one of {', '.join(STRENGTH_KEYS)}")
        for way in ("draft", "buff"):
            proof, ultimate = getattr(self, f"{way}_proof"), getattr(self, f"{way}_ultimate")
            if proof is not None and ultimate is not None and proof > ultimate:
                raise ValueError(f"{way}_proof ({proof:g} N) is above {way}_ultimate "
                                 f"({ultimate:g} N): a coupling yields before it breaks")
        return self


def strength_limits(strength: "str | CouplerStrength | None") -> CouplerStrength | None:
    """The limits of a coupler's ``strength`` key: a grade's (by name) or the inline
    table; None without one."""
    if strength is None or isinstance(strength, CouplerStrength):
        return strength
    grade = load_preset("strength", strength)
    return CouplerStrength(**{k: float(grade[k]) for k in STRENGTH_KEYS if k in grade})


#: a coupler's ``strength``: a grade's name or an inline table (told apart by type, so a
#: mistake is reported once, against the form given)
StrengthKey = Annotated[
    Union[Annotated[str, Tag("grade")], Annotated[CouplerStrength, Tag("table")]],
    Discriminator(lambda v: "grade" if isinstance(v, str) else "table")]


def fatigue_curves() -> tuple[str, ...]:
    """Names of the shipped coupler fatigue curves (``fatigue = NAME`` in a coupler:
    ``ltdsim/data/fatigue``, docs/fatigue.md)."""
    return preset_names("fatigue")


#: the keys of a fatigue curve (docs/fatigue.md), the numbers of its S-N law
FATIGUE_KEYS = ("load", "reference_range", "reference_cycles", "slope", "knee_cycles",
                "slope_beyond_knee", "cutoff_cycles", "gate")


class FatigueCurve(_Strict):
    """An S-N curve in coupler force range (docs/fatigue.md): a Basquin law
    N = reference_cycles (reference_range / dF)^slope, optionally with a knee (below it
    no damage, or a second slope down to a cut-off). A curve of ``ltdsim/data/fatigue``
    or a table given inline. No mean-force correction: a cycle's damage depends on its
    range alone (after ``load`` has chosen the part of the force that loads the part)."""

    load: Literal["draft", "buff", "both"] = Field(
        description="which force loads the part: draft (tension, compression counted as "
                    "0), buff (compression, tension counted as 0) or both (the signed "
                    "force)")
    reference_range: float = Field(gt=0.0, le=1e9,
                                   description="force range of a point of the curve, N")
    reference_cycles: float = Field(ge=1.0, le=1e12,
                                    description="cycles to failure at reference_range, -")
    slope: float = Field(ge=1.0, le=30.0, description="Basquin exponent m above the knee "
                                                      "(N ~ dF^-m), -")
    knee_cycles: float | None = Field(None, ge=1.0, le=1e12,
                                      description="cycles at the knee, below whose range "
                                                  "the curve changes, - (none: one slope "
                                                  "throughout)")
    slope_beyond_knee: float | None = Field(None, ge=1.0, le=60.0,
                                            description="exponent below the knee, - (none: "
                                                        "no damage below the knee)")
    cutoff_cycles: float | None = Field(None, ge=1.0, le=1e15,
                                        description="cycles at the cut-off, below whose "
                                                    "range no damage, - (none: no cut-off)")
    gate: float = Field(0.0, ge=0.0, le=1e9,
                        description="hysteresis gate: reversals smaller than this are "
                                    "dropped before counting, N")

    @model_validator(mode="after")
    def _consistent(self):
        if self.slope_beyond_knee is not None and self.knee_cycles is None:
            raise ValueError("slope_beyond_knee needs knee_cycles (the knee it starts at)")
        if self.cutoff_cycles is not None:
            if self.slope_beyond_knee is None:
                raise ValueError("cutoff_cycles needs slope_beyond_knee (without a second "
                                 "slope nothing below the knee does damage, so a cut-off "
                                 "below it has no effect)")
            if not self.cutoff_cycles > self.knee_cycles:
                raise ValueError(f"cutoff_cycles ({self.cutoff_cycles:g}) must be above "
                                 f"knee_cycles ({self.knee_cycles:g}): the cut-off lies "
                                 "below the knee's range")
        if self.gate >= self.reference_range:
            raise ValueError(f"gate ({self.gate:g} N) must be below reference_range "
                             f"({self.reference_range:g} N): a gate that wide drops the "
                             "cycles the curve is about")
        return self


def fatigue_curve(fatigue: "str | FatigueCurve | None") -> FatigueCurve | None:
    """The S-N curve of a coupler's ``fatigue`` key: a shipped curve's (by name) or the
    inline table; None without one."""
    if fatigue is None or isinstance(fatigue, FatigueCurve):
        return fatigue
    curve = load_preset("fatigue", fatigue)
    return FatigueCurve(**{k: curve[k] for k in FATIGUE_KEYS if k in curve})


#: a coupler's ``fatigue``: a shipped curve's name or an inline table (told apart by type)
FatigueKey = Annotated[
    Union[Annotated[str, Tag("curve")], Annotated[FatigueCurve, Tag("table")]],
    Discriminator(lambda v: "curve" if isinstance(v, str) else "table")]


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
    # the coupling's strength (its coupler, knuckle, draw hook; not its gear's): a run
    # lists when a coupler's force first went over its proof and ultimate loads
    # (ltdsim.results.strength); the forces themselves do not depend on it
    strength: StrengthKey | None = Field(
        None, description="strength grade of the coupling (docs/strength.md: aar-e, "
                          "aar-e-body, en15566-1000, en15566-1200, en15566-1500, uic-850) "
                          "or a table of draft_proof, draft_ultimate, buff_proof, "
                          "buff_ultimate, N; none: no strength events")

    # the coupling's fatigue curve (its knuckle's, coupler's or draw gear's S-N curve in
    # coupler force range): a run counts the cycles of each coupler's force and sums their
    # damage by Miner's rule (ltdsim.results.fatigue); the forces do not depend on it
    fatigue: FatigueKey | None = Field(
        None, description="fatigue curve of the coupling (docs/fatigue.md: aar-e-knuckle) "
                          "or a table of load, reference_range, reference_cycles, slope, "
                          "knee_cycles, slope_beyond_knee, cutoff_cycles, gate; none: no "
                          "fatigue damage")

    @field_validator("fatigue")
    @classmethod
    def _known_curve(cls, v):
        if isinstance(v, str) and v not in fatigue_curves():
            raise ValueError(f"unknown coupler fatigue curve {v!r}; available: "
                             f"{', '.join(fatigue_curves()) or 'none'}")
        return v

    @field_validator("strength")
    @classmethod
    def _known_grade(cls, v):
        if isinstance(v, str) and v not in strength_grades():
            raise ValueError(f"unknown coupler strength grade {v!r}; available: "
                             f"{', '.join(strength_grades()) or 'none'}")
        return v

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
    # what is in series with the gear at the end of the slack (coupler, yoke, draft
    # sill): without it the force steps from nothing to the gear's released force as the
    # slack closes (physics.gears.draftgear.edge_structure, docs/draftgear.md)
    edge_stiffness: float | None = Field(
        None, gt=0.0, le=1e11,
        description="stiffness of the structure in series with the gear at the end of "
                    "the slack, up to the gear's force, N/m (none: rigid, the force steps "
                    "to the gear's released force there)")
    edge_damping: float = Field(
        0.0, ge=0.0, le=1e9,
        description="damping of that structure, N s/m (needs edge_stiffness)")

    def _check(self) -> None:
        if self.edge_damping > 0.0 and self.edge_stiffness is None:
            raise ValueError("edge_damping acts only across the structure of "
                             "edge_stiffness; give edge_stiffness too, or leave "
                             "edge_damping out (a rigid end of the slack has no damping)")

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
        super()._check()
        if self.S is not None and self.S_table is not None:
            raise ValueError("S and S_table both given: the lubrication factor is either the "
                             "constant S or the table S_table (impact speed m/s, deflection "
                             "m); give one of them")
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
        super()._check()
        for name in ("loading", "unloading"):
            pts = getattr(self, name)
            _check_table(pts, f"{name} deflections, m", lambda f: 0.0 <= f <= 1e8,
                         "forces in [0, 1e8] N")
            if pts[0][0] != 0.0:
                raise ValueError(f"{name} must start at deflection 0")
            if len(pts) < 2:
                raise ValueError(f"{name}: {len(pts)} point ({pts[0][1]:g} N at 0 m) is not a "
                                 "force-deflection curve: give at least 2 [deflection m, "
                                 "force N] points, from deflection 0 to the gear's travel")
        first, last = self.loading[0], self.loading[-1]
        if last[1] <= first[1]:
            raise ValueError(f"loading: the force must rise from its start ({first[1]:g} N at "
                             f"0 m) to its last point ({last[1]:g} N at {last[0]:g} m): a "
                             "gear resists more the further it is closed")
        ends = max(self.loading[-1][0], self.unloading[-1][0])
        if self.travel is not None and self.travel < ends:
            name = "loading" if self.loading[-1][0] == ends else "unloading"
            raise ValueError(f"travel ({self.travel:g} m) is below the last deflection of "
                             f"{name} ({ends:g} m): the points beyond travel would have no "
                             "effect (the gear is solid from travel on); end the curves at "
                             "travel, or leave travel out (the last point is then the "
                             "travel)")
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
        super()._check()
        if self.force_at_travel < self.preload + self.initial_stiffness * self.travel:
            raise ValueError("force_at_travel must be at least preload + initial_stiffness "
                             "* travel (the static curve never falls)")
        if self.return_ratio * self.gain_unloading > self.gain_loading:
            raise ValueError("return_ratio * gain_unloading must not exceed gain_loading, "
                             "or unloading would lie above loading at speed")


class CushionUnit(_CouplerBase):
    """End-of-car cushioning unit: a hydraulic piston behind a stiff oil column, stroking
    through an orifice against a preloaded return spring, rigid below its preload
    (physics.gears.cushion, docs/draftgear.md). ``travel`` is its stroke."""

    _required = ("preload", "spring_stiffness", "oil_stiffness", "orifice_linear",
                 "orifice_quadratic", "travel")

    model: Literal["cushion"] = Field("cushion", description="coupler model")
    preload: float | None = Field(None, ge=0.0, le=1e7,
                                  description="force the piston starts to stroke at, N")
    spring_stiffness: float | None = Field(None, ge=0.0, le=1e9,
                                           description="stiffness of the return spring, "
                                                       "N/m")
    oil_stiffness: float | None = Field(None, gt=0.0, le=1e11,
                                        description="stiffness of the oil column between "
                                                    "follower and piston, N/m")
    orifice_linear: float | None = Field(None, gt=0.0, le=1e9,
                                         description="the orifice's laminar resistance, "
                                                     "N s/m")
    orifice_quadratic: float | None = Field(None, ge=0.0, le=1e10,
                                            description="the orifice's turbulent "
                                                        "resistance, N s^2/m^2")

    @property
    def damping(self) -> float:
        """Viscous damping in parallel with the coupling, N s/m: none (the orifice acts in
        series with the oil column)."""
        return 0.0

    def _check(self) -> None:
        if self.spring_stiffness >= self.oil_stiffness:
            raise ValueError("spring_stiffness must be below oil_stiffness (the return "
                             "spring is soft against the oil column)")


#: the coupler models' schema classes by ``model`` name (the order of
#: ``ltdsim.engine.couplers.MODEL_NAMES``)
COUPLER_CLASSES: dict[str, type[_CouplerBase]] = {
    "linear": LinearCoupler, "simplified": SimplifiedCoupler,
    "friction_wedge": FrictionWedgeGear, "table": TableGear, "polymer": PolymerGear,
    "cushion": CushionUnit}


class _UnknownCoupler(_Strict):
    """Stand-in member of the coupler union for an unknown ``model``: its only check
    refuses the name, listing the models (as a Literal does)."""

    model_config = ConfigDict(extra="ignore", strict=True)
    model: Literal[tuple(COUPLER_CLASSES)]  # type: ignore[valid-type]


#: union tags (bracketed so that error locations leave them out, see _is_internal)
_TAGS = {f"[{name}]": cls for name, cls in COUPLER_CLASSES.items()}


_UNKNOWN_TAG = "[unknown model]"


#: keys that stand for one another (one of them is given): a table's or an override's
#: key replaces the other one of a preset or a default beneath it
ALTERNATIVE_KEYS = {"S": "S_table", "S_table": "S"}


def over(base: dict, given: dict) -> dict:
    """``base`` (a preset's or a default's keys) with the ``given`` keys over it, in place:
    a key of :data:`ALTERNATIVE_KEYS` given alone drops its alternative from ``base``."""
    for key in given:
        if key in ALTERNATIVE_KEYS and ALTERNATIVE_KEYS[key] not in given:
            base.pop(ALTERNATIVE_KEYS[key], None)
    base.update(given)
    return base


def _merge_preset(data):
    """``preset = NAME``: the preset's keys under the ones given (None values dropped; S or
    S_table given replaces the preset's other one)."""
    if isinstance(data, dict) and data.get("preset"):
        base = load_preset("gears", data["preset"])
        return over(base, {k: v for k, v in data.items() if v is not None})
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
    another gear: it keeps only the default's ``slack``, ``gears``, ``strength`` and
    ``fatigue`` (the coupling's free play, how many gears it holds and its coupler's
    strength and fatigue curve, not the gear's own keys) and takes every other key
    from itself and its preset. An override's S replaces the default's S_table, its
    S_table the default's S (:data:`ALTERNATIVE_KEYS`; a preset's likewise).
    """

    default: Coupler
    override: list[CouplerOverride] = []
