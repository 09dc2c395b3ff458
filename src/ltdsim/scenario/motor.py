"""Input schema of the induction traction drive: the motor and its controller (pydantic).

A :class:`Motor` is one traction motor with its inverter and field-oriented controller:
the ratings, the star-equivalent equivalent circuit, the rotor inertia and the figures
of the controller's design. Shipped parameter sets live in ``ltdsim/data/motors/*.toml``
(``ltdsim.data.preset_names("motors")``, :func:`load_motor`), each with its sources.
Units are SI except where the key says otherwise (speeds in rpm, the current-loop bandwidth in Hz, as
engineers read them on a rating plate and a controller's data sheet).
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ltdsim.data import load_preset


class Motor(BaseModel):
    """One traction motor: ratings, equivalent circuit, inertia, controller design."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True,
                              strict=True)

    # --- ratings (the study's section 3) ---
    rated_power: float = Field(gt=0.0, le=1.0e7, description="rated shaft power at base "
                               "speed, W; also the controller's power limit")
    base_speed: float = Field(gt=0.0, le=2.0e4, description="base (rated) speed, rpm: "
                              "field weakening above it")
    max_speed: float = Field(gt=0.0, le=2.0e4, description="maximum speed, rpm")
    dc_link_voltage: float = Field(gt=0.0, le=1.0e4, description="inverter DC-link "
                                   "voltage, V")
    rated_current: float = Field(gt=0.0, le=1.0e4, description="rated winding current, "
                                 "A rms")
    max_current: float = Field(gt=0.0, le=1.0e4, description="largest winding current the "
                               "controller allows, A rms")
    connection: Literal["star", "delta"] = Field(description="stator connection: the "
                                                 "model's phase (line) current is sqrt(3) "
                                                 "times the winding current in delta")
    # --- machine (star-equivalent per phase) ---
    pole_pairs: int = Field(ge=1, le=12, description="pole pairs, -")
    stator_resistance: float = Field(gt=0.0, le=100.0, description="R_s, ohm")
    rotor_resistance: float = Field(gt=0.0, le=100.0, description="R_r referred to the "
                                    "stator, ohm")
    stator_leakage_inductance: float = Field(gt=0.0, le=1.0, description="L_ls, H")
    rotor_leakage_inductance: float = Field(gt=0.0, le=1.0, description="L_lr, H")
    magnetising_inductance: float = Field(gt=0.0, le=10.0, description="L_m, H")
    rotor_inertia: float = Field(gt=0.0, le=1.0e3, description="rotor moment of inertia, "
                                 "kg m^2")
    # --- figures of the derivation from the ratings ---
    rated_slip: float = Field(gt=0.0, lt=0.2, description="slip at the rated point, -")
    stator_copper_loss: float = Field(gt=0.0, lt=0.2, description="stator copper loss at "
                                      "the rated point as a fraction of rated_power, -")
    # --- controller ---
    current_bandwidth: float = Field(gt=0.0, le=5.0e3, description="closed-loop bandwidth "
                                     "of the synchronous-frame current loops, Hz")
    voltage_margin: float = Field(gt=0.5, le=1.0, description="fraction of the inverter's "
                                  "voltage limit V_dc/sqrt(3) that field weakening plans "
                                  "with (the rest is the current loops' headroom), -")
    breakdown_margin: float = Field(gt=0.0, lt=1.0, description="fraction of the breakdown "
                                    "torque the controller demands at most, -")

    @model_validator(mode="after")
    def _ranges(self):
        if self.max_speed <= self.base_speed:
            raise ValueError("max_speed must exceed base_speed")
        if self.max_current < self.rated_current:
            raise ValueError("max_current must be at least rated_current")
        return self

    @property
    def leakage_factor(self) -> float:
        """``sigma = 1 - L_m^2 / (L_s L_r)``, -."""
        ls = self.stator_leakage_inductance + self.magnetising_inductance
        lr = self.rotor_leakage_inductance + self.magnetising_inductance
        return 1.0 - self.magnetising_inductance ** 2 / (ls * lr)

    @property
    def rated_torque(self) -> float:
        """Rated power over base speed, N m."""
        return self.rated_power / (self.base_speed * math.pi / 30.0)


def load_motor(name: str) -> Motor:
    """The shipped motor parameter set ``name`` (``ltdsim.data.preset_names("motors")``),
    validated; a bad key is one ``ValueError`` line naming the file and the key."""
    data = load_preset("motors", name)
    try:
        return Motor(**data)
    except ValidationError as e:
        err = e.errors()[0]
        key = ".".join(str(x) for x in err["loc"]) or "(file)"
        raise ValueError(f"{name}.toml: {key}: {err['msg']}") from None
