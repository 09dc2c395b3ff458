"""Curving safety (ltdsim.results.safety, ltdsim.physics.curving) against closed forms: the
plane curve of arcs and clothoids, coupler angles on a circle, the direction and size of
the coupler's lateral components, the body's lateral and yaw balance, Nadal's and
Prud'homme's limits and their published numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import fresnel

from ltdsim.physics.alignment import Alignment, alignment_of
from ltdsim.results.safety import TrainGeometry, curving_state
from ltdsim.physics.curving import (
    body_lateral_balance,
    cant_deficiency,
    lateral_acceleration,
    nadal_limit,
    prudhomme_limit,
)
from ltdsim.scenario import Track


def _geo(n, half_b=4.2, overhang=1.0, mass=1.3e5):
    return TrainGeometry(half_b=np.broadcast_to(np.asarray(half_b, float), (n,)).copy(),
                         overhang=np.broadcast_to(np.asarray(overhang, float), (n,)).copy(),
                         h_coupler=np.full(n, 0.876), h_cg=np.full(n, 2.0),
                         axles=np.full(n, 4.0), mass=np.broadcast_to(mass, (n,)).copy())


def _circle(radius, cant=0.0):
    k = 1.0 / radius
    return Alignment.from_knots([0.0, 5000.0], [k], [k], [cant], [cant])


def _state(align, geo, x, v=0.0, f=0.0):
    x = np.atleast_2d(x)
    n = x.shape[1]
    return curving_state(align, geo, x, np.full(x.shape, v),
                         np.broadcast_to(f, (x.shape[0], n - 1)), 1.0, 1.5, 9.81)


# ---------------------------------------------------------------- the plane curve
def test_clothoid_pose_is_fresnel():
    """Curvature s / A^2 from a straight: heading s^2 / (2 A^2), position
    A sqrt(pi) (C(u), S(u)) with u = s / (A sqrt(pi)) (Fresnel integrals)."""
    a2 = 300.0 * 120.0  # reaches R = 300 m after 120 m
    al = Alignment.from_knots([0.0, 120.0], [0.0], [120.0 / a2], [0.0], [0.0])
    s = np.array([0.0, 30.0, 60.0, 119.0])
    px, py, th = al.pose(s)
    x0, y0, _ = al.pose(np.array([0.0]))
    a = math.sqrt(a2)
    ss, cc = fresnel(s / (a * math.sqrt(math.pi)))
    np.testing.assert_allclose(th - th[0], s ** 2 / (2 * a2), atol=1e-12)
    np.testing.assert_allclose(px - x0, a * math.sqrt(math.pi) * cc, atol=1e-9)
    np.testing.assert_allclose(py - y0, a * math.sqrt(math.pi) * ss, atol=1e-9)


def test_track_transitions_build_the_ramps():
    """`curve` with `transitions`: straight, a 60 m clothoid to 300 m, the arc, a 60 m
    clothoid out; the curvature is linear in the ramps, the cant linear between points."""
    tr = Track(curve=[(0.0, 0.0), (100.0, 300.0), (400.0, 0.0)],
               transitions=[(100.0, 60.0), (400.0, 60.0)],
               cant=[(0.0, 0.0), (100.0, 0.0), (160.0, 0.06), (400.0, 0.06), (460.0, 0.0)])
    al = alignment_of(tr)
    s = np.array([50.0, 100.0, 130.0, 160.0, 300.0, 430.0, 460.0, 600.0])
    np.testing.assert_allclose(al.curvature(s), [0, 0, 0.5 / 300, 1 / 300, 1 / 300,
                                                 0.5 / 300, 0, 0], atol=1e-15)
    np.testing.assert_allclose(al.cant(s), [0, 0, 0.03, 0.06, 0.06, 0.03, 0, 0], atol=1e-15)
    # the curve resistance's steps keep the integral of curvature (the total turning)
    steps = tr.resistance_curve()
    starts = np.array([p for p, _ in steps] + [700.0])
    kap = np.array([0.0 if r == 0 else 1.0 / r for _, r in steps])
    total = np.sum(kap * np.diff(starts))
    assert total == pytest.approx(300.0 / 300.0, rel=1e-12)  # 240 m arc + 2 x 60 m / 2
    # the kernel's track arrays are those steps
    from ltdsim.engine.lowering import merge_track

    _, _, curv = merge_track(tr.gradient, steps)
    nonzero = np.array([0.0 if r == 0 else 1.0 / r for _, r in steps])
    np.testing.assert_array_equal(curv, nonzero)
    # and without transitions the kernel reads `curve` unchanged
    plain = Track(curve=[(0.0, 0.0), (100.0, 300.0), (400.0, 0.0)])
    assert plain.resistance_curve() == plain.curve


# ---------------------------------------------------------------- coupler angles
@settings(max_examples=30, deadline=None)
@given(radius=st.floats(60.0, 5000.0), length=st.floats(8.0, 25.0),
       left=st.booleans())
def test_identical_vehicles_on_a_circle(radius, length, left):
    """Identical vehicles spaced ``L`` along a circle: by the mirror symmetry between two
    neighbours the bar is square to the bisecting radius, so its yaw to either body is
    L / (2 R), whatever the bogie spacing and overhang."""
    r = radius if left else -radius
    n = 5
    hb = 0.5 * (length - 3.8)
    x = 2000.0 - length * np.arange(n)
    s = _state(_circle(r), _geo(n, half_b=hb), x)
    expect = length / (2.0 * radius)
    np.testing.assert_allclose(np.abs(s.coupler_angle), expect, rtol=0, atol=1e-6)
    # + left: turning left, the bar heads right of the body ahead and left of the body behind
    sign = 1.0 if left else -1.0
    np.testing.assert_array_less(0.0, -sign * s.coupler_angle[..., 0])
    np.testing.assert_array_less(0.0, sign * s.coupler_angle[..., 1])


def test_different_vehicles_on_a_circle_polar_closed_form():
    """Two different vehicles on a circle: each pivot in polar coordinates about the
    centre, r = hypot(R cos b, R sin b + a), offset atan2(R sin b + a, R cos b) with
    b = half bogie spacing / R; the bar's yaw to each body's tangent in closed form."""
    R = 250.0
    hb = np.array([7.5, 4.0])
    a = np.array([2.4, 1.1])
    x = np.array([1000.0, 1000.0 - 17.3])
    s = _state(_circle(R), _geo(2, half_b=hb, overhang=a), x)
    psi = x / R  # angular position of each centre (left turn: angle grows forward)
    beta = hb / R
    rp = np.hypot(R * np.cos(beta), R * np.sin(beta) + a)
    gam = np.arctan2(R * np.sin(beta) + a, R * np.cos(beta))
    p1 = rp[0] * np.array([np.cos(psi[0] - gam[0]), np.sin(psi[0] - gam[0])])  # rear of 1
    p2 = rp[1] * np.array([np.cos(psi[1] + gam[1]), np.sin(psi[1] + gam[1])])  # front of 2
    bar = math.atan2(*(p1 - p2)[::-1])
    head = psi + math.pi / 2
    expect = [(bar - head[0] + math.pi) % (2 * math.pi) - math.pi,
              (bar - head[1] + math.pi) % (2 * math.pi) - math.pi]
    np.testing.assert_allclose(s.coupler_angle[0, 0], expect, atol=1e-9)


def test_straight_track_gives_zero_angles_and_forces():
    al = Alignment.from_knots([0.0, 5000.0], [0.0], [0.0], [0.0], [0.0])
    x = 1000.0 - np.array([0.0, 15.0, 29.0, 44.5])
    s = _state(al, _geo(4), x, v=20.0, f=-1e6)
    assert np.max(np.abs(s.coupler_angle)) < 1e-12
    assert np.max(np.abs(s.bogie_force)) < 1e-3  # N, under 1 MN of buff


def test_clothoid_angles_follow_the_curvature():
    """On a clothoid of short vehicles the yaw of each bar follows the local curvature:
    L k(s_coupler) / 2, to the first order in L k' L."""
    a2 = 400.0 * 200.0
    al = Alignment.from_knots([0.0, 200.0], [0.0], [200.0 / a2], [0.0], [0.0])
    L = 10.0
    x = 195.0 - L * np.arange(18)
    s = _state(al, _geo(18, half_b=3.1), x)
    mid = 0.5 * (x[:-1] + x[1:])
    expect = L * mid / a2 / 2.0
    got = 0.5 * (s.coupler_angle[0, :, 1] - s.coupler_angle[0, :, 0])
    np.testing.assert_allclose(got, expect, rtol=0, atol=2e-4 * L / 400.0 + 1e-7)
    assert np.all(np.diff(got[::-1]) > 0)  # grows with the curvature


