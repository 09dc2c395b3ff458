"""``[solver]``: the integration method, step, end time, recording, bs23's tolerances and
the energy accounting.
"""

from __future__ import annotations

import math
from typing import Literal, Optional

from pydantic import (
    Field,
    model_validator,
)

from ltdsim.variables import ENERGY_VARIABLES, RECORDABLE

from ltdsim.scenario._base import _Strict


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
                                    "positions, m and m/s (vehicle speeds use atol x 10 unless "
                                    "speed_atol is given: "
                                    "1e-4 means 1 mm/s; force states atol x 1e6 N/m: "
                                    "1e-6 means 1 N, a draft gear's internal force atol x "
                                    "1e7 N/m on the force it exerts; the fluid brake's "
                                    "pressures atol x 1e6 "
                                    "Pa/m, 1 Pa, and pipe flows atol x 10 kg/(s m), 1e-5 "
                                    "kg/s)")
    speed_atol: Optional[float] = Field(
        None, gt=0.0, le=1.0,
        description="bs23: absolute tolerance on the vehicles' speeds, m/s (their error "
                    "is then held to it alone, whatever the train's speed: a coupler's "
                    "force depends on the differences of the speeds, not on the speed. "
                    "Left out, atol x 10 plus rtol x the speed: 19 mm/s at 18 m/s with "
                    "the heavy-haul scenario's tolerances. Single couplers' peaks of a "
                    "long train need 1e-5 to 1e-6 m/s, docs/heavy-haul.md)")
    hold_speed: Optional[float] = Field(
        None, gt=0.0, le=0.1,
        description="bs23: the closing or opening speed below which a coupling that meets "
                    "or leaves its slack edge is held there, if its gear has a preload "
                    "and a rigid end of the slack (no edge_stiffness), m/s (held, the "
                    "vehicles on its two sides move as one body and it carries the force "
                    "that makes them, until that force leaves the range from none to the "
                    "gear's released force; the touch is plastic, its kinetic energy the "
                    "coupler's work. Left out, none is held: such a coupling chatters at "
                    "its edge and its force alternates between none and the preload, "
                    "docs/heavy-haul.md, \"Couplings held at their slack edge\")")
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
    energy_interval: float = Field(
        5e-4, gt=0.0, le=1.0,
        description="fixed step with energy = true: the longest interval between the "
                    "samples of the brakes', resistances' and couplers' powers for their "
                    "trapezoids (traction's: every step), a whole number of steps that "
                    "divides the record interval (every step when none does), s")
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
        if not math.isfinite(ratio):  # (a step so small that the ratio overflows)
            raise ValueError(f"dt ({self.dt:g} s) is too small to count the steps of one "
                             f"output_interval ({self.output_interval:g} s)")
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
    def energy_every(self) -> int:
        """Steps between two samples of the brakes', resistances' and couplers' powers
        in the fixed-step energy accounting: the largest whole number of steps that
        divides :attr:`record_every` and spans at most ``energy_interval`` (1 when none
        does)."""
        re_ = self.record_every
        fit = max(1, int(math.floor(self.energy_interval / self.dt + 1e-9)))
        return max(d for d in range(1, min(fit, re_) + 1) if re_ % d == 0)

    @property
    def n_steps(self) -> int:
        """Number of steps: t_end rounded down to a whole number of output intervals."""
        n_rec = int(math.floor(self.t_end / self.output_interval + 1e-9))
        return n_rec * self.record_every
