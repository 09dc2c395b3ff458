"""One coupling in every analysis: the train the kernel simulates rings at the modes the
modal analysis computes for it.

Each test runs the compiled kernel on a train that vibrates freely about a state and
reads its natural frequencies off the coupler forces (FFT), then compares them with
:func:`ltdsim.analysis.modal.train_modes` on the same scenario: the eigenvalues of the chain whose
springs are the couplings' stiffness as the kernel applies it (one gear or two in
series, on the branch the couplings are on).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import signal

import ltdsim
from ltdsim.analysis.modal import operating_stiffness, train_modes

from conftest import build

#: the study's train: locomotive (dynamic mass) and nine 90 t wagons, kg (Appendix I)
MASSES = [74151.0] + [90000.0] * 9
#: case LHHL's draft stiffness k2 + k3 and its buff stiffness k1, N/m (Appendix I)
K_DRAFT = 1.856364e6 + 3.4748e6
K_BUFF = 8.265776e6


def _train(coupler: dict, *, t_end: float, dt: float = 1e-3, velocities=None) -> dict:
    vehicles = [{"name": f"v{i}", "mass": m, "length": 15.0, "powered": i == 0,
                 "davis": {"a": 0.0, "b": 0.0, "c": 0.0}} for i, m in enumerate(MASSES)]
    return {
        "solver": {"method": "ode3", "dt": dt, "t_end": t_end, "output_interval": 0.01,
                   "record": ["coupler_force", "coupler_deflection"]},
        "vehicles": vehicles,
        "couplers": {"default": coupler},
        "traction": {"max_force": 1e8, "max_power": 1e9, "adhesion_mass": 1e8},
        "driver": {"mode": "force", "force_profile": [[0.0, 0.0]]},
        "initial": {"speed": 0.0, "velocities": velocities},
    }


def _ringing_frequencies(forces: np.ndarray, dt: float, near: np.ndarray,
                         search: float = 0.03) -> np.ndarray:
    """Frequency (Hz) of the spectral peak nearest each of ``near`` (within +-``search``
    of it, relative), from the summed power of the coupler forces ``forces`` (time x
    coupler, N) sampled every ``dt`` s: Hann window, zero-padded eight times, peak
    located by a parabola through the log power at its top three lines."""
    x = signal.detrend(forces, axis=0, type="linear")
    w = signal.get_window("hann", x.shape[0])[:, None]
    n = 8 * x.shape[0]
    p = np.sum(np.abs(np.fft.rfft(x * w, n=n, axis=0)) ** 2, axis=1)
    f = np.fft.rfftfreq(n, dt)
    df = f[1]
    floor = np.median(p[f < 2.0 * np.max(near)])
    found = []
    for fm in near:
        band = np.flatnonzero((f > fm * (1 - search)) & (f < fm * (1 + search)))
        k = band[np.argmax(p[band])]
        a, b, c = np.log(p[k - 1:k + 2])
        found.append(f[k] + 0.5 * df * (a - c) / (a - 2 * b + c))
        # a real line: well above the spectrum's floor
        assert p[k] > 100 * floor, (fm, f[k])
    return np.array(found)


@pytest.mark.parametrize("gears", [1, 2])
def test_a_free_train_of_linear_couplings_rings_at_its_modal_frequencies(gears):
    # no slack, no damping, no resistance: the lead given a 2 cm/s kick rings every mode
    coupler = {"model": "linear", "stiffness": K_DRAFT, "damping": 0.0, "slack": 0.0,
               "gears": gears}
    sc = build(_train(coupler, t_end=200.0, velocities=[0.02] + [0.0] * 9))
    ds = ltdsim.simulate(sc)
    modes = train_modes(sc, "draft", "free").frequency_hz.values[1:]
    # the modal analysis sees the coupling the kernel simulates: with two gears in series
    # half the stiffness of one
    assert_allclose(modes, train_modes(sc, K_DRAFT / gears, "free").frequency_hz.values[1:],
                    rtol=1e-12)
    rings = _ringing_frequencies(ds.coupler_force.values, 0.01, modes)
    assert_allclose(rings, modes, rtol=0.01)


def test_wagons_against_a_locomotive_held_by_its_speed_controller_ring_at_the_held_modes():
    # a stiff speed controller on the locomotive's own mass (a time constant of 2 ms)
    # holds its speed: the wagons, one given a 2 cm/s kick, ring against a moving wall
    coupler = {"model": "linear", "stiffness": K_BUFF, "damping": 0.0, "slack": 0.0}
    d = _train(coupler, t_end=200.0, velocities=[10.0] * 4 + [10.02] + [10.0] * 5)
    d["driver"] = {"mode": "speed", "speed_profile": [[0.0, 10.0], [200.0, 10.0]],
                   "pid": {"kp": 500.0, "ki": 0.0, "kd": 0.0, "n": 100.0, "ts": 1e-3,
                           "acceleration_of": "locomotive"}}
    d["traction"]["max_accel"] = d["traction"]["max_decel"] = 10.0
    d["traction"]["feedforward"] = False
    sc = build(d)
    ds = ltdsim.simulate(sc)
    held = train_modes(sc, "buff", "held").frequency_hz.values
    rings = _ringing_frequencies(ds.coupler_force.values, 0.01, held)
    assert_allclose(rings, held, rtol=0.01)


def _stretched_study_train(fade: str, t_end: float = 140.0):
    # case LHHL's simplified couplers, slack and damping as in the study, pulled slowly
    # to a steady 300 kN and nudged by 5 % at 40 s
    coupler = {"model": "simplified", "slack": 0.025, "damping": 999.8706, "k1": K_BUFF,
               "k2": 1.856364e6, "k3": 3.4748e6, "v_c": 0.6, "fade": fade}
    d = _train(coupler, t_end=t_end)
    d["initial"] = {"speed": 0.0, "couplers": "stretched"}
    d["driver"]["force_profile"] = [[0.0, 0.0], [30.0, 3e5], [40.0, 3e5], [40.05, 3.15e5],
                                    [t_end, 3.15e5]]
    sc = build(d)
    return sc, ltdsim.simulate(sc).sel(time=slice(40.1, None))


def test_the_study_train_rings_about_a_stretched_state_at_its_tangent_modes():
    # every coupling stays in draft, and the train rings at the modes of each coupling's
    # tangent stiffness at its mean deflection (Eq. 9 as printed: k3 + k2 exp(-e/v)(1 - e/v))
    sc, ds = _stretched_study_train("deflection")
    defl = ds.coupler_deflection.values
    assert (defl > 0.5 * 0.025).all()  # in draft throughout
    modes = train_modes(sc, operating_stiffness(sc, defl.mean(axis=0)),
                        "free").frequency_hz.values[1:]
    rings = _ringing_frequencies(ds.coupler_force.values, 0.01, modes)
    assert_allclose(rings, modes, rtol=0.01)


def test_read_on_the_rate_the_study_train_pumps_its_own_oscillation_about_a_stretched_state():
    # the same nudge: with k2 fading with the deflection rate the couplers feed the
    # oscillation (a gear that loads faster than it unloads returns more than it took),
    # so it grows against the damper until a coupling runs into its slack; as printed
    # (fading with the deflection) it dies away
    swing = {}
    for fade in ("deflection", "rate"):
        _, ds = _stretched_study_train(fade)
        d = ds.coupler_deflection.isel(coupler=8)
        early = d.sel(time=slice(40.1, 60.0))
        late = d.sel(time=slice(120.0, None))
        swing[fade] = float(late.max() - late.min()) / float(early.max() - early.min())
    assert swing["deflection"] < 1.0
    assert swing["rate"] > 2.0