# ---------------------------------------------------------------- lateral components
@pytest.mark.parametrize("left", [True, False])
def test_draft_pulls_inward_buff_pushes_outward(left):
    """Stringlining and jackknifing: in draft the coupler's lateral pull on each body is
    towards the centre of the curve, in buff away from it, and its size F sin(angle)."""
    R = 300.0 if left else -300.0
    n = 4
    x = 1500.0 - 12.2 * np.arange(n)
    for f in (4e5, -4e5):
        s = _state(_circle(R), _geo(n), x, f=f)
        centre = 1.0 if left else -1.0  # + left
        lat = np.concatenate([s.coupler_lateral_rear[0, :-1], s.coupler_lateral_front[0, 1:]])
        ang = np.concatenate([s.coupler_angle[0, :, 0], s.coupler_angle[0, :, 1]])
        assert np.all(np.sign(lat) == np.sign(f) * centre)
        np.testing.assert_allclose(np.abs(lat), abs(f) * np.sin(np.abs(ang)), rtol=1e-12)


def test_body_balance_closes_with_vectors():
    """Every body's lateral sum and yaw moment, recomputed from the 2-D force vectors at
    the plane points (coupler forces along the bars, loads and bogie forces square to the
    body axis), vanish within 1e-9 of the forces' size."""
    tr = Track(curve=[(0.0, 0.0), (100.0, 300.0), (250.0, -300.0), (400.0, 0.0)],
               transitions=[(100.0, 40.0), (250.0, 60.0), (400.0, 40.0)],
               cant=[(0.0, 0.0), (140.0, 0.08), (250.0, 0.08), (280.0, 0.0),
                     (310.0, 0.08)])
    al = alignment_of(tr)
    n = 30
    rng = np.random.default_rng(3)
    x = 420.0 - np.cumsum(np.r_[0.0, rng.uniform(11.0, 23.0, n - 1)])
    hb = rng.uniform(3.0, 5.0, n)
    geo = _geo(n, half_b=hb, overhang=rng.uniform(0.8, 2.5, n),
               mass=rng.uniform(2e4, 2e5, n))
    f = rng.uniform(-2e6, 2e6, (1, n - 1))
    s = curving_state(al, geo, x[None], np.full((1, n), 22.0), f, 1.0, 1.5, 9.81)
    piv = s.pivots[0]
    e = np.stack([np.cos(s.body_heading[0]), np.sin(s.body_heading[0])], axis=-1)
    nrm = np.stack([-e[:, 1], e[:, 0]], axis=-1)
    centre = 0.5 * (piv[:, 0] + piv[:, 1])
    forces = [[] for _ in range(n)]  # (point, vector)
    for j in range(n - 1):
        u = piv[j + 1, 0] - piv[j, 1]
        u /= np.linalg.norm(u)
        forces[j].append((piv[j, 1], f[0, j] * u))          # pulled back towards j + 1
        forces[j + 1].append((piv[j + 1, 0], -f[0, j] * u))  # pulled forward towards j
    for i in range(n):
        bogie_pts = s.bogies[0, i]
        for k in range(2):
            vec = (s.bogie_load[0, i, k] + s.bogie_force[0, i, k]) * nrm[i]
            forces[i].append((bogie_pts[k], vec))
        lat = sum(v @ nrm[i] for _, v in forces[i])
        mom = sum((p - centre[i])[0] * v[1] - (p - centre[i])[1] * v[0]
                  for p, v in forces[i])
        scale = max(np.abs(f).max(), np.abs(s.bogie_load[0, i]).max())
        assert abs(lat) < 1e-9 * scale
        assert abs(mom) < 1e-9 * scale * 10.0  # lever arms of about 10 m


