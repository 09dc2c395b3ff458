"""``[traction]`` and ``[[locomotives]]``: the traction curve, the motor lag and jerk
limit, dynamic-brake fade, the induction drive's motor and creep, and the locomotive
consists of distributed power.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from ltdsim.scenario.creep import Creep
from ltdsim.data import preset_names

from ltdsim.scenario._base import Points, _Strict, _check_table
from ltdsim.scenario.messages import first_problem


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
        from ltdsim.scenario.motor import Motor, load_motor

        if self.preset not in preset_names("motors"):
            raise ValueError(f"unknown motor preset {self.preset!r}; available: "
                             f"{', '.join(preset_names('motors')) or 'none'}")
        base = load_motor(self.preset).model_dump()
        extra = dict(self.model_extra or {})
        unknown = sorted(set(extra) - set(base))
        if unknown:
            raise ValueError(f"unknown key {unknown[0]!r}; allowed: preset, per_locomotive, "
                             f"{', '.join(base)}")
        try:
            return Motor(**{**base, **extra})
        except ValidationError as exc:
            raise ValueError(first_problem(exc, model=Motor)) from None


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
                    "no braking at standstill, m/s (0 = the study's mirrored curve down to "
                    "standstill_speed)")
    standstill_speed: float = Field(
        0.01, gt=0.0, le=1.0,
        description="with dynamic_brake_fade = 0, the speed below which dynamic braking "
                    "fades linearly to 0 (and turns with the motion when the train runs "
                    "back): no brake pushes a standing train, m/s")

    @property
    def brake_fade(self) -> float:
        """The speed below which dynamic braking fades linearly to 0, m/s (> 0):
        ``dynamic_brake_fade``, or without one ``standstill_speed``."""
        return self.dynamic_brake_fade if self.dynamic_brake_fade > 0.0 else \
            self.standstill_speed
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
        # (a value other than the default: a scenario read back from its dictionary
        # names every key)
        default = type(self).model_fields["standstill_speed"].default
        if self.dynamic_brake_fade > 0.0 and self.standstill_speed != default:
            raise ValueError("standstill_speed has no effect with dynamic_brake_fade > 0 "
                             "(the fade speed then sets the band): leave one of them out")
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
