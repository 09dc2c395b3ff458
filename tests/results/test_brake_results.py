"""What an engineer reads from a fluid-brake run: the propagation speed of an application
along the train and the cylinders' 95 % times (ltdsim.results.summary.fluid_brake_summary),
checked on synthetic results whose arrival and filling times are known in closed form,
and the pressure figure (ltdsim.viz.plotting)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

from ltdsim.results.summary import CYLINDER_SHARE, PIPE_DROP, VENTED, fluid_brake_summary

P0 = 5.0e5  # Pa gauge, a charged pipe
P_CYL = 3.8e5  # Pa gauge, a full cylinder


def synthetic(lengths, speed, t_cmd, *, sources=(0,), drop=5.0e5, ramp=1.0, fill=20.0,
              dt=0.01, t_end=None, braked=None, delays=None, command=True, exp_tau=None):
    """A result whose brake pipe at vehicle i falls linearly by ``drop`` (Pa) over
    ``ramp`` (s) from t_cmd + d_i / speed, d_i the distance from the nearest of
    ``sources`` (vehicle indices; ``delays`` s each, default 0), and whose cylinder rises
    from its pipe's start of fall: linearly to P_CYL over ``fill`` s, or with ``exp_tau``
    as P_CYL (1 - exp(-t / tau)). Vehicle centres from ``lengths`` (m)."""
    lengths = np.asarray(lengths, float)
    n = lengths.size
    x0 = -(np.cumsum(lengths) - 0.5 * lengths)  # centres, lead at -L1/2, rear behind
    delays = np.zeros(len(sources)) if delays is None else np.asarray(delays, float)
    start = np.min(np.abs(x0[:, None] - x0[list(sources)][None, :]) / speed + delays, axis=1)
    start = t_cmd + start
    if t_end is None:
        t_end = start.max() + ramp + fill + 10.0
    t = np.arange(0.0, t_end + dt / 2, dt)
    s = (t[:, None] - start[None, :])
    pipe = P0 - drop * np.clip(s / ramp, 0.0, 1.0)
    if exp_tau is None:
        cyl = P_CYL * np.clip(s / fill, 0.0, 1.0)
    else:
        cyl = P_CYL * (1.0 - np.exp(-np.clip(s, 0.0, None) / exp_tau))
    if braked is not None:
        cyl[:, ~np.asarray(braked, bool)] = np.nan
    data = {"position": (("time", "vehicle"), np.broadcast_to(x0, (t.size, n)).copy()),
            "brake_pipe_pressure": (("time", "vehicle"), pipe),
            "brake_cylinder_pressure": (("time", "vehicle"), cyl)}
    if command:
        data["brake_command"] = ("time", (t >= t_cmd).astype(float))
    ds = xr.Dataset(data, coords={"time": t, "vehicle": np.arange(n)})
    return ds, start, x0


@settings(max_examples=40, deadline=None)
@given(n=st.integers(3, 80), speed=st.floats(80.0, 400.0), t_cmd=st.floats(0.5, 5.0),
       length=st.floats(10.0, 25.0), ramp=st.floats(0.3, 3.0), drop=st.floats(1.0e5, 5.0e5))
def test_propagation_speed_is_the_slope_of_arrival_against_distance(n, speed, t_cmd, length,
                                                                    ramp, drop):
    """A pipe drop that sets off from each vehicle d / c after the command: the summary's
    speed is c, its arrival times t_cmd + d / c + ramp x threshold / drop (the linear fall
    reaches the threshold that far into its ramp), and the end-to-end time to the rear
    is that arrival at the farthest vehicle."""
    lengths = np.full(n, length)
    ds, start, x0 = synthetic(lengths, speed, t_cmd, drop=drop, ramp=ramp, dt=0.01)
    out = fluid_brake_summary(ds, control_points=[0])
    delay = ramp * PIPE_DROP / drop
    t = ds.time.values
    assert out["command_time_s"] == t[np.argmax(t >= t_cmd)]  # the first sample that sees it
    expect = start + delay - out["command_time_s"]
    np.testing.assert_allclose(out["arrival_s"], expect, atol=1e-6)
    assert out["propagation_speed_m_s"] == pytest.approx(speed, rel=1e-6)
    assert out["propagation_fit_rms_s"] < 1e-6
    assert out["farthest_vehicle"] == n - 1
    assert out["farthest_distance_m"] == pytest.approx((n - 1) * length)
    assert out["propagation_time_s"] == pytest.approx(expect[-1], abs=1e-6)
    assert out["end_to_end_speed_m_s"] == pytest.approx((n - 1) * length / expect[-1],
                                                        rel=1e-6)
    assert out["end_to_end_speed_m_s"] < speed  # the threshold's delay counts end to end
    # the vent front: the rear's pipe below VENTED (gauge) ramp (P0 - VENTED) / drop into
    # its fall, when the drop goes that deep; a shallower (service) drop has none
    # (linear interpolation between samples is exact on the ramp, not across its end)
    if drop > 1.04 * (P0 - VENTED):  # crossed a sample or more before the ramp ends
        t_vent = start[-1] + ramp * (P0 - VENTED) / drop - out["command_time_s"]
        assert out["vent_time_s"] == pytest.approx(t_vent, abs=1e-6)
        assert out["vent_front_speed_m_s"] == pytest.approx((n - 1) * length / t_vent,
                                                            rel=1e-6)
    elif drop < P0 - VENTED - 1.0:
        assert math.isnan(out["vent_front_speed_m_s"])


@settings(max_examples=25, deadline=None)
@given(n=st.integers(3, 60), fill=st.floats(1.0, 40.0), speed=st.floats(150.0, 350.0))
def test_cylinder_95_percent_time(n, fill, speed):
    """Cylinders that fill linearly over ``fill`` s from their pipe's fall: 95 % at
    0.95 fill after it; the rear is the last braked vehicle, also when the locomotives at
    either end carry no cylinder (NaN)."""
    braked = np.ones(n, bool)
    braked[0] = braked[-1] = False
    ds, start, _ = synthetic(np.full(n, 15.0), speed, 1.0, fill=fill, braked=braked)
    out = fluid_brake_summary(ds, control_points=[0])
    t_cmd = out["command_time_s"]
    rear = n - 2
    assert out["last_vehicle"] == rear
    assert out["last_cylinder_final_Pa"] == pytest.approx(P_CYL)
    assert out["last_cylinder_95_s"] == pytest.approx(start[rear] + CYLINDER_SHARE * fill
                                                      - t_cmd, abs=1e-6)
    assert out["last_cylinder_settled"]
    assert np.isnan(out["cylinder_95_s"][[0, -1]]).all()
    assert out["slowest_vehicle"] == rear


def test_unsettled_cylinder_is_flagged_and_its_time_follows_its_last_pressure():
    """An exponential fill (tau 8 s) cut off 10 s after it began: the final pressure is
    the last recorded one, P (1 - e^-1.25), its 95 % point t = -tau ln(1 - 0.95 (1 -
    e^-1.25)), and the cylinder is flagged as not settled; given 80 s it is settled and
    reaches 95 % of P at tau ln 20."""
    tau = 8.0
    ds, start, _ = synthetic([20.0, 15.0, 15.0], 250.0, 1.0, exp_tau=tau, t_end=None)
    cut = ds.sel(time=slice(0.0, start[-1] + 10.0))
    out = fluid_brake_summary(cut, control_points=[0])
    frac = 1.0 - np.exp(-(cut.time.values[-1] - start[-1]) / tau)
    expect = start[-1] - tau * np.log(1.0 - CYLINDER_SHARE * frac) - out["command_time_s"]
    assert out["last_cylinder_95_s"] == pytest.approx(expect, abs=2e-4)
    assert not out["last_cylinder_settled"]
    ds, start, _ = synthetic([20.0, 15.0, 15.0], 250.0, 1.0, exp_tau=tau, t_end=start[-1] + 80)
    out = fluid_brake_summary(ds, control_points=[0])
    assert out["last_cylinder_settled"]
    assert out["last_cylinder_95_s"] == pytest.approx(
        start[-1] + tau * np.log(20.0) - out["command_time_s"], abs=0.05)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(40, 120), where=st.floats(0.3, 0.8), speed=st.floats(150.0, 350.0),
       late=st.floats(0.0, 0.5))
def test_remote_venting_counts_distance_from_the_source_that_reaches_it_first(n, where, speed,
                                                                            late):
    """Lead and a remote point vent, the remote later by ``late`` x the lead wave's travel
    time to it (a radio link's delay): each vehicle's distance is to the source whose
    wave reaches it first (the nearer one, unless the remote's delay lets the lead's
    wave win), and the speed is still c (the remote's waves ahead and behind it get
    their own intercepts, so its delay does not tilt the slope); the farthest vehicle is
    the one farthest from its source. A remote point the wave only passes (it did not vent) is
    no source, and then distances run from the lead alone."""
    remote = int(where * (n - 1))
    lengths = np.full(n, 12.0)
    lengths[remote] = 22.6  # a locomotive
    x0 = -(np.cumsum(lengths) - 0.5 * lengths)
    delay = late * (x0[0] - x0[remote]) / speed
    ds, start, x0 = synthetic(lengths, speed, 2.0, sources=(0, remote), delays=(0.0, delay))
    out = fluid_brake_summary(ds, control_points=[0, remote])
    assert out["sources"] == [0, remote]
    to_lead, to_remote = np.abs(x0 - x0[0]), np.abs(x0 - x0[remote])
    d = np.where(to_lead / speed <= to_remote / speed + delay, to_lead, to_remote)
    np.testing.assert_allclose(out["distance_m"], d)
    assert out["propagation_speed_m_s"] == pytest.approx(speed, rel=1e-6)
    assert out["farthest_distance_m"] == pytest.approx(d.max())
    ds, _, _ = synthetic(lengths, speed, 2.0, sources=(0,))
    out = fluid_brake_summary(ds, control_points=[0, remote])
    assert out["sources"] == [0]
    assert out["propagation_speed_m_s"] == pytest.approx(speed, rel=1e-6)
    assert out["farthest_vehicle"] == n - 1


def test_without_a_command_the_pipe_at_the_lead_marks_the_application():
    """No ``brake_command`` in the result: the application starts when the pipe at the
    lead has fallen by the threshold, so the lead's arrival is 0 s and the end-to-end
    time is the wave's travel alone; the speed is unchanged."""
    ds, start, x0 = synthetic(np.full(30, 15.0), 270.0, 3.0, command=False)
    out = fluid_brake_summary(ds, control_points=[0])
    assert out["command_time_s"] == pytest.approx(3.0 + PIPE_DROP / 5.0e5, abs=1e-6)
    assert out["arrival_s"][0] == pytest.approx(0.0, abs=1e-6)
    assert out["propagation_time_s"] == pytest.approx(29 * 15.0 / 270.0, abs=1e-6)
    assert out["propagation_speed_m_s"] == pytest.approx(270.0, rel=1e-6)


def test_a_release_ends_the_application_window():
    """A release 6 s after the command (the command falls to 0) while the cylinders fill
    over 20 s: the final pressure is the one at the release, so the 95 % time is that of
    the cut ramp (0.95 of the time filled by then)."""
    ds, start, _ = synthetic([20.0, 15.0], 300.0, 1.0, fill=20.0)
    t = ds.time.values
    ds["brake_command"] = ("time", ((t >= 1.0 - 1e-9) & (t < 7.0 - 1e-9)).astype(float))
    out = fluid_brake_summary(ds, control_points=[0])
    end = out["end_time_s"]
    assert end == pytest.approx(7.0 - 0.01, abs=1e-6)
    filled = end - start[-1]
    assert out["last_cylinder_final_Pa"] == pytest.approx(P_CYL * filled / 20.0, rel=1e-9)
    assert out["last_cylinder_95_s"] == pytest.approx(
        start[-1] + CYLINDER_SHARE * filled - out["command_time_s"], abs=1e-6)


def test_no_fluid_brake_or_no_application_gives_none():
    ds, _, _ = synthetic(np.full(5, 15.0), 250.0, 1.0)
    assert fluid_brake_summary(ds.drop_vars("brake_pipe_pressure")) is None
    flat = ds.assign(brake_pipe_pressure=ds.brake_pipe_pressure * 0 + P0).drop_vars(
        "brake_command")
    assert fluid_brake_summary(flat) is None


# ----------------------------------------------------------------- on real runs
C_ISOTHERMAL = math.sqrt(287.05 * 293.15)  # m/s, sqrt(R T) of the scenario's default air


def pipe_train(n: int, remote: int | None = None, thermal: str = "adiabatic") -> dict:
    """A braked locomotive and ``n`` unbraked 14.4 m wagons (with ``remote``, a second,
    unbraked locomotive at that index, a brake-control point too), a frictionless pipe
    (``brake.air.viscosity = 0``) of the bore alone (no hoses, no branch at the
    locomotive's valve) whose air is ``thermal`` (``brake.air.thermal``), standing; an
    emergency at 0.2 s."""
    loco = {"name": "loco", "mass": 9e4, "length": 19.0, "powered": True}
    vehicles = [dict(loco, brake={"cylinder_force": 40500.0, "rigging_ratio": 2.6,
                                  "friction": 0.3})]
    if remote is None:
        vehicles.append({"name": "wagon", "count": n, "mass": 9e4, "length": 14.4})
    else:
        vehicles += [{"name": "wagon", "count": remote - 1, "mass": 9e4, "length": 14.4},
                     dict(loco, name="remote"),
                     {"name": "wagon", "count": n - remote + 1, "mass": 9e4, "length": 14.4}]
    d = {"solver": {"method": "bs23", "dt": 1e-4, "t_end": 0.2 + (n * 14.4 + 19.0) / 250.0,
                    "output_interval": 0.01, "rtol": 1e-4, "atol": 1e-5, "max_step": 0.05},
         "vehicles": vehicles,
         "couplers": {"default": {"model": "linear", "stiffness": 5e7, "damping": 2e5}},
         "traction": {"max_force": 3e5, "max_power": 6.4e6, "adhesion_mass": 9e4},
         "brake": {"model": "fluid",
                   "fluid": {"valve": {"preset": "uic-g",
                                       "control_valve": {"branch_volume": 0.0}},
                             "hose_volume": 0.0},
                   "air": {"viscosity": 0.0, "thermal": thermal}},
         "driver": {"mode": "force", "force_profile": [[0.0, 0.0]],
                    "brake_commands": [{"time": 0.2, "handle": "emergency"}]}}
    if remote is not None:
        d["locomotives"] = [{"name": "lead", "vehicles": [0]},
                            {"name": "remote", "vehicles": [remote]}]
    return d


@pytest.mark.parametrize("thermal", ["isothermal", "adiabatic"])
@pytest.mark.parametrize("remote", [None, 31])
def test_summary_of_a_frictionless_pipe_gives_the_simple_wave_speed(remote, thermal):
    """An emergency vent into a frictionless pipe of unbraked wagons sends a simple
    rarefaction wave along it, whose pressure level p travels away from the vent at the
    speed the Riemann invariant carried from the gas at rest gives: c (1 - ln(p0 / p)) in
    isothermal flow, c = sqrt(R T); c0 ((gamma + 1) (p / p0)^((gamma - 1) / (2 gamma)) -
    2) / (gamma - 1) in adiabatic flow, c0 = sqrt(gamma R T). The summary's slope along
    the train, at its 0.3 bar drop, matches that within 0.5 % (the linear acoustic c is
    5 % and 4.4 % faster), from the lead alone and with a venting remote locomotive,
    which it finds as a source."""
    from conftest import build

    import ltdsim

    ds = ltdsim.simulate(build(pipe_train(60, remote, thermal)))
    out = fluid_brake_summary(ds)
    p0 = float(ds.brake_pipe_pressure.values[0, 0]) + 101325.0  # Pa, absolute
    ratio = (p0 - PIPE_DROP) / p0
    if thermal == "isothermal":
        c0 = C_ISOTHERMAL
        simple = c0 * (1.0 + math.log(ratio))
    else:
        c0 = math.sqrt(1.4) * C_ISOTHERMAL
        simple = c0 * (2.4 * ratio ** (0.4 / 2.8) - 2.0) / 0.4
    assert out["sources"] == ([0] if remote is None else [0, remote])
    assert out["vehicles_reached"] == ds.sizes["vehicle"]
    assert out["propagation_speed_m_s"] == pytest.approx(simple, rel=5e-3)
    assert abs(out["propagation_speed_m_s"] / c0 - 1.0) > 0.02