@settings(max_examples=50, deadline=None)
@given(cf=st.floats(-1e6, 1e6), cr=st.floats(-1e6, 1e6), bf=st.floats(-1e5, 1e5),
       br=st.floats(-1e5, 1e5), e=st.floats(1.0, 10.0), a=st.floats(0.0, 3.0))
def test_balance_law_sums_to_zero(cf, cr, bf, br, e, a):
    yf, yr = body_lateral_balance(cf, cr, bf, br, e, a)
    scale = max(abs(cf), abs(cr), abs(bf), abs(br), 1.0)
    assert abs(yf + yr + cf + cr + bf + br) < 1e-9 * scale
    assert abs(e * (yf + bf) - e * (yr + br) + (e + a) * (cf - cr)) < 1e-9 * scale * (e + a)


# ---------------------------------------------------------------- limits and loads
def test_nadal_formula_and_published_numbers():
    g = np.radians([60.0, 70.0, 75.0])
    mu = np.array([0.3, 0.36, 0.5])
    np.testing.assert_allclose(nadal_limit(g, mu),
                               (np.tan(g) - mu) / (1 + mu * np.tan(g)), rtol=1e-14)
    # AAR: 75 deg flange, mu 0.5 -> 1.13; EN 14363: 70 deg, mu 0.36 -> 1.2
    assert nadal_limit(math.radians(75.0), 0.5) == pytest.approx(1.13, abs=0.005)
    assert nadal_limit(math.radians(70.0), 0.36) == pytest.approx(1.20, abs=0.005)
    assert nadal_limit(math.radians(70.0), 0.0) == pytest.approx(math.tan(math.radians(70)))


