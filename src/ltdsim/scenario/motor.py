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
from ltdsim.scenario._base import quantity
from ltdsim.scenario.messages import first_problem

# Each key's physical range: generous bounds around traction motors as they are built,
# so that a slip of units or a typing error (a 1 V DC link, a 1e-9 H inductance) is
# refused by its key; the relations between the keys follow in Motor._design. Readings:
# traction motors of 10 kW (tram) to some 1.6 MW (the largest locomotive motors), on DC
# links of 600-750 V (trams) to 2.8-3.6 kV (locomotives; multilevel inverters more),
# four to eight poles at 1000-3000 rpm base and 4000-6000 rpm top speed; the
# per-unit circuit of Krause et al. (resistances ~0.01 pu, leakages ~0.1 pu, magnetising
# 2-4 pu: milliohms to ohms, tens of microhenries to tens of millihenries).
_Power = quantity(1e3, 1e7, "W", why="traction motors: 10 kW to 1.6 MW")
_Speed = quantity(100.0, 2e4, "rpm")
_Voltage = quantity(100.0, 1e4, "V", why="DC links: 600-750 V trams, 2.8-3.6 kV locomotives")
_Current = quantity(1.0, 1e4, "A rms")
_Resistance = quantity(1e-4, 100.0, "ohm")
_Leakage = quantity(1e-6, 1.0, "H")
_Magnetising = quantity(1e-4, 10.0, "H")
_Inertia = quantity(0.01, 1e3, "kg m^2", why="rotors of tens of kg m^2 at MW")
_Share = quantity(1e-4, 0.2, "-")
_Bandwidth = quantity(1.0, 5e3, "Hz", why="a tenth of a 1-10 kHz switching frequency and "
                      "below")

#: the largest power factor x efficiency the rated power is checked against, -: an
#: induction motor's power factor stays under about 0.9 and its efficiency under 0.97
#: (their product, 0.87, is left some room: the check refuses the impossible, not the
#: unusual)
MAX_POWER_FACTOR_EFFICIENCY = 0.95


