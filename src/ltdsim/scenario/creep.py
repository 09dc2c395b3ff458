"""Input schema of the wheel-rail contact, the driven wheelsets and their slip control.

Three pydantic models, meant to hang under ``[traction.creep]`` of a scenario (the
wiring is not done yet): :class:`RailCondition` (Polach's creep-law parameters, from a
shipped preset ``data/creep/<name>.toml`` with keys overriding it), :class:`Wheelset`
(geometry, materials, inertia, gear, the creep regularisation speed) and
:class:`SlipControl` (the re-adhesion controller). :class:`Creep` groups them. The row
builders at the bottom turn them into the float rows the compiled laws of
:mod:`ltdsim.physics.drive.creep` take; the controller's gains are derived there from its
bandwidth and the wheelset's inertia, not typed in. Units SI.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from ltdsim.data import load_preset, preset_names
from ltdsim.scenario._base import _Strict
from ltdsim.physics.drive import creep as _creep


@functools.cache
def _preset(name: str) -> dict:
    return load_preset("creep", name)


class RailCondition(_Strict):
    """Polach's creep-force parameters of one rail condition: a shipped preset (``dry``,
    ``wet``, ``low-adhesion``, ``eurosprinter``) with any key given here replacing the
    preset's."""

    preset: str | None = Field(None, description="name of a shipped rail condition "
                                                 "(data/creep/*.toml); none: give all keys")
    mu0: float = Field(gt=0.0, le=1.0, description="friction coefficient at zero slip "
                                                   "velocity, -")
    A: float = Field(gt=0.0, le=1.0, description="friction at infinite slip velocity over "
                                                 "mu0, -")
    B: float = Field(ge=0.0, le=10.0, description="decay of the friction coefficient with "
                                                  "the slip velocity, s/m")
    kA: float = Field(gt=0.0, le=1.0, description="Polach's reduction factor in the area "
                                                  "of adhesion, -")
    kS: float = Field(gt=0.0, le=1.0, description="Polach's reduction factor in the area "
                                                  "of slip, at most kA, -")

    @model_validator(mode="before")
    @classmethod
    def _merge_preset(cls, data: Any):
        if isinstance(data, str):
            data = {"preset": data}
        if not isinstance(data, dict) or data.get("preset") is None:
            return data
        name = data["preset"]
        names = preset_names("creep")
        if not isinstance(name, str) or name not in names:
            raise ValueError(f"unknown rail condition preset {name!r}; available: "
                             f"{', '.join(names) or 'none'}")
        base = {k: v for k, v in _preset(name).items() if k in _creep.CREEP_PARAMS}
        return {**base, **data}

    @model_validator(mode="after")
    def _factors(self):
        if self.kS > self.kA:
            raise ValueError(f"kS = {self.kS} must not exceed kA = {self.kA} (Polach: "
                             "kS <= kA <= 1)")
        return self


class Wheelset(_Strict):
    """A driven wheelset of the locomotive, its contact with the rail and its gear."""

    axles: int = Field(6, ge=1, le=12, description="driven axles per locomotive; the axle "
                                                  "load is its static mass (or "
                                                  "adhesion_mass) x g / axles, -")
    adhesion_mass: float | None = Field(None, gt=0.0, le=1.0e7,
                                        description="mass the driven wheelsets carry; none: "
                                                    "the locomotive's static mass, kg")
    wheel_radius: float = Field(0.625, ge=0.3, le=0.7,
                                description="rolling radius (1250 mm wheels), m")
    rail_radius: float = Field(0.3, ge=0.05, le=2.0,
                               description="transverse radius of the rail head at the "
                                           "contact (UIC 60 and 136 RE crowns: 0.3 m), m")
    young: float = Field(2.1e11, ge=1e11, le=3e11, description="Young's modulus of wheel "
                                                               "and rail steel, Pa")
    poisson: float = Field(0.28, ge=0.2, le=0.35, description="Poisson's ratio of wheel "
                                                              "and rail steel, -")
    shear_modulus: float = Field(8.2e10, ge=5e10, le=1.2e11,
                                 description="shear modulus, E / (2 (1 + nu)), Pa")
    inertia: float = Field(200.0, gt=0.0, le=5000.0,
                           description="polar inertia of the wheelset with its gear wheel, "
                                       "kg m^2 (the motor rotor's, times the gear ratio "
                                       "squared, is added from the motor)")
    gear_ratio: float = Field(5.02, ge=1.0, le=10.0,
                              description="motor speed over wheelset speed; 5.02 puts the "
                                          "study's base speed 1283 rpm at its v_Pmax "
                                          "16.72 m/s on 0.625 m wheels, -")
    gear_efficiency: float = Field(0.975, gt=0.5, le=1.0,
                                   description="gear efficiency (wheel torque = ratio x "
                                               "efficiency x motor torque), -")
    v_reg: float = Field(1.0, ge=0.01, le=5.0,
                         description="creep regularisation speed: below it the creep is "
                                     "slip velocity over v_reg (docs/creep.md), m/s")

    @model_validator(mode="after")
    def _shear(self):
        iso = self.young / (2.0 * (1.0 + self.poisson))
        if abs(self.shear_modulus - iso) > 0.1 * iso:
            raise ValueError(f"shear_modulus = {self.shear_modulus:.3g} Pa is more than 10 % "
                             f"from E / (2 (1 + nu)) = {iso:.3g} Pa")
        return self