def test_prudhomme_formula_and_published_number():
    # 10 kN + P/3 (P in kN): a 22.5 t axle (220.7 kN) -> 83.6 kN; 0.85 of it for wagons
    p = 22.5e3 * 9.81
    assert prudhomme_limit(p) == pytest.approx(83.6e3, rel=1e-3)
    assert prudhomme_limit(p, 0.85) == pytest.approx(0.85 * (10e3 + p / 3.0), rel=1e-14)


def test_balancing_speed_has_no_unbalanced_force():
    """At the equilibrium speed v^2 = g R sin(phi) / cos(phi) the lateral acceleration in
    the track plane vanishes and the cant deficiency is zero."""
    R, h, s, g = 600.0, 0.1, 1.5, 9.81
    phi = math.asin(h / s)
    v = math.sqrt(g * R * math.tan(phi))
    assert abs(lateral_acceleration(v, 1 / R, h, s, g)) < 1e-12
    assert abs(lateral_acceleration(v, -1 / R, h, s, g)) < 1e-12
    # without the cos(phi): the usual cant-deficiency formula h_d = s v^2 / (g R) - h
    hd = cant_deficiency(v, 1 / R, h, s, g)
    assert hd == pytest.approx(s * math.tan(phi) - h, rel=1e-12)


def test_profile_file_gives_the_same_alignment(tmp_path):
    """A CSV of chainage, curvature and cant read at load time gives the alignment that
    the same track given as `curve`, `transitions` and `cant` gives; a bad row is one
    line naming the file and the line."""
    from ltdsim.errors import ScenarioError
    from ltdsim.scenario import load_scenario

    base = (tmp_path / "s.toml")
    toml = """name = "p"
[solver]
t_end = 1.0
dt = 1e-3
output_interval = 0.1
[[vehicles]]
name = "loco"
mass = 9e4
length = 20.0
powered = true
[traction]
max_force = 1e5
max_power = 1e6
adhesion_mass = 9e4
[driver]
mode = "force"
force_profile = [[0.0, 0.0]]
[track]
profile_file = "alignment.csv"
"""
    base.write_text(toml)
    (tmp_path / "alignment.csv").write_text(
        "chainage_m,curvature_1_per_m,cant_m\n0,0,0\n100,0,0\n160,0.0033333333333333335,0.06\n"
        "400,0.0033333333333333335,0.06\n460,0,0\n")
    sc = load_scenario(base)
    a = alignment_of(sc.track)
    ref = alignment_of(Track(curve=[(0.0, 0.0), (100.0, 300.0), (400.0, 0.0)],
                             transitions=[(100.0, 60.0), (400.0, 60.0)],
                             cant=[(0.0, 0.0), (100.0, 0.0), (160.0, 0.06), (400.0, 0.06),
                                   (460.0, 0.0)]))
    s = np.linspace(-50.0, 600.0, 131)
    np.testing.assert_allclose(a.curvature(s), ref.curvature(s), atol=1e-15)
    np.testing.assert_allclose(a.cant(s), ref.cant(s), atol=1e-15)
    np.testing.assert_allclose(a.pose(s)[2], ref.pose(s)[2], atol=1e-12)
    (tmp_path / "alignment.csv").write_text("0,0,0\n100,zero,0\n")
    with pytest.raises(ScenarioError) as err:
        load_scenario(base)
    assert "alignment.csv line 2" in str(err.value) and "\n" not in str(err.value).strip()