class Motor(BaseModel):
    """One traction motor: ratings, equivalent circuit, inertia, controller design."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True,
                              strict=True)

    # --- ratings (the study's section 3) ---
    rated_power: _Power = Field(description="rated shaft power at base speed, W; also the "
                                "controller's power limit")
    base_speed: _Speed = Field(description="base (rated) speed, rpm: field weakening "
                               "above it")
    max_speed: _Speed = Field(description="maximum speed, rpm")
    dc_link_voltage: _Voltage = Field(description="inverter DC-link voltage, V")
    rated_current: _Current = Field(description="rated winding current, A rms")
    max_current: _Current = Field(description="largest winding current the controller "
                                  "allows, A rms")
    connection: Literal["star", "delta"] = Field(description="stator connection: the "
                                                 "model's phase (line) current is sqrt(3) "
                                                 "times the winding current in delta")
    # --- machine (star-equivalent per phase) ---
    pole_pairs: int = Field(ge=1, le=12, description="pole pairs, -")
    stator_resistance: _Resistance = Field(description="R_s, ohm")
    rotor_resistance: _Resistance = Field(description="R_r referred to the stator, ohm")
    stator_leakage_inductance: _Leakage = Field(description="L_ls, H")
    rotor_leakage_inductance: _Leakage = Field(description="L_lr, H")
    magnetising_inductance: _Magnetising = Field(description="L_m, H")
    rotor_inertia: _Inertia = Field(description="rotor moment of inertia, kg m^2")
    # --- figures of the derivation from the ratings ---
    rated_slip: _Share = Field(description="slip at the rated point, -")
    stator_copper_loss: _Share = Field(description="stator copper loss at the rated point "
                                       "as a fraction of rated_power, -")
    # --- controller ---
    current_bandwidth: _Bandwidth = Field(description="closed-loop bandwidth of the "
                                          "synchronous-frame current loops, Hz")
    voltage_margin: quantity(0.5, 1.0, "-") = Field(
        description="fraction of the inverter's voltage limit V_dc/sqrt(3) that field "
                    "weakening plans with (the rest is the current loops' headroom), -")
    breakdown_margin: quantity(0.05, 0.99, "-") = Field(
        description="fraction of the breakdown torque the controller demands at most, -")

    @model_validator(mode="after")
    def _ranges(self):
        if self.max_speed <= self.base_speed:
            raise ValueError(f"max_speed ({self.max_speed:g} rpm) must exceed base_speed "
                             f"({self.base_speed:g} rpm)")
        if self.max_current < self.rated_current:
            raise ValueError(f"max_current ({self.max_current:g} A) must be at least "
                             f"rated_current ({self.rated_current:g} A)")
        return self

    @model_validator(mode="after")
    def _design(self):
        """What a motor designer checks between the keys: the power the inverter can
        feed, the current the magnetising inductance needs, the torque the leakage
        allows. Each refusal is one line naming the keys and the relation."""
        from ltdsim.physics.drive.foc import rated_flux
        from ltdsim.physics.drive.induction import line_current_peak

        def line(key: str, rms: float, peak: float) -> str:
            if self.connection == "delta":
                return (f"{key} {rms:g} A rms winding x sqrt(3) = {peak:.4g} A rms line "
                        "(delta)")
            return f"{key} = {peak:.4g} A rms line (star)"

        # 1. power: P <= k sqrt(3) U I, U the line voltage (rms) of the space-vector
        # limit, phase peak V_dc / sqrt(3), line rms V_dc / sqrt(2); I the largest line
        # current (rated_power is also the controller's power limit, which it holds up
        # to max_current)
        u = self.dc_link_voltage / math.sqrt(2.0)
        i_max = line_current_peak(self.max_current, self.connection) / math.sqrt(2.0)
        k = MAX_POWER_FACTOR_EFFICIENCY
        p_max = k * math.sqrt(3.0) * u * i_max
        if self.rated_power > p_max:
            raise ValueError(
                f"rated_power ({self.rated_power:g} W) is more than the inverter can feed "
                f"the motor: {k} x sqrt(3) x U x I = {p_max:.4g} W, with U = "
                f"dc_link_voltage / sqrt(2) = {u:.4g} V rms line (the space-vector "
                f"modulator's limit) and I = {line('max_current', self.max_current, i_max)} "
                f"({k}: the most power factor x efficiency an induction motor reaches)")
        # 2. magnetising: the rated flux psi_0 (the equivalent circuit at base speed,
        # rated slip and voltage_margin V_dc / sqrt(3)) over L_m is the flux current
        # i_d0, which must leave room for torque within the rated current
        i_rated = line_current_peak(self.rated_current, self.connection)
        psi0 = rated_flux(self)
        i_d0 = psi0 / self.magnetising_inductance
        if not i_d0 < i_rated:
            raise ValueError(
                f"magnetising_inductance ({self.magnetising_inductance:g} H) needs a "
                f"magnetising current psi_0 / L_m = {psi0:.4g} Wb / "
                f"{self.magnetising_inductance:g} H = {i_d0:.4g} A peak at the rated point "
                f"(base_speed, rated_slip, voltage_margin x dc_link_voltage / sqrt(3)), "
                f"not below the rated current {i_rated:.4g} A peak "
                f"({line('rated_current', self.rated_current, i_rated / math.sqrt(2.0))}): "
                "no current is left for torque "
                "(motors magnetise with some 20-60 % of their rated current)")
        # 3. breakdown: the controller's breakdown torque at base speed, k_t (V /
        # w_e)^2 / (2 sigma L_s^2) (stator resistance neglected, as the controller
        # computes it), times breakdown_margin, must reach the rated torque
        lm = self.magnetising_inductance
        ls = self.stator_leakage_inductance + lm
        lr = self.rotor_leakage_inductance + lm
        w_e = self.pole_pairs * self.base_speed * math.pi / 30.0 / (1.0 - self.rated_slip)
        v = self.voltage_margin * self.dc_link_voltage / math.sqrt(3.0)
        t_bd = 1.5 * self.pole_pairs * lm * lm / lr * (v / w_e) ** 2 / (
            2.0 * self.leakage_factor * ls * ls)
        if self.breakdown_margin * t_bd < self.rated_torque:
            raise ValueError(
                f"stator_leakage_inductance and rotor_leakage_inductance "
                f"({self.stator_leakage_inductance:g} and "
                f"{self.rotor_leakage_inductance:g} H) leave a breakdown torque at "
                f"base_speed of {t_bd:.4g} N m, and breakdown_margin x that = "
                f"{self.breakdown_margin * t_bd:.4g} N m is below the rated torque "
                f"rated_power / base_speed = {self.rated_torque:.4g} N m: the motor cannot "
                "deliver its rated power")
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
        raise ValueError(f"{name}.toml: {first_problem(e, model=Motor)}") from None
