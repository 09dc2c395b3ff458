"""``[[vehicles]]``: mass, length, Davis resistance, tread brake and the plan geometry the
curving indicators read.
"""

from __future__ import annotations

import typing
from typing import Annotated, Literal, Union

from pydantic import (
    Field,
    field_validator,
    model_validator,
)


from ltdsim.scenario._base import MAX_LENGTH, MAX_MASS, MAX_VEHICLES, Points, _Strict, _check_table


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
    """Plan and height geometry of a vehicle for the curving indicators (ltdsim.results.safety);
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

    @field_validator("axles")
    @classmethod
    def _two_bogies(cls, v):
        # the curving indicators (ltdsim.results.safety) share a bogie's lateral force
        # among its wheelsets, half of the axles under each of the two bogies
        if v is not None and v % 2:
            raise ValueError(f"{v} axles cannot be split between the vehicle's two bogies "
                             "(the curving indicators put half of them in each): give an "
                             "even number from 2 to 16")
        return v


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

    @model_validator(mode="after")
    def _masses(self):
        # the dynamic mass is the static mass plus the equivalent mass of the rotating
        # parts (wheelsets, gears, motors): never less
        if self.static_mass is not None and self.mass < self.static_mass:
            raise ValueError(f"mass ({self.mass:g} kg) must be at least static_mass "
                             f"({self.static_mass:g} kg): mass is the dynamic mass, the "
                             "static mass plus the rotating parts' equivalent mass")
        return self

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