class SlipControl(_Strict):
    """The re-adhesion controller: a slip-velocity limiter (law in
    :func:`ltdsim.physics.drive.creep.slip_control`)."""

    enabled: bool = Field(True, description="limit the wheel torque on slip; off: the "
                                            "demanded torque reaches the wheel whatever it "
                                            "slips")
    w_set: float = Field(0.39, gt=0.0, le=5.0,
                         description="slip velocity held at standstill, m/s (fitted to the "
                                     "peak of the wet-rail curve, docs/creep.md)")
    w_slope: float = Field(0.040, ge=0.0, le=0.5,
                           description="rise of the held slip velocity per m/s of "
                                       "speed (m/s per m/s), -")
    bandwidth: float = Field(20.0, gt=0.0, le=500.0,
                             description="closed-loop bandwidth of the slip-velocity loop "
                                         "past the curve's peak, rad/s")
    recovery_time: float = Field(2.0, gt=0.0, le=60.0,
                                 description="time for the torque limit to climb back from "
                                             "0 to the largest wheel torque, s")


class Creep(_Strict):
    """The wheel-rail contact of the induction drive (``[traction.creep]``)."""

    rail: RailCondition = Field(default_factory=lambda: RailCondition(preset="dry"),
                                description="rail condition (a preset name or a table)")
    wheelset: Wheelset = Field(default_factory=Wheelset, description="driven wheelsets")
    slip_control: SlipControl = Field(default_factory=SlipControl,
                                      description="re-adhesion controller")


# --- rows for the compiled laws -----------------------------------------------------------
def rail_row(rail: RailCondition) -> np.ndarray:
    """The :data:`ltdsim.physics.drive.creep.CREEP_PARAMS` row of a rail condition."""
    return _creep.creep_row(rail.model_dump())


def wheelset_row(ws: Wheelset, static_mass: float, gravity: float,
                 motor_inertia: float = 0.0) -> np.ndarray:
    """The :data:`ltdsim.physics.drive.creep.WHEELSET_PARAMS` row of one driven wheelset of a
    locomotive of ``static_mass`` kg (``ws.adhesion_mass`` instead when given) under
    ``gravity`` (m/s^2, ``track.gravity``), with the
    motor rotor's inertia ``motor_inertia`` (kg m^2, at the motor shaft)."""
    if ws.adhesion_mass is not None:
        static_mass = ws.adhesion_mass
    return _creep.wheelset_row(
        static_mass=static_mass, axles=ws.axles, gravity=gravity,
        wheel_radius=ws.wheel_radius, rail_radius=ws.rail_radius, young=ws.young,
        poisson=ws.poisson, shear_modulus=ws.shear_modulus, inertia=ws.inertia,
        motor_inertia=motor_inertia, gear_ratio=ws.gear_ratio, v_reg=ws.v_reg)


def slip_row(sc: SlipControl, ws_row: np.ndarray, max_wheel_torque: float) -> np.ndarray:
    """The :data:`ltdsim.physics.drive.creep.SLIP_PARAMS` row. Past the curve's peak the creep
    force no longer holds the wheel back, so the slip velocity ``w`` follows the torque as
    ``J/r dw/dt = T_w`` (a pure integrator): a proportional gain ``J omega_c / r``
    (N m s/m) closes the loop at ``omega_c`` = ``bandwidth`` rad/s, and the integral gain
    ``gain omega_c / 4`` (N m/m) puts the PI zero a quarter of the bandwidth below it.
    The limit recovers at ``max_wheel_torque / recovery_time`` N m/s and, left above a
    lower demand, follows it down at the bandwidth (1/s)."""
    j, r = ws_row[_creep.WS_J], ws_row[_creep.WS_R]
    gain = j * sc.bandwidth / r
    return np.array([sc.w_set, sc.w_slope, gain, gain * sc.bandwidth / 4.0,
                     max_wheel_torque / sc.recovery_time, sc.bandwidth])
