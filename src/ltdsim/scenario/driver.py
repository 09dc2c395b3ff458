"""``[driver]``: the speed, force or notch mode with its profile, the discrete PID, and the
brake schedule, positions and commands.
"""

from __future__ import annotations

from typing import Literal, Union

from pydantic import (
    Field,
    field_validator,
    model_validator,
)


from ltdsim.scenario._base import Pair, Points, Triple, _Strict, _check_chainages, _check_table
from ltdsim.scenario.brakes import BrakeCommand
from ltdsim.scenario.traction import _check_notches


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

    @field_validator("brake_profile")
    @classmethod
    def _levels(cls, v):
        if v is None:
            return v
        return _check_table(v, "times, s", lambda q: 0.0 <= q <= 1.0, "brake levels in [0, 1]")

    @field_validator("brake_positions")
    @classmethod
    def _level_positions(cls, v):
        if v is None:
            return v
        _check_chainages([p[0] for p in v], "lead positions, m")
        return _check_table(v, "lead positions, m", lambda q: 0.0 <= q <= 1.0,
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