# ---------------------------------------------------------------- curve-limit, end to end
def test_curve_limit_fed_back_as_steady_buff_reaches_the_limit():
    """``curve_limit`` for a pair of identical wagons gives a buff force; a simulated
    train of those wagons held in steady buff by that force (the lead locomotive's
    dynamic brake against a pusher's full notch, no resistance) on that curve has the
    middle wagons' L/V at Nadal's limit within 1 %."""
    from conftest import build

    from ltdsim.results.safety import curve_limit
    from ltdsim.results.simulate import simulate

    radius, cant, speed = 200.0, 0.05, 12.0
    wagon = {"name": "wagon", "mass": 1.3e5, "length": 15.0}
    loco = {"name": "loco", "mass": 1.3e5, "length": 15.0, "powered": True}
    d = {
        "solver": {"method": "rk4", "dt": 1e-3, "t_end": 15.0, "output_interval": 0.5},
        "vehicles": [loco] + [dict(wagon) for _ in range(6)] + [dict(loco, name="pusher")],
        "couplers": {"default": {"model": "linear", "stiffness": 5e7, "damping": 1e6,
                                 "slack": 0.0}},
        "track": {"curve": [[0.0, radius]], "cant": [[0.0, cant]], "curve_h": 0.0},
        "traction": {"max_force": 1e8, "max_power": 1e9, "adhesion_mass": 1e8,
                     "time_constant": 1.0},
        "locomotives": [{"name": "lead", "vehicles": [0]},
                        {"name": "pusher", "vehicles": [7],
                         "notch_profile": [[0.0, 0.0], [1.0, 8.0]]}],
        "driver": {"mode": "force", "force_profile": [[0.0, 0.0], [1.0, 0.0], [1.0 + 1e-9, 0.0]]},
        "initial": {"speed": speed},
        "curving": {},
    }
    sc = build(d)
    w = sc.vehicles[3]
    c = sc.curving
    lim = curve_limit(w, w, radius, cant, speed, c.flange_angle, c.flange_friction,
                      c.leading_share, sc.track.rail_spacing, sc.track.gravity, c.prudhomme_alpha)
    assert 1e5 < lim.buff_force < 5e7
    # the pusher at full notch gives max_force: set both ends to the limit force
    d["locomotives"][1]["max_force"] = lim.buff_force
    d["driver"]["force_profile"] = [[0.0, 0.0], [1.0, 0.0], [1.0 + 1e-9, -lim.buff_force]]
    ds = simulate(build(d))
    end = ds.isel(time=-1)
    np.testing.assert_allclose(end.coupler_force.values, -lim.buff_force, rtol=1e-4)
    np.testing.assert_allclose(end.velocity.values, speed, rtol=1e-3)
    lv = end.wheel_l_over_v.values[2:6]  # wagons with wagons on both sides
    print(f"limit {lim.buff_force:.6g} N, L/V {lv} against {lim.limit:.6g}")
    np.testing.assert_allclose(lv, lim.limit, rtol=0.01)
    assert float(ds.nadal_limit) == pytest.approx(lim.limit, rel=1e-12)


def test_curve_limit_cli_prints_the_function_and_refuses_bad_input():
    """`ltdsim curve-limit` prints curve_limit's force for the vehicles at the coupler;
    a coupler or radius out of range is one line naming the option."""
    from conftest import ROOT
    from typer.testing import CliRunner

    from ltdsim.cli.app import app
    from ltdsim.results.safety import curve_limit
    from ltdsim.scenario import Curving, load_scenario

    path = ROOT / "scenarios" / "heavy-haul.toml"
    runner = CliRunner()
    res = runner.invoke(app, ["curve-limit", str(path), "--coupler", "107", "--radius", "300",
                              "--cant", "0.05", "--speed", "15"])
    assert res.exit_code == 0, res.output
    sc = load_scenario(path)
    c = Curving()
    lim = curve_limit(sc.vehicles[106], sc.vehicles[107], 300.0, 0.05, 15.0, c.flange_angle,
                      c.flange_friction, c.leading_share, sc.track.rail_spacing,
                      sc.track.gravity, c.prudhomme_alpha)
    assert f"{lim.buff_force / 1e3:.0f}" in res.output
    assert f"{lim.buff_force_prudhomme / 1e3:.0f}" in res.output
    for args, key in ((["--coupler", "214", "--radius", "300"], "--coupler"),
                      (["--coupler", "3", "--radius", "10"], "--radius")):
        bad = runner.invoke(app, ["curve-limit", str(path), *args])
        assert bad.exit_code == 2 and key in bad.output and "Traceback" not in bad.output


