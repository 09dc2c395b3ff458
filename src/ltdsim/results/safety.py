"""Curving safety after the run: the track in the plane, each vehicle body on it, the
coupler angles, the lateral components of the coupler forces and the wheel L/V they
cause.

The model is kinematic and quasi-static, and it is evaluated on the recorded positions,
speeds and coupler forces of a run rather than inside the compiled kernel: the lateral
balance does not act back on the longitudinal dynamics (the study's model has no lateral
degrees of freedom), so computing it afterwards gives the same numbers at the cost of one
vectorised pass over the records, and leaves the kernel untouched. Assumptions:

* the track's centre line is a plane curve whose curvature is piecewise linear in
  distance (straights, circular arcs, clothoid transitions); heading and position follow
  from integrating it (Gauss-Legendre on pieces of at most a few metres: exact to
  rounding);
* each vehicle body is the chord between its two bogie centres, which sit on the centre
  line half the bogie spacing (measured along the track) ahead of and behind the
  recorded position of the vehicle's centre;
* each coupler pivot lies on its body's axis ``pivot_overhang`` beyond the bogie centre;
  the coupler is the straight bar between the two pivots it joins, its length taken from
  the recorded positions (it includes the slack and the gear travel);
* the coupler force acts along that bar; the body is in quasi-static lateral and yaw
  equilibrium under the lateral components of its two coupler forces, the unbalanced
  centrifugal force (cant deficiency) of half its mass at each bogie, and the lateral
  forces of its two bogies, which the track takes;
* the roll moment of these lateral forces (the centrifugal force at the centre of gravity,
  the coupler components at the coupler height) shifts load from one rail to the other,
  shared evenly by all wheelsets of the vehicle;
* a share (``curving.leading_share``) of each bogie's lateral force goes through its
  leading wheelset and is taken whole by the flanging wheel; the wheel L/V is that force
  over that wheel's load.

Sign conventions: lateral ``+`` left of the direction of travel inside the computation;
curvature ``+`` for a curve turning left. Results an engineer reads are given towards
the inside (``+``) or outside of the curve where that is the question.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ltdsim.physics.curving import (
    body_lateral_balance,
    lateral_acceleration,
    nadal_limit,
    prudhomme_limit,
    wheel_l_over_v,
)

from ltdsim.physics.alignment import Alignment, alignment_of, reach


@dataclass
class TrainGeometry:
    """Per-vehicle geometry arrays (m, -), front to rear."""

    half_b: np.ndarray      # half the bogie spacing, m
    overhang: np.ndarray    # bogie centre to coupler pivot, m
    h_coupler: np.ndarray   # coupler height, m
    h_cg: np.ndarray        # centre of gravity height, m
    axles: np.ndarray       # axles per vehicle, -
    mass: np.ndarray        # static mass, kg

    @classmethod
    def of(cls, vehicles) -> TrainGeometry:
        gs = [v.resolved_geometry() for v in vehicles]
        return cls(half_b=np.array([0.5 * g.bogie_spacing for g in gs]),
                   overhang=np.array([g.pivot_overhang for g in gs]),
                   h_coupler=np.array([g.coupler_height for g in gs]),
                   h_cg=np.array([g.cg_height for g in gs]),
                   axles=np.array([g.axles for g in gs], dtype=float),
                   mass=np.array([v.weight_mass for v in vehicles]))


@dataclass
class CurvingState:
    """Curving quantities at a set of instants (first axis) and vehicles or couplers."""

    coupler_angle: np.ndarray           # (t, coupler, 2) yaw to the body ahead, behind; rad
    coupler_lateral_front: np.ndarray   # (t, vehicle) coupler component at the front pivot, N + left
    coupler_lateral_rear: np.ndarray    # (t, vehicle) at the rear pivot, N + left
    bogie_load: np.ndarray              # (t, vehicle, 2) lateral load applied at each bogie, N + left
    bogie_force: np.ndarray             # (t, vehicle, 2) force of each bogie on the body, N + left
    wheelset_force: np.ndarray          # (t, vehicle, 2) leading wheelset on the track, N + left
    wheel_load: np.ndarray              # (t, vehicle, 2) left and right wheel load, N
    l_over_v: np.ndarray                # (t, vehicle, 2) flanging wheel L/V per bogie, -
    inward: np.ndarray                  # (t, coupler) +1 / -1: the side of the turn (left +)
    body_heading: np.ndarray            # (t, vehicle) rad
    pivots: np.ndarray                  # (t, vehicle, 2 ends, 2 xy) m
    bogies: np.ndarray                  # (t, vehicle, 2 ends, 2 xy) m


def curving_state(align: Alignment, geo: TrainGeometry, position, speed, coupler_force,
                  share: float, rail_spacing: float, g: float) -> CurvingState:
    """The curving quantities of a train at the recorded instants.

    Parameters
    ----------
    align : Alignment
    geo : TrainGeometry
    position : array (t, vehicle)
        Chainage of each vehicle's centre, m.
    speed : array (t, vehicle)
        Vehicle speed, m/s.
    coupler_force : array (t, coupler)
        Coupler force, N (+ tension).
    share : float
        Share of a bogie's lateral force on its leading wheelset, -.
    rail_spacing : float
        Contact-point distance of a wheelset, m.
    g : float
        Gravitational acceleration, m/s^2.
    """
    x = np.atleast_2d(np.asarray(position, dtype=float))
    v = np.atleast_2d(np.asarray(speed, dtype=float))
    f = np.atleast_2d(np.asarray(coupler_force, dtype=float)).reshape(x.shape[0], -1)
    nt, n = x.shape
    hb = geo.half_b
    # bogie centres on the centre line
    bx, by, _ = align.pose(np.stack([x + hb, x - hb], axis=-1))  # (t, n, 2): front, rear
    ex, ey = bx[..., 0] - bx[..., 1], by[..., 0] - by[..., 1]
    norm = np.hypot(ex, ey)
    ex, ey = ex / norm, ey / norm  # body axis, forward
    heading = np.arctan2(ey, ex)
    a = geo.overhang
    piv = np.empty((nt, n, 2, 2))
    piv[:, :, 0, 0] = bx[..., 0] + a * ex
    piv[:, :, 0, 1] = by[..., 0] + a * ey
    piv[:, :, 1, 0] = bx[..., 1] - a * ex
    piv[:, :, 1, 1] = by[..., 1] - a * ey
    # coupler j: from the rear pivot of vehicle j to the front pivot of vehicle j + 1
    angle = np.zeros((nt, n - 1, 2))
    lat_front = np.zeros((nt, n))
    lat_rear = np.zeros((nt, n))
    inward = np.ones((nt, n - 1))
    if n > 1:
        dx = piv[:, :-1, 1, 0] - piv[:, 1:, 0, 0]  # bar pointing forward: j+1 front -> j rear
        dy = piv[:, :-1, 1, 1] - piv[:, 1:, 0, 1]
        bar = np.arctan2(dy, dx)
        ahead = _wrap(bar - heading[:, :-1])    # bar's yaw to the body ahead, + left
        behind = _wrap(bar - heading[:, 1:])    # to the body behind
        angle[..., 0], angle[..., 1] = ahead, behind
        # tension pulls the body ahead backwards along the bar: its lateral part is
        # -F sin(ahead); it pulls the body behind forwards: +F sin(behind)
        lat_rear[:, :-1] = -f * np.sin(ahead)
        lat_front[:, 1:] = f * np.sin(behind)
        turn = heading[:, :-1] - heading[:, 1:]
        kmid = align.curvature(0.5 * (x[:, :-1] + x[:, 1:]))
        inward = np.where(np.abs(turn) > 1e-12, np.sign(turn), np.where(kmid < 0, -1.0, 1.0))
    # unbalanced lateral acceleration at each bogie
    pos_b = np.stack([x + hb, x - hb], axis=-1)
    acc = lateral_acceleration(v[..., None], align.curvature(pos_b), align.cant(pos_b),
                               rail_spacing, g)
    half_m = 0.5 * geo.mass[None, :, None]
    bl = half_m * acc
    # the lever arms are along the chord: half of it to a bogie, plus the overhang
    yf, yr = body_lateral_balance(lat_front, lat_rear, bl[..., 0], bl[..., 1], 0.5 * norm, a)
    bogie = np.stack([yf, yr], axis=-1)
    # wheel loads: weight in the track plane plus the roll moment of the lateral loads,
    # shared by all wheelsets; left wheels gain what right wheels lose
    cant_c = align.cant(x)
    kap_c = align.curvature(x)
    sphi = cant_c / rail_spacing
    cphi = np.sqrt(1.0 - sphi * sphi)
    normal = geo.mass * (g * cphi + v ** 2 * np.abs(kap_c) * sphi)
    roll = geo.h_cg * bl.sum(-1) + geo.h_coupler * (lat_front + lat_rear)  # N m, + leans left
    dq = roll / (rail_spacing * geo.axles)
    q0 = normal / (2.0 * geo.axles)
    wheel = np.stack([q0 + dq, q0 - dq], axis=-1)
    ws = -share * bogie  # the wheelset pushes the track opposite to the bogie's force on the body
    lv = wheel_l_over_v(ws, wheel[..., 0:1], wheel[..., 1:2])
    return CurvingState(coupler_angle=angle, coupler_lateral_front=lat_front,
                        coupler_lateral_rear=lat_rear, bogie_load=bl, bogie_force=bogie,
                        wheelset_force=ws, wheel_load=wheel, l_over_v=lv, inward=inward,
                        body_heading=heading, pivots=piv,
                        bogies=np.stack([bx, by], axis=-1))


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


# ------------------------------------------------------------------------ a run
def add_curving(ds: xr.Dataset, scenario, chunk: int = 2000) -> xr.Dataset:
    """Add the curving variables of run ``ds`` of ``scenario`` (which has ``[curving]``):
    ``coupler_angle``, ``coupler_lateral_force`` (time x coupler), ``wheel_l_over_v``,
    ``wheelset_lateral_force`` (time x vehicle), their limits and the worst place."""
    cfg = scenario.curving
    align = alignment_of(scenario.track)
    geo = TrainGeometry.of(scenario.vehicles)
    g = scenario.track.gravity
    pos = ds["position"].values
    if np.isfinite(pos).any():  # the track over the stretch the run covered only
        align = align.clipped(*reach(float(np.nanmin(pos)), float(np.nanmax(pos))))
    vel = ds["velocity"].values
    n = pos.shape[1]
    f = ds["coupler_force"].values if n > 1 else np.zeros((pos.shape[0], 0))
    nt = pos.shape[0]
    ang = np.zeros((nt, max(n - 1, 0)))
    clat = np.zeros((nt, max(n - 1, 0)))
    lv = np.zeros((nt, n))
    hws = np.zeros((nt, n))
    for lo in range(0, nt, chunk):
        hi = min(nt, lo + chunk)
        st = curving_state(align, geo, pos[lo:hi], vel[lo:hi], f[lo:hi], cfg.leading_share,
                           scenario.track.rail_spacing, g)
        if n > 1:
            a = st.coupler_angle
            pick = np.abs(a[..., 0]) >= np.abs(a[..., 1])
            big = np.where(pick, np.abs(a[..., 0]), np.abs(a[..., 1]))
            ang[lo:hi] = big
            # lateral component on the body where it is larger, + towards the inside
            comp_ahead = st.coupler_lateral_rear[:, :-1]
            comp_behind = st.coupler_lateral_front[:, 1:]
            comp = np.where(pick, comp_ahead, comp_behind)
            clat[lo:hi] = comp * st.inward
        worst = np.argmax(st.l_over_v, axis=-1)
        lv[lo:hi] = np.take_along_axis(st.l_over_v, worst[..., None], -1)[..., 0]
        hws[lo:hi] = np.max(np.abs(st.wheelset_force), axis=-1)
    nadal = float(nadal_limit(math.radians(cfg.flange_angle), cfg.flange_friction))
    axle = geo.mass * g / geo.axles
    prud = prudhomme_limit(axle, cfg.prudhomme_alpha)
    out = ds.copy()
    cd, vd = ("time", "coupler"), ("time", "vehicle")
    out["coupler_angle"] = (cd, ang, {
        "units": "rad", "long_name": "yaw angle of the coupler to the body it turns most "
                                     "against (the larger of its two)"})
    out["coupler_lateral_force"] = (cd, clat, {
        "units": "N", "long_name": "lateral component of the coupler force on that body, + "
                                   "towards the inside of the curve (draft), - outwards "
                                   "(buff)"})
    out["wheel_l_over_v"] = (vd, lv, {
        "units": "1", "long_name": "L/V of the flanging wheel of the worse leading wheelset "
                                   "of the vehicle (inf where that wheel has no load left: "
                                   "wheel lift, its L/V undefined)"})
    out["wheelset_lateral_force"] = (vd, hws, {
        "units": "N", "long_name": "largest lateral force of a leading wheelset of the "
                                   "vehicle on the track (magnitude)"})
    out["nadal_limit"] = ((), nadal, {"units": "1", "long_name": "Nadal's L/V limit"})
    out["prudhomme_limit"] = (("vehicle",), prud, {
        "units": "N", "long_name": "Prud'homme's wheelset lateral-force limit"})
    return out


# ------------------------------------------------------------------------ curve-limit
@dataclass
class CurveLimit:
    """Largest steady buff force a pair of vehicles carries on a curve (N; inf where the
    limit is not reached below the search bound, 0 where it is exceeded without force)."""

    buff_force: float            # N, L/V of the worse wheel reaches Nadal's limit
    limit: float                 # Nadal's L/V limit, -
    l_over_v_at_zero: float      # worse wheel's L/V with no coupler force, -
    governing: str               # "front" or "rear" vehicle of the pair at that force
    buff_force_prudhomme: float  # N, a leading wheelset's force reaches Prud'homme's limit
    prudhomme: tuple             # Prud'homme limit of the front and rear vehicle, N


def _pair_state(front, rear, radius, cant, speed, buff, share, rail_spacing, g):
    """Curving state of ``front, front, rear, rear`` on a circle in steady buff (N, each
    of the three couplers), for an array of buff forces; vehicles 1 and 2 are the pair."""
    vehicles = [front, front, rear, rear]
    geo = TrainGeometry.of(vehicles)
    lengths = np.array([v.length for v in vehicles])
    centres = 1000.0 - np.concatenate(([0.0], np.cumsum(0.5 * (lengths[:-1] + lengths[1:]))))
    align = Alignment.from_knots([0.0, 2000.0], [1.0 / radius], [1.0 / radius], [cant],
                                 [cant])
    buff = np.atleast_1d(np.asarray(buff, dtype=float))
    k = buff.size
    return curving_state(align, geo, np.broadcast_to(centres, (k, 4)),
                         np.full((k, 4), float(speed)), -np.repeat(buff[:, None], 3, axis=1),
                         share, rail_spacing, g)


def pair_l_over_v(front, rear, radius, cant, speed, buff, share, rail_spacing,
                  g) -> np.ndarray:
    """L/V of the worse wheel of ``front`` and of ``rear`` (two scenario vehicles),
    coupled on a circular curve of ``radius`` (m, + left) with ``cant`` (m) at ``speed``
    (m/s), with a steady buff force ``buff`` (N, >= 0, scalar or array) in every coupler:
    the front vehicle follows another like it and the rear one leads another like it.
    ``share`` of each coupler's lateral force on its leading wheelset (-),
    ``rail_spacing`` (m) and gravity ``g`` (m/s^2) as in the scenario (``[curving]``,
    ``track``). Returns an array (forces, 2)."""
    st = _pair_state(front, rear, radius, cant, speed, buff, share, rail_spacing, g)
    return st.l_over_v[:, 1:3].max(axis=-1)


def curve_limit(front, rear, radius, cant, speed, flange_angle_deg, friction, share,
                rail_spacing, g, prudhomme_alpha, f_max=5.0e7) -> CurveLimit:
    """The largest steady buff force (N) the coupler between vehicles ``front`` and
    ``rear`` may carry on a circular curve (``radius`` m, ``cant`` m, ``speed`` m/s)
    before the worse wheel's L/V reaches Nadal's limit (``flange_angle_deg``,
    ``friction``), and before a leading wheelset's lateral force reaches Prud'homme's
    limit (``prudhomme_alpha``): roots by Brent's method on [0, ``f_max``] N."""
    from scipy.optimize import brentq

    lim = float(nadal_limit(math.radians(flange_angle_deg), friction))
    geo = TrainGeometry.of([front, rear])
    prud = prudhomme_limit(geo.mass * g / geo.axles, prudhomme_alpha)

    def lv(fb):
        return pair_l_over_v(front, rear, radius, cant, speed, fb, share, rail_spacing, g)[0]

    def hratio(fb):
        st = _pair_state(front, rear, radius, cant, speed, fb, share, rail_spacing, g)
        return float(np.max(np.abs(st.wheelset_force[0, 1:3]).max(axis=-1) / prud))

    def root(fun, target):
        if fun(0.0) >= target:
            return 0.0
        if fun(f_max) < target:
            return math.inf
        return brentq(lambda x: fun(x) - target, 0.0, f_max, xtol=1.0, rtol=1e-12)

    fb = root(lambda x: float(np.max(lv(x))), lim)
    fp = root(hratio, 1.0)
    at = lv(fb if math.isfinite(fb) else f_max)
    return CurveLimit(buff_force=fb, limit=lim, l_over_v_at_zero=float(np.max(lv(0.0))),
                      governing="front" if at[0] >= at[1] else "rear",
                      buff_force_prudhomme=fp, prudhomme=(float(prud[0]), float(prud[1])))
