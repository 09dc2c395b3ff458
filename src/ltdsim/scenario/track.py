"""``[track]``: grades, curves, transitions, cant or a profile file, and ``[curving]``, the
curving-safety indicators computed after a run.
"""

from __future__ import annotations


from pydantic import (
    Field,
    field_validator,
    model_validator,
)


from ltdsim.scenario._base import MAX_CHAINAGE, Points, Triple, _Strict, _check_chainages, _check_table


class Track(_Strict):
    """Track as piecewise-constant functions of position along the line."""

    gradient: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                             description="[start position m, grade -] pieces, grade = rise/run, "
                                         "+ uphill in the direction of travel; starts strictly "
                                         f"increasing, within +-{MAX_CHAINAGE:g} m, grades "
                                         "in [-0.1, 0.1]; the first piece also covers "
                                         "everything before it")
    curve: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                          description="[start position m, radius m] pieces; starts strictly "
                                      f"increasing, within +-{MAX_CHAINAGE:g} m, radius "
                                      "0 (straight) or 20 to 1e6, + turning left, - "
                                      "turning right (the side matters to the curving "
                                      "indicators only)")
    transitions: Points = Field([], description="[position m, length m] clothoids: the "
                                                "curvature step of `curve` at that position "
                                                "becomes a ramp, linear in distance, from "
                                                "there over the length (each position a "
                                                "break of `curve`; the ramp ends before the "
                                                "next break), positions within "
                                                f"+-{MAX_CHAINAGE:g} m")
    cant: Points = Field(default_factory=lambda: [(0.0, 0.0)],
                         description="[position m, cant m] height of the outer rail over the "
                                     "inner, linear between the points and constant beyond "
                                     "them, 0 to 0.2 m, positions within "
                                     f"+-{MAX_CHAINAGE:g} m; it leans towards the "
                                     "centre of the curve at each place")
    profile_file: str | None = Field(None, description="CSV of chainage m, curvature 1/m "
                                                       "(+ left), cant m, one point a line, "
                                                       "linear between points; replaces "
                                                       "curve, transitions and cant (a path "
                                                       "relative to the scenario file)")
    profile: list[Triple] = Field([], description="[chainage m, curvature 1/m, cant m] "
                                                  "points as profile_file gives them (filled "
                                                  "from it at load time), chainages "
                                                  f"within +-{MAX_CHAINAGE:g} m")
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
        _check_chainages([p[0] for p in v], "start positions, m")
        return _check_table(v, "start positions, m", lambda g: abs(g) <= 0.1, "in [-0.1, 0.1] (rise/run)")

    @field_validator("curve")
    @classmethod
    def _curves(cls, v):
        _check_chainages([p[0] for p in v], "start positions, m")
        return _check_table(v, "start positions, m", lambda r: r == 0.0 or 20.0 <= abs(r) <= 1e6,
                            "0 (straight) or radii of 20-1e6 m")

    @field_validator("cant")
    @classmethod
    def _cants(cls, v):
        _check_chainages([p[0] for p in v], "positions, m")
        return _check_table(v, "positions, m", lambda h: 0.0 <= h <= 0.2, "in [0, 0.2] m")

    @field_validator("transitions")
    @classmethod
    def _transitions(cls, v):
        _check_chainages([p[0] for p in v], "positions, m")
        return v

    @field_validator("profile")
    @classmethod
    def _profile(cls, v):
        xs = [p[0] for p in v]
        _check_chainages(xs, "chainages, m")
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

    def resistance_curve(self, reach: tuple[float, float] | None = None) -> Points:
        """The ``curve`` table the kernel's curve resistance reads: ``curve`` itself when
        the alignment has no transitions or profile, otherwise the alignment's curvature
        averaged over steps of at most 5 m (the ramps keep their integral of curvature,
        so the curve resistance summed over them is that of the alignment), m and m;
        with ``reach`` (from m, to m) the steps cover that stretch only (the alignment's
        values beyond it are its values at its ends), so that a profile reaching
        10,000 km costs only the steps the run can reach."""
        if not self.transitions and not self.profile:
            return self.curve
        from ltdsim.physics.alignment import alignment_of

        align = alignment_of(self)
        if reach is not None:
            align = align.clipped(*reach)
        return align.step_table(5.0)


class Curving(_Strict):
    """Curving-safety indicators computed after the run (ltdsim.results.safety): coupler angles,
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