def test_run_report_and_figure_name_the_worst_place(tmp_path):
    """`ltdsim run --plot --report` on a short train pushed into a curve: the printed
    and reported worst L/V is the largest value of ``wheel_l_over_v``, at its vehicle;
    the figure and the page are written; in buff every lateral component points out."""
    import xarray as xr
    from typer.testing import CliRunner

    from ltdsim.cli.app import app

    toml = tmp_path / "push.toml"
    toml.write_text("""name = "pushed"
[solver]
method = "rk4"
dt = 1e-3
t_end = 6.0
output_interval = 0.5
[[vehicles]]
name = "wagon"
count = 4
mass = 8e4
length = 15.0
[[vehicles]]
name = "loco"
mass = 1.2e5
length = 20.0
powered = true
[couplers.default]
model = "linear"
stiffness = 5e7
damping = 1e6
[track]
curve = [[-200.0, 0.0], [-150.0, -250.0]]
transitions = [[-150.0, 30.0]]
[traction]
max_force = 1e8
max_power = 1e9
adhesion_mass = 1e8
[driver]
mode = "force"
force_profile = [[0.0, 0.0], [2.0, 6e5]]
[initial]
speed = 5.0
[curving]
""")
    res = CliRunner().invoke(app, ["run", str(toml), "-q", "-o", str(tmp_path / "r.nc"),
                                   "-p", str(tmp_path / "r.png"),
                                   "--report", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    ds = xr.load_dataset(tmp_path / "r.nc")
    lv = ds.wheel_l_over_v.values
    k, i = np.unravel_index(np.argmax(lv), lv.shape)
    assert f"worst wheel L/V {lv[k, i]:.3f}" in " ".join(res.output.split())
    assert f"at vehicle {i + 1}," in res.output
    assert (tmp_path / "r-curving.png").stat().st_size > 10_000
    page = (tmp_path / "rep" / "index.html").read_text()
    assert f"<b>{lv[k, i]:.3f}</b>" in page and "curving_worst.csv" in page
    # every coupler is in buff once the loco pushes: outward components only
    assert float(ds.coupler_lateral_force.isel(time=-1).max()) <= 0.0
    assert float(ds.coupler_force.isel(time=-1).max()) < 0.0


def test_add_curving_on_records_and_angle_stops():
    """``add_curving`` on hand-made records of identical wagons standing on a 250 m
    circle in steady buff (no kernel): every coupler angle is L / (2R); the lateral
    component is -F sin(L / 2R) (outwards); with stops below that angle every coupler
    is counted at its stops, with stops above it none."""
    import json

    import xarray as xr
    from conftest import train_dict

    from ltdsim.results.safety import add_curving
    from ltdsim.scenario import Scenario
    from ltdsim.results.summary import curving_summary

    n, L, R, F = 6, 15.0, 250.0, 4e5
    d = train_dict([8e4] * n, powered=(0,))
    for v in d["vehicles"]:  # the same plan geometry for the locomotive
        v["geometry"] = {"pivot_overhang": 1.2, "coupler_length": 0.9}
    d["track"] = {"curve": [[-500.0, R]]}
    d["curving"] = {"coupler_angle_limit": 0.02}
    sc = Scenario.from_dict(d, "test")
    x = -L * np.arange(n) + np.array([[0.0], [5.0]])
    ds = xr.Dataset({"position": (("time", "vehicle"), x),
                     "velocity": (("time", "vehicle"), np.full((2, n), 3.0)),
                     "coupler_force": (("time", "coupler"), np.full((2, n - 1), -F))},
                    coords={"time": [0.0, 1.0], "vehicle": np.arange(n),
                            "coupler": np.arange(n - 1)},
                    attrs={"scenario_json": json.dumps(sc.to_dict())})
    out = add_curving(ds, sc)
    np.testing.assert_allclose(out.coupler_angle.values, L / (2 * R), atol=1e-9)
    np.testing.assert_allclose(out.coupler_lateral_force.values, -F * np.sin(L / (2 * R)),
                               rtol=1e-9)
    assert curving_summary(out)["couplers_at_stops"] == n - 1
    d["curving"] = {"coupler_angle_limit": 0.04}
    ds.attrs["scenario_json"] = json.dumps(Scenario.from_dict(d, "test").to_dict())
    assert curving_summary(add_curving(ds, sc))["couplers_at_stops"] == 0


@settings(max_examples=25, deadline=None)
@given(force=st.floats(1e4, 5e6), radius=st.floats(100.0, 2000.0),
       overhang=st.floats(0.5, 2.5), left=st.booleans())
def test_l_over_v_of_like_vehicles_in_steady_buff_closed_form(force, radius, overhang, left):
    """Like vehicles on a circle at standstill in steady buff F: each end pushes outwards
    with F sin(L / 2R), each bogie takes that much (the yaw moments of the two ends
    cancel, so the overhang drops out), the roll moment 2 F sin(L / 2R) h_c moves
    load to the outer wheels: L/V = F sin(L / 2R) / (m g / 2N + 2 F sin(L / 2R) h_c /
    (s N)) for N axles and contact spacing s."""
    n, L, m = 5, 15.0, 9e4
    r = radius if left else -radius
    geo = _geo(n, half_b=0.5 * (L - 2 * overhang - 1.8), overhang=overhang, mass=m)
    x = 3000.0 - L * np.arange(n)
    s = curving_state(_circle(r), geo, x[None], np.zeros((1, n)),
                      np.full((1, n - 1), -force), 1.0, 1.5, 9.81)
    lat = force * math.sin(L / (2 * radius))
    q = m * 9.81 / 8 + 2 * lat * 0.876 / (1.5 * 4)
    np.testing.assert_allclose(s.l_over_v[0, 1:-1], lat / q, rtol=1e-9)
    # the wheelsets push the outer rail: right on a left-hand curve
    outward = -1.0 if left else 1.0
    assert np.all(np.sign(s.wheelset_force[0, 1:-1]) == outward)


def test_a_failing_curving_pass_keeps_the_run_and_says_so_in_one_line(tmp_path, monkeypatch):
    """The curving indicators are computed after the run: when that pass fails (here made
    to run out of memory) the run is not lost. ``simulate`` returns every recorded
    variable, equal to the same run without ``[curving]``, the reason in
    ``attrs["curving_error"]`` and a RuntimeWarning; ``ltdsim run -o`` prints one
    warning line, no traceback, exits 0 and writes the result."""
    import xarray as xr
    from typer.testing import CliRunner

    import ltdsim
    import ltdsim.results.safety as safety
    from conftest import ROOT
    from ltdsim.cli.app import app

    path = ROOT / "scenarios" / "short-train.toml"
    sc = ltdsim.load_scenario(path).with_overrides({"solver.t_end": 1.0, "curving": {}})

    def broken(ds, scenario):
        raise MemoryError("unable to allocate 2.1 GiB")

    monkeypatch.setattr(safety, "add_curving", broken)
    with pytest.warns(RuntimeWarning, match="curving indicators not computed"):
        ds = ltdsim.simulate(sc)
    plain = ltdsim.simulate(sc.with_overrides({"curving": None}))
    assert "wheel_l_over_v" not in ds
    assert "MemoryError: unable to allocate 2.1 GiB" in ds.attrs["curving_error"]
    for name in plain.data_vars:
        np.testing.assert_array_equal(ds[name].values, plain[name].values)
    toml = tmp_path / "s.toml"
    toml.write_text(path.read_text().replace("t_end = 60.0", "t_end = 1.0")
                    .replace("[traction]", "[curving]\n\n[traction]"))
    res = CliRunner().invoke(app, ["run", str(toml), "-q", "-o", str(tmp_path / "r.nc")])
    assert res.exit_code == 0, res.output
    assert "Traceback" not in res.output and res.exception is None
    warned = [ln for ln in res.stderr.splitlines() if "curving indicators not computed" in ln]
    assert len(warned) == 1 and warned[0].startswith("warning:")
    kept = xr.load_dataset(tmp_path / "r.nc")
    np.testing.assert_array_equal(kept.position.values, plain.position.values)
    assert "curving_error" in kept.attrs


def test_wheel_lift_is_reported_as_such_and_never_as_an_infinite_l_over_v(tmp_path,
                                                                         monkeypatch):
    """A flanging wheel the roll moment unloads fully has no L/V (the result stores inf
    there). Made to happen at two known places of a real run (vehicle 3 from record 5,
    vehicle 4 at record 7): the summary names the first lift (vehicle 3, its time and
    chainage) and the worst L/V of the loaded wheels (the largest finite value);
    ``ltdsim run``'s lines, the report page, its curving_worst.csv (the lifting vehicles
    first) and the figure say "wheel lift" and print no "inf" anywhere."""
    import re

    import xarray as xr
    from typer.testing import CliRunner

    import ltdsim.results.safety as safety
    from conftest import ROOT
    from ltdsim.cli.app import app
    from ltdsim.results.summary import curving_summary, l_over_v_text

    real = safety.add_curving

    def lifting(ds, scenario):
        out = real(ds, scenario)
        lv = out.wheel_l_over_v.values
        lv[5:, 2] = np.inf
        lv[7, 3] = np.inf
        return out

    monkeypatch.setattr(safety, "add_curving", lifting)
    toml = tmp_path / "s.toml"
    toml.write_text((ROOT / "scenarios" / "short-train.toml").read_text()
                    .replace("t_end = 60.0", "t_end = 1.0")
                    .replace("output_interval = 1e-3", "output_interval = 0.05")
                    .replace("[traction]", "[curving]\n\n[traction]"))
    res = CliRunner().invoke(app, ["run", str(toml), "-q", "-o", str(tmp_path / "r.nc"),
                                   "-p", str(tmp_path / "r.png"),
                                   "--report", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    ds = xr.load_dataset(tmp_path / "r.nc")
    c = curving_summary(ds)
    t, x = ds.time.values, ds.position.values
    assert (c["wheel_lift_vehicles"], c["wheel_lift_vehicle"]) == (2, 3)
    assert c["wheel_lift_time_s"] == t[5] and c["wheel_lift_position_m"] == x[5, 2]
    lv = ds.wheel_l_over_v.values
    assert c["max_l_over_v"] == lv[np.isfinite(lv)].max()
    text = l_over_v_text(c)
    assert text.startswith(f"wheel lift: the flanging wheel of vehicle 3 unloads fully at "
                           f"{t[5]:.1f} s, chainage {x[5, 2]:.0f} m (L/V undefined")
    assert "2 vehicles lift a wheel" in text and "worst L/V of the loaded wheels" in text
    out = " ".join(res.output.split())
    assert f"curving: {text}" in out
    page = (tmp_path / "rep" / "index.html").read_text()
    csv = (tmp_path / "rep" / "curving_worst.csv").read_text()
    assert "Wheel lift:" in page and "vehicle 3" in page
    for written in (out, page, csv):
        assert not re.search(r"\binf\b", written, re.I), written
    from ltdsim.viz.plotting import curving_figure

    import matplotlib.pyplot as plt

    fig = curving_figure(ds, c)
    title = fig._suptitle.get_text()
    plt.close(fig)
    assert title.startswith("wheel lift at vehicle 3") and "inf" not in title
    rows = csv.splitlines()
    assert rows[1].split(",")[0] == "3" and rows[2].split(",")[0] == "4"
    assert "wheel lift" in rows[0] and rows[1].count("yes") == 1
    # without a lift the sentence is the plain worst L/V, as before
    plain = {k: v for k, v in c.items() if not k.startswith("wheel_lift")}
    assert l_over_v_text(plain).startswith(f"worst wheel L/V {c['max_l_over_v']:.3f} (")


def test_straight_track_prints_no_negative_zero(tmp_path):
    """On straight track no coupler has a lateral component: the summary's largest
    inward and outward components are +0 N and ``ltdsim run`` prints no "-0.0 kN"
    (the records' signed zeros once came out as "up to -0.0 kN inward")."""
    from typer.testing import CliRunner

    from conftest import ROOT
    from ltdsim.cli.app import app

    toml = tmp_path / "straight.toml"
    toml.write_text((ROOT / "scenarios" / "short-train.toml").read_text()
                    .replace("t_end = 60.0", "t_end = 1.0")
                    .replace("curve = [[0.0, 0.0], [150.0, 300.0], [450.0, 0.0]]", "")
                    .replace("[traction]", "[curving]\n\n[traction]"))
    res = CliRunner().invoke(app, ["run", str(toml), "-q"])
    assert res.exit_code == 0, res.output
    out = " ".join(res.output.split())
    assert "lateral coupler components up to 0.0 kN inward (draft), 0.0 kN outward" in out
    assert "-0.0" not in out
