"""The air brakes in the right-hand side: the lumped brake (cylinder fills following the
driver's commands with their signal delay) and the fluid-dynamic brake (the brake pipe,
the driver's and control valves, :mod:`ltdsim.physics.air`), whose braking force each
vehicle takes from its cylinder pressure and shoe friction.

Under bs23 the fluid brake's pneumatic states take steps of their own
(:func:`_air_step`): they do not depend on the mechanical states, only on the driver's
commands, and the mechanical right-hand side reads the cylinder pressures from the
pneumatic step's cubic Hermite interpolant (:func:`_fluid_forces`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ltdsim.engine.kernel.structs import (
    AIR_F0, AIR_F1, AIR_FP, AIR_K2, AIR_K3, AIR_Y0, AIR_Y1, AIR_YP, AIR_YT,
)
from ltdsim.engine.kernel.rk import (
    MIN_STEP, max_scaled_error, pair_solution, step_accepted, step_rejected,
)
from ltdsim.engine.features import when
from ltdsim.engine.kernel.tables import _interp_at
from ltdsim.engine.layout import (
    A_AREA, A_ATM, A_COND, A_DIAM, A_GAMMA, A_RGAS, A_RLIN, A_ROUGH, A_TEMP, A_THERMAL,
    A_VISC, BRAKE_FLUID,
    CMD_EMERGENCY, CMD_FAST_FILL, CMD_LAP, CMD_LEVEL, CMD_RELEASE, D_BFULLSUM, D_BMODEL,
    D_BSHOEREF, D_BTAUA,
    D_BTAUR, D_BVS, EV_KIND, EV_LEVEL, EV_TIME, EV_VALUE, I_CELLS, I_DV, I_EXH, I_NCP,
    I_PIPE, V_BAREA, V_BCELL, V_BCV, V_BDELAY, V_BFRIC, V_BFULL, V_BGAIN, V_BINVSHOES,
    V_BMU, V_BNTAB, V_BSHOE, V_BSPRING, V_BTAB, V_BZ,
)
from ltdsim.physics.air.brakepipe import pipe_rates
from ltdsim.physics.air.brakes import (
    FRICTION_CONSTANT, FRICTION_KARWATZKI, karwatzki_mu, retarding_force,
)
from ltdsim.physics.air.brakevalves import (
    CV_CYL, DVP_FULL, N_CV, N_DV,
    H_EMERGENCY, H_FAST_FILL, H_LAP, H_RELEASE, H_SERVICE, control_valve, driver_valve, driver_valve_compressor,
)


@njit(cache=True, inline="always")
def shoe_friction(i, v, shoe_force, veh, ctab):
    """Shoe-wheel friction coefficient of vehicle ``i``'s brake at speed ``v`` (m/s)
    and force per shoe ``shoe_force`` (N)."""
    model = int(veh[i, V_BFRIC])
    if model == FRICTION_KARWATZKI:
        return karwatzki_mu(v, shoe_force)
    if model == FRICTION_CONSTANT:
        return veh[i, V_BMU]
    return _interp_at(ctab, int(veh[i, V_BTAB]), int(veh[i, V_BNTAB]), abs(v))


@njit(cache=True, inline="always")
def brake_target(t, delay, events, n_events):
    """Brake level (0-1) that the latest command to have reached a vehicle with signal
    delay ``delay`` (s) asks for at time ``t`` (s); 0 before any command arrives."""
    e = n_events - 1
    while e >= 0:
        if events[e, EV_TIME] + delay <= t:
            return events[e, EV_LEVEL]
        e -= 1
    return 0.0


@njit(cache=True, _nrt=False, forceinline=True)
def _brakes(t, y, events, n_events, tr, dr, w, dy):
    """Air brakes at time ``t`` (s), every state in ``y``: the lumped brake
    (:func:`_lumped_brakes`) or the fluid brake with its pneumatic states advanced with
    the rest (:func:`_fluid_brakes`, the fixed-step kernel :func:`run`). Nothing when
    the train has no air brakes."""
    if dr.par[D_BMODEL] == BRAKE_FLUID:
        when(tr.features.fluid, _fluid_brakes, None, t, y, events, n_events, tr, dr, w, dy)
    elif dr.par[D_BFULLSUM] > 0.0:
        _lumped_brakes(t, y, events, n_events, tr, dr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _brakes_split(t, y, events, n_events, tr, dr, w, dy):
    """Air brakes at time ``t`` (s) for :func:`run_adaptive`: the lumped brake
    (:func:`_lumped_brakes`) or the fluid brake's forces from its pneumatic states,
    which that kernel advances on their own steps (:func:`_fluid_forces`; ``y`` then
    holds the mechanical states only). Nothing when the train has no air brakes."""
    if dr.par[D_BMODEL] == BRAKE_FLUID:
        when(tr.features.fluid, _fluid_forces, None, t, y, tr, dr, w)
    elif dr.par[D_BFULLSUM] > 0.0:
        _lumped_brakes(t, y, events, n_events, tr, dr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _lumped_brakes(t, y, events, n_events, tr, dr, w, dy):
    """The lumped air brake at time ``t`` (s): each brake-cylinder fill (0-1) follows
    the latest of the commands ``events[:n_events]`` to have reached its vehicle, with
    the apply or release time constant (s); its rate (1/s) goes to ``dy``. The shoe
    force (N) times the shoe friction gives the braking force, written to ``w.bforce``
    (N, + opposing forward motion) and added to ``w.res``."""
    drv = dr.par
    veh = tr.veh
    ctab = tr.tables
    res = w.res
    n = veh.shape[0]
    vs = drv[D_BVS]
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb < 0:
            continue
        v = y[n + i]
        target = brake_target(t, veh[i, V_BDELAY], events, n_events)
        fill = y[zb]
        tau = drv[D_BTAUA] if target > fill else drv[D_BTAUR]
        # (settled within 1e-12: an endless decay to 0 ends in slow subnormals)
        dy[zb] = (target - fill) / tau if abs(target - fill) > 1e-12 else 0.0
        fb = 0.0
        if fill > 0.0:
            shoe = fill * veh[i, V_BSHOE]
            fb = -retarding_force(v, fill * veh[i, V_BFULL]
                                    * shoe_friction(i, v, shoe, veh, ctab), vs)
        w.bforce[i] = fb
        res[i] += fb


@njit(cache=True, inline="always")
def fluid_command(t, events, n_events, full):
    """Handle (``brakevalves.H_*``) and service reduction (Pa) of the driver's valves at
    time ``t`` (s): the latest of ``events[:n_events]`` issued by then (every
    brake-control point at once: the remote units follow the lead by radio). A command
    by level L (``CMD_LEVEL``) is a service reduction of L x ``full`` (Pa), 0 a release;
    lap and fast fill are the valve's positions of those names;
    before any command, release (the pipe charged)."""
    e = n_events - 1
    while e >= 0:
        if events[e, EV_TIME] <= t:
            kind = events[e, EV_KIND]
            if kind == CMD_LEVEL:
                level = events[e, EV_LEVEL]
                if level > 0.0:
                    return H_SERVICE, level * full
                return H_RELEASE, 0.0
            if kind == CMD_RELEASE:
                return H_RELEASE, 0.0
            if kind == CMD_EMERGENCY:
                return H_EMERGENCY, 0.0
            if kind == CMD_LAP:
                return H_LAP, 0.0
            if kind == CMD_FAST_FILL:
                return H_FAST_FILL, 0.0
            return H_SERVICE, events[e, EV_VALUE]
        e -= 1
    return H_RELEASE, 0.0


@njit(cache=True, _nrt=False, forceinline=True)
def _air_rates(t, y, events, n_events, tr, w, dy):
    """The fluid-dynamic air brake's pneumatics at time ``t`` (s): the rates of the brake
    pipe's cell pressures (Pa/s), face flows (kg/s^2) and cell densities (kg/(m^3 s))
    (:func:`~ltdsim.physics.air.brakepipe.pipe_rates`), of every driver's valve's and
    control valve's states (:func:`~ltdsim.physics.air.brakevalves.driver_valve`,
    ``control_valve``, each at its cell's pressure and air temperature ``p / (rho R)``)
    and of the air exhausted to atmosphere (kg/s: vents, exhausts and leaks, less what
    compressors deliver), written to ``dy`` at the states' places in ``y``
    (``tr.air.index``). The driver's valves all take the latest command
    (:func:`fluid_command`). Reads and writes the fluid brake's states only.

    Inlined by LLVM like the other subsystems, and so are the laws it calls (the pipe,
    the valves, the orifice law: ``forceinline``). Compiled once and called instead, the
    two kernels' first compile took as long (73 s of CPU against 66-71 s); the time went
    into numba's own inlining of the laws' bodies (``inline="always"``), and letting
    LLVM inline them instead cut the bs23 kernel's first compile from 45 to 33 s of CPU
    with the same results to the bit."""
    air = tr.air
    gas = air.gas
    idx = air.index
    veh = tr.veh
    inflow = w.inflow
    feed = w.feed
    n = veh.shape[0]
    gamma = gas[A_GAMMA]
    r_gas = gas[A_RGAS]
    temp = gas[A_TEMP]
    atm = gas[A_ATM]
    r_lin = gas[A_RLIN]
    zp = idx[I_PIPE]
    nc = idx[I_CELLS]
    zq = zp + nc
    zr = zq + nc - 1
    zd = idx[I_DV]
    zx = idx[I_EXH]
    p = y[zp:zq]
    rho = y[zr:zr + nc]
    for c in range(nc):
        inflow[c] = 0.0
        feed[c] = 0.0
    exhausted = 0.0
    handle, reduction = fluid_command(t, events, n_events, air.dv[0, DVP_FULL])
    for c in range(idx[I_NCP]):
        o = zd + c * N_DV
        cell = air.dv_cell[c]
        into, out, fed = driver_valve(p[cell], p[cell] / (r_gas * rho[cell]), y[o:o + N_DV],
                                      air.dv[c], handle, reduction, gamma, r_gas, temp, atm,
                                      r_lin, dy[o:o + N_DV])
        inflow[cell] += into
        feed[cell] += fed
        exhausted += out - driver_valve_compressor(y[o:o + N_DV], air.dv[c])
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb < 0:
            continue
        cell = int(veh[i, V_BCELL])
        draw, out, fed = control_valve(p[cell], p[cell] / (r_gas * rho[cell]),
                                       y[zb:zb + N_CV], air.cv[int(veh[i, V_BCV])], gamma,
                                       r_gas, temp, atm, r_lin, dy[zb:zb + N_CV])
        inflow[cell] -= draw
        feed[cell] += fed
        exhausted += out
    leak = pipe_rates(p, y[zq:zq + nc - 1], rho, inflow, feed,
                      (gas[A_AREA], air.dx_cell, air.dx_face, air.volume, gas[A_DIAM],
                       gas[A_ROUGH], gas[A_VISC], gas[A_COND], air.leak),
                      (gamma, r_gas, temp, atm, r_lin, gas[A_THERMAL]),
                      dy[zp:zq], dy[zq:zq + nc - 1], dy[zr:zr + nc])
    dy[zx] = exhausted + leak


@njit(cache=True, _nrt=False, forceinline=True)
def _cylinder_brake(i, p_cyl, v, tr, vs, w):
    """Braking force of vehicle ``i`` at speed ``v`` (m/s) from its brake-cylinder
    pressure ``p_cyl`` (Pa gauge): ``max(0, p x piston area - return spring) x
    efficiency x rigging ratio`` on its shoes, times the shoe friction, through
    :func:`~ltdsim.physics.air.brakes.brake_retardation` (standstill speed ``vs``, m/s).
    Written to ``w.bforce`` (N, + opposing forward motion) and added to ``w.res``."""
    veh = tr.veh
    fc = max(p_cyl * veh[i, V_BAREA] - veh[i, V_BSPRING], 0.0) * veh[i, V_BGAIN]
    fb = 0.0
    if fc > 0.0:
        shoe = fc * veh[i, V_BINVSHOES]
        fb = -retarding_force(v, fc * shoe_friction(i, v, shoe, veh, tr.tables), vs)
    w.bforce[i] = fb
    w.res[i] += fb


@njit(cache=True, _nrt=False, forceinline=True)
def _fluid_brakes(t, y, events, n_events, tr, dr, w, dy):
    """The fluid-dynamic air brake at time ``t`` (s) with its pneumatic states in ``y``
    (the fixed-step kernel :func:`run`): their rates (:func:`_air_rates`) to ``dy``, and
    each braked vehicle's braking force from its cylinder pressure
    (:func:`_cylinder_brake`)."""
    _air_rates(t, y, events, n_events, tr, w, dy)
    veh = tr.veh
    n = veh.shape[0]
    vs = dr.par[D_BVS]
    atm = tr.air.gas[A_ATM]
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb >= 0:
            _cylinder_brake(i, y[zb + CV_CYL] - atm, y[n + i], tr, vs, w)


@njit(cache=True, _nrt=False, forceinline=True)
def _hermite_weights(t, st):
    """Rows of :class:`Work`'s ``air`` array holding ``y0, f0, y1, f1`` and weights
    ``(h00, h10 H, h01, h11 H)`` of the cubic Hermite interpolant at ``t`` (s) over the
    pneumatic step that holds ``t``: the current one ``[t0, t1]`` of the ``AIR_STEPPER``
    record ``st``, or the previous one ``[tp, t0]`` when ``t < t0`` and it is kept
    (``H`` the step's length). The value at ``t`` is ``h00 y0 + h10 H f0 + h01 y1 + h11
    H f1`` from the states ``y`` and rates ``f`` at both ends (the dense output of the
    bs23 pair, third order like its solution; weights of ``y0`` and ``y1`` sum to 1, so
    mass stays conserved). ``t`` is clipped to the step."""
    t0 = st["t0"]
    t1 = st["t1"]
    r0, r1, r2, r3 = AIR_Y0, AIR_F0, AIR_Y1, AIR_F1
    if t < t0 and st["tp"] < t0:
        t1 = t0
        t0 = st["tp"]
        r0, r1, r2, r3 = AIR_YP, AIR_FP, AIR_Y0, AIR_F0
    big_h = t1 - t0
    if big_h <= 0.0:
        return r0, r1, r2, r3, 1.0, 0.0, 0.0, 0.0
    th = min(max((t - t0) / big_h, 0.0), 1.0)
    u = 1.0 - th
    return (r0, r1, r2, r3, (1.0 + 2.0 * th) * u * u, th * u * u * big_h,
            th * th * (3.0 - 2.0 * th), -th * th * u * big_h)


@njit(cache=True, _nrt=False, forceinline=True)
def _fluid_forces(t, y, tr, dr, w):
    """The fluid-dynamic air brake's forces at time ``t`` (s) for :func:`run_adaptive`,
    whose pneumatic states move on their own steps (:func:`_air_step`): each braked
    vehicle's cylinder pressure interpolated in the pneumatic step that holds ``t``
    (:func:`_hermite_weights`), its braking force by :func:`_cylinder_brake` at its
    speed in ``y``."""
    veh = tr.veh
    n = veh.shape[0]
    vs = dr.par[D_BVS]
    atm = tr.air.gas[A_ATM]
    ab = w.air
    r0, r1, r2, r3, a0, a1, a2, a3 = _hermite_weights(t, w.air_step[0])
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb >= 0:
            q = zb + CV_CYL
            pc = a0 * ab[r0, q] + a1 * ab[r1, q] + a2 * ab[r2, q] + a3 * ab[r3, q]
            _cylinder_brake(i, pc - atm, y[n + i], tr, vs, w)


@njit(cache=True, _nrt=False, forceinline=True)
def _air_interpolate(t, tr, w, y):
    """Every pneumatic state at ``t`` (s), interpolated in the pneumatic step that holds
    it (:func:`_hermite_weights`), written to its place in ``y`` (for the records)."""
    ab = w.air
    r0, r1, r2, r3, a0, a1, a2, a3 = _hermite_weights(t, w.air_step[0])
    for q in range(tr.air.index[I_PIPE], ab.shape[1]):
        y[q] = a0 * ab[r0, q] + a1 * ab[r1, q] + a2 * ab[r2, q] + a3 * ab[r3, q]


@njit(cache=True, _nrt=False, forceinline=True)
def _air_start(t, y, tr, w):
    """Start the pneumatic stepping at ``t`` (s) from the pneumatic states in ``y``: a
    step of length 0 at ``t`` (its rates follow from :func:`_air_cut`)."""
    ab = w.air
    st = w.air_step[0]
    for q in range(tr.air.index[I_PIPE], ab.shape[1]):
        ab[AIR_Y0, q] = y[q]
        ab[AIR_Y1, q] = y[q]
        ab[AIR_F0, q] = 0.0
        ab[AIR_F1, q] = 0.0
    st["t0"] = t
    st["t1"] = t
    st["tp"] = t
    st["started"] = True


@njit(cache=True, _nrt=False, forceinline=True)
def _air_cut(t, events, n_events, tr, w):
    """End the pneumatic stepping at ``t`` (s), inside the current pneumatic step or at
    its end, or inside the previous one (the next was taken ahead and is dropped),
    because a brake command was issued at ``t`` (or the stepping starts there,
    :func:`_air_start`): the states at ``t`` interpolated, their rates evaluated with the
    commands issued so far (at the start, the same rates at both ends)."""
    ab = w.air
    st = w.air_step[0]
    z0 = tr.air.index[I_PIPE]
    if t < st["t0"] and st["tp"] < st["t0"]:  # back to the previous step
        for q in range(z0, ab.shape[1]):
            ab[AIR_Y1, q] = ab[AIR_Y0, q]
            ab[AIR_F1, q] = ab[AIR_F0, q]
            ab[AIR_Y0, q] = ab[AIR_YP, q]
            ab[AIR_F0, q] = ab[AIR_FP, q]
        st["t1"] = st["t0"]
        st["t0"] = st["tp"]
    _air_interpolate(t, tr, w, ab[AIR_YT])
    for q in range(z0, ab.shape[1]):
        ab[AIR_Y1, q] = ab[AIR_YT, q]
    _air_rates(t, ab[AIR_Y1], events, n_events, tr, w, ab[AIR_F1])
    if st["t0"] == t:  # a step of length 0 (the start)
        for q in range(z0, ab.shape[1]):
            ab[AIR_Y0, q] = ab[AIR_Y1, q]
            ab[AIR_F0, q] = ab[AIR_F1, q]
    st["t1"] = t
    st["tp"] = st["t0"]  # the steps after t are to be taken anew


@njit(cache=True, _nrt=False, forceinline=True)
def _air_step(t_cap, events, n_events, tr, w, ad):
    """One accepted step of the fluid brake's pneumatic states, on their own from the
    end ``t1`` of the last one, for :func:`run_adaptive`: the bs23 pair of ``ad`` under
    the same error control as the mechanical states (``ad.atol``, ``ad.rtol`` of the
    pneumatic states, max norm, PI step control), at most ``ad.air_h_max`` long and ending
    no later than ``t_cap`` (s). The pneumatics do not depend on the mechanical states
    (only on the driver's commands), so they need not move in the mechanical steps,
    which take far smaller steps when gears and slack are at work: the mechanical right
    hand side reads the cylinder pressures from this step's interpolant
    (:func:`_fluid_forces`), and a command issued inside the step ends it there
    (:func:`_air_cut`). Returns False when no step down to 1e-12 s gives a finite state."""
    ab = w.air
    st = w.air_step[0]
    y0 = ab[AIR_Y0]
    y1 = ab[AIR_Y1]
    f0 = ab[AIR_F0]
    f1 = ab[AIR_F1]
    k2 = ab[AIR_K2]
    yt = ab[AIR_YT]
    z0 = tr.air.index[I_PIPE]
    ny = ab.shape[1]
    A = ad.A
    B = ad.b
    C = ad.c
    E = ad.e
    atol = ad.atol
    rtol = ad.rtol
    t = st["t1"]
    # the pair's stages as rows of the air array, by their offsets in it flat
    # (rk.pair_solution)
    flat = ab.reshape(-1)
    stage_at = (AIR_F0 * ny, AIR_K2 * ny, AIR_K3 * ny)
    error_at = (AIR_F0 * ny, AIR_K2 * ny, AIR_K3 * ny, AIR_F1 * ny)
    yp = ab[AIR_YP]
    fp = ab[AIR_FP]
    for q in range(z0, ny):  # the current step becomes the previous one
        yp[q] = y0[q]
        fp[q] = f0[q]
        y0[q] = y1[q]
        f0[q] = f1[q]
    st["tp"] = st["t0"]
    st["t0"] = t
    h = st["h"]
    while True:
        h_try = min(h, ad.air_h_max)
        hit = False
        if t + h_try >= t_cap:
            h_try = t_cap - t
            hit = True
        # stages 2 and 3, then the rates at the step's end (stage s reads the state
        # row src and writes the rates row dst; one call of the brake's law, so that it
        # is compiled once here)
        finite = True
        for stage in range(1, 4):
            if stage < 3:
                src = AIR_YT
                dst = AIR_K2 if stage == 1 else AIR_K3
                a0, a1 = h_try * A[stage, 0], h_try * A[stage, 1]
                if stage == 1:
                    for q in range(z0, ny):
                        yt[q] = y0[q] + a0 * f0[q]
                else:
                    for q in range(z0, ny):
                        yt[q] = y0[q] + a0 * f0[q] + a1 * k2[q]
                ts = t + C[stage] * h_try
            else:
                src = AIR_Y1
                dst = AIR_F1
                finite = pair_solution(y0, flat, stage_at, h_try, B, z0, ny, y1)
                if not finite:
                    break
                ts = t_cap if hit else t + h_try
            _air_rates(ts, ab[src], events, n_events, tr, w, ab[dst])
        t_new = t_cap if hit else t + h_try
        err = np.inf
        if finite:
            err = max_scaled_error(flat, error_at, h_try, E, z0, ny, y0, y1, atol, rtol)
            if not (err - err == 0.0):
                err = np.inf
        if err <= 1.0:
            st["t1"] = t_new
            st["h"] = step_accepted(st, err, h, h_try, hit)
            return True
        h = step_rejected(st, err, h_try)
        if h < MIN_STEP:
            for q in range(z0, ny):  # the step's start stays the state
                y1[q] = y0[q]
                f1[q] = f0[q]
            st["t1"] = t
            return False


@njit(cache=True, inline="always")
def expected_shoe_friction(v, drv, veh, ctab):
    """Friction coefficient the controller expects at speed ``v`` (m/s): that of the
    first braked vehicle's shoes at the mean full shoe force."""
    for i in range(veh.shape[0]):
        if veh[i, V_BZ] >= 0:
            return shoe_friction(i, v, drv[D_BSHOEREF], veh, ctab)
    return 0.0
