"""The standard manoeuvres of a make-up study, each as dotted-key overrides of the base
scenario (docs/makeup.md, "Manoeuvres"): the driver's commands replaced whole (force
mode, so no speed controller acts), the track one straight piece of the manoeuvre's
grade (a crest or a sag: two grades meeting where the lead vehicle starts), the run's
length and one analysis phase over it.

* ``emergency``, ``full_service``: from ``speed``, power off; the handle moves to
  emergency or full service at ``at``. (With the lumped brake both are a full
  application, brake level 1; the fluid brake vents the pipe faster in emergency.)
* ``traction_start``: from rest with the couplers bunched; the air brake is applied at
  0 s and released at ``at``, when the traction demand starts to ramp up to ``force``
  over ``ramp`` seconds (a train held on its brakes and pulled away).
* ``dynamic_brake``: from ``speed``; the dynamic-brake demand ramps to ``force`` from
  ``at`` over ``ramp`` seconds.
* ``crest``, ``sag``: coasting from ``speed``, power off, over a change of grade at
  chainage 0 (where the lead vehicle starts): ``+grade`` to ``-grade`` (crest: the
  front runs away downhill first and the train is stretched) or ``-grade`` to
  ``+grade`` (sag: the front climbs first and the train bunches).
"""

from __future__ import annotations

from ltdsim.makeup.study import Manoeuvre
from ltdsim.scenario import Scenario

#: -: the grade either side of a crest or sag when the manoeuvre gives none
CREST_GRADE = 0.01
#: m: where the first grade of a crest or sag begins, behind any train's rear
_FAR_BEHIND = -1.0e6


def full_force(base: Scenario) -> float:
    """Every consist's force limit together, N (a consist's own ``max_force`` or
    ``[traction]``'s)."""
    t = base.traction.max_force
    return float(sum(c.max_force if c.max_force is not None else t for c in base.consists()))


def manoeuvre_overrides(base: Scenario, m: Manoeuvre) -> dict:
    """The overrides of ``base`` that make manoeuvre ``m``."""
    force = m.force if m.force is not None else full_force(base)
    grade = m.grade
    gradient = [[0.0, grade]]
    driver: dict = {"mode": "force", "force_profile": [[0.0, 0.0]]}
    speed = m.speed if m.speed is not None else 0.0
    couplers = m.couplers
    if m.kind in ("emergency", "full_service"):
        handle = "emergency" if m.kind == "emergency" else "full"
        driver["brake_commands"] = [{"time": m.at, "handle": handle}]
    elif m.kind == "traction_start":
        driver["force_profile"] = _ramp(m, force)
        driver["brake_commands"] = ([{"time": 0.0, "handle": "full"},
                                     {"time": m.at, "handle": "release"}]
                                    if any(v.brake for v in base.vehicles) else None)
        couplers = couplers or "bunched"
    elif m.kind == "dynamic_brake":
        driver["force_profile"] = _ramp(m, -force)
    else:
        g = grade if grade > 0.0 else CREST_GRADE
        first, second = (g, -g) if m.kind == "crest" else (-g, g)
        gradient = [[_FAR_BEHIND, first], [0.0, second]]
    if driver.get("brake_commands") is None:
        driver.pop("brake_commands", None)
    out = {
        "driver": driver,
        "initial.speed": speed,
        "solver.t_end": m.duration,
        "track.gradient": gradient,
        "track.curve": [[0.0, 0.0]],
        "phases": [{"name": m.name, "start": 0.0, "end": m.duration}],
    }
    if couplers is not None:
        out["initial.couplers"] = couplers
    if base.track.transitions:
        out["track.transitions"] = []
    if base.track.profile:
        out["track.profile"] = []
        out["track.profile_file"] = None
    if any(c[1] != 0.0 for c in base.track.cant):
        out["track.cant"] = [[0.0, 0.0]]
    out.update(m.overrides)
    return out


def _ramp(m: Manoeuvre, force: float) -> list[list[float]]:
    """A demand of 0 until ``m.at``, rising linearly to ``force`` (N) over ``m.ramp``."""
    if m.ramp == 0.0:
        return [[0.0, 0.0], [m.at, 0.0], [m.at + 1e-6, force]]
    pts = [[0.0, 0.0], [m.at, 0.0], [m.at + m.ramp, force]]
    return pts if m.at > 0.0 else pts[1:]
