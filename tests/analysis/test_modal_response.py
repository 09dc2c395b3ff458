"""Modal analysis and step/ramp metrics against closed forms and the study's numbers."""

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import ltdsim
from ltdsim.data import study_tables
from ltdsim.analysis.modal import chain_modes, train_modes
from ltdsim.analysis.response import ramp_error, step_metrics, tf_from_z_inverse

from conftest import PAPER

TABLES = study_tables()


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 60), m=st.floats(1e3, 2e5), k=st.floats(1e5, 1e8))
def test_uniform_chain_frequencies_match_the_closed_form(n, m, k):
    f, phi = chain_modes(np.full(n, m), np.full(n - 1, k))
    j = np.arange(n)
    exact = np.sqrt(k / m) / np.pi * np.sin(j * np.pi / (2 * n))
    assert_allclose(f[1:], exact[1:], rtol=1e-9)
    assert f[0] < 1e-6 * f[-1]  # exactly one rigid-body mode
    assert np.sum(f < 1e-6 * f[-1]) == 1
    assert_allclose(phi.T @ np.diag(np.full(n, m)) @ phi, np.eye(n), atol=1e-9)  # M-orthonormal


def test_figure_8s_low_band_is_the_study_train_with_two_gears_in_series_per_coupling():
    # the study's Fig. 8 band for k1 (0.23-1.45 Hz) is the train of case LLLL with its
    # couplings half as stiff as one Eq. 9 law: two gears in series; one gear (the default,
    # as its Eq. 10 writes the train) gives modes sqrt(2) higher
    low = TABLES["figure8_modal_bands"]["low_stiffness_k1_Hz"]
    one = ltdsim.load_scenario(PAPER, case="LLLL")
    two = one.with_overrides({"couplers.default.gears": 2})
    f2 = train_modes(two, "buff").frequency_hz.values
    f1 = train_modes(one, "buff").frequency_hz.values
    assert_allclose([f2[1], f2[-1]], low, rtol=0.05)
    assert_allclose(f1[1:], np.sqrt(2.0) * f2[1:], rtol=1e-12)


@pytest.mark.parametrize("zeta,wn", [(0.1, 2.0), (0.3, 5.0), (0.6, 1.0)])
def test_step_metrics_of_a_second_order_system_match_the_closed_form(zeta, wn):
    sys = control.tf([wn**2], [1, 2 * zeta * wn, wn**2])
    m = step_metrics(sys)
    assert_allclose(m["Overshoot"], 100 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2)), rtol=1e-2)
    assert_allclose(m["PeakTime"], np.pi / (wn * np.sqrt(1 - zeta**2)), rtol=1e-2)


def test_ramp_error_of_a_first_order_lag_is_its_time_constant():
    for tau in (0.05, 0.5, 2.0):
        assert_allclose(ramp_error(control.tf([1], [tau, 1])), tau, rtol=1e-3)
        sysd = control.c2d(control.tf([1], [tau, 1]), tau / 50, method="zoh")
        assert_allclose(ramp_error(sysd), tau, rtol=2e-2)
    assert ramp_error(control.tf([0.9], [1, 1])) == float("inf")  # DC gain 0.9: no steady state


@pytest.mark.parametrize("case", ["LLLL", "LLHL", "HLLH", "HLHL", "HHLH"])
def test_appendix_ii_models_reproduce_table_4_overshoot_and_peak(case):
    tf = TABLES["appendix2_transfer_functions_Ts_1e-4"][case]
    m = step_metrics(tf_from_z_inverse(tf["numerator_z^-1"], tf["denominator_z^-1"], 1e-4))
    t4 = TABLES["table4_step_response"][case]
    assert abs(m["Overshoot"] - t4["overshoot_percent"]) < 2.0  # percentage points
    assert abs(m["Peak"] - t4["peak"]) < 0.015


def test_known_sines_are_read_back_at_the_right_frequency_and_amplitude():
    from ltdsim.analysis.spectra import amplitude_spectrum, spectral_peaks

    dt, n = 1e-3, 100_000  # 100 s: 0.01 Hz bins; tones between bins
    t = np.arange(n) * dt
    tones = [(0.437, 2.0e4), (1.73, 8.0e3), (3.61, 5.0e3)]
    x = 1e5 + sum(a * np.sin(2 * np.pi * f * t + 0.4) for f, a in tones)
    f, a = amplitude_spectrum(x, dt, window="flattop")
    peaks = spectral_peaks(f, a, rel_height=0.1)
    for (f0, a0), p in zip(sorted(tones, key=lambda z: -z[1]), peaks):
        assert abs(p["frequency_hz"] - f0) <= 0.1
        assert_allclose(p["amplitude"], a0, rtol=0.01)


def test_band_rms_from_the_spectrum_equals_the_time_domain_rms_of_the_band():
    from ltdsim.analysis.spectra import amplitude_spectrum, band_stats

    dt, n = 1e-3, 10_000
    t = np.arange(n) * dt
    inside = 3.0 * np.sin(2 * np.pi * 0.7 * t) + 1.5 * np.cos(2 * np.pi * 6.3 * t)
    outside = 2.0 * np.sin(2 * np.pi * 37.0 * t)  # beyond the 10 Hz band
    f, a = amplitude_spectrum(5.0 + inside + outside, dt)
    assert_allclose(band_stats(f, a, 10.0)["rms"], np.sqrt(np.mean(inside**2)), rtol=0.01)


def test_main_coupler_force_peaks_lie_in_the_trains_modal_band():
    from ltdsim.analysis.phases import phases_of
    from ltdsim.analysis.spectra import amplitude_spectrum, spectral_peaks

    sc = ltdsim.load_scenario(PAPER, case="LHHL")
    ds = ltdsim.simulate(sc)
    # modes of the chain as simulated, each coupling on its buff or draft branch, lead
    # free or held by the speed controller
    modes = np.concatenate([train_modes(sc, w, lead).frequency_hz.values
                            for w in ("buff", "draft") for lead in ("held", "free")])
    modes = modes[modes > 1e-6]  # not the free train's rigid-body mode
    lo, hi = modes.min() - 0.1, modes.max() + 0.1  # +- one 0.1 Hz bin
    for _, a, b in phases_of(ds, sc):
        w = ds.coupler_force.sel(time=slice(a, b - 1e-9))
        for c in (0, 7, 8):
            # the strongest line of the force with its trend over the window removed,
            # above twice the resolution (0.2 Hz: below it lies what is left of the trend)
            f, amp = amplitude_spectrum(w.isel(coupler=c).values, 1e-3, detrend="linear")
            lines = spectral_peaks(f, amp, rel_height=0.0, max_peaks=len(f))
            main = next(p["frequency_hz"] for p in lines if p["frequency_hz"] >= 0.2)
            assert lo <= main <= hi, (a, c, main, lo, hi)


def test_identification_recovers_a_known_four_pole_three_zero_system():
    from scipy import optimize, signal

    from ltdsim.analysis.identify import identify

    # two lightly damped modes, like a sampled mechanical chain
    poles = np.array([0.97 * np.exp(1j * 0.2), 0.97 * np.exp(-1j * 0.2),
                      0.9 * np.exp(1j * 0.5), 0.9 * np.exp(-1j * 0.5)])
    a = np.real(np.poly(poles))
    b = np.array([0.05, 0.02, -0.03, 0.01])
    rng = np.random.default_rng(11)
    u = rng.normal(size=20_000)
    y0 = signal.lfilter(b, a, u)
    y = y0 + 0.01 * np.std(y0) * rng.normal(size=y0.size)  # 1 % output noise
    m = identify(u, y, dt=0.01)
    assert m.fit_percent >= 98.0
    err = np.abs(m.poles[:, None] - poles[None, :]) / np.abs(poles[None, :])
    rows, cols = optimize.linear_sum_assignment(err)
    assert err[rows, cols].max() < 0.01
    assert_allclose(m.b, b, rtol=0.05, atol=2e-3)
    assert m.fpe >= m.mse > 0  # FPE penalises the parameter count


def test_identification_of_the_base_scenario_reports_its_fits():
    from ltdsim.analysis.identify import identify_result

    ds = ltdsim.simulate(ltdsim.load_scenario(PAPER, case="LHHL"))
    m = identify_result(ds, resample_dt=0.01)
    assert np.isfinite([m.fit_percent, m.fpe, m.mse, m.cost]).all()
    assert np.all(np.abs(m.poles) < 1.0)  # a stable model
    # one-step-ahead prediction at a fine sample time follows any smooth signal: the
    # study's ~99 % "fit" level, far above the model's own simulation fit
    fine = identify_result(ds)
    assert fine.prediction_fit_percent > 99.0 > fine.fit_percent + 40.0


def test_best_response_is_the_fast_one_without_overshoot():
    from ltdsim.analysis.response import rank_responses

    systems = {"slow": control.tf([1], [2.0, 1]), "fast": control.tf([1], [0.2, 1]),
               "ringing": control.tf([25.0], [1, 2.0, 25.0])}  # 25 % overshoot, fast
    order = rank_responses({k: step_metrics(v) for k, v in systems.items()})
    assert order == ["fast", "slow", "ringing"]


def test_welch_psd_integrates_to_the_variance_and_peaks_at_the_tone():
    from ltdsim.analysis.spectra import welch_psd

    dt = 1e-3
    t = np.arange(200_000) * dt
    rng = np.random.default_rng(5)
    x = 4.0 * np.sin(2 * np.pi * 1.3 * t) + rng.normal(scale=0.5, size=t.size)
    f, p = welch_psd(x, dt, segment_s=20.0)
    assert_allclose(np.trapezoid(p, f), np.var(x), rtol=0.02)  # Parseval
    assert abs(f[np.argmax(p)] - 1.3) <= 0.05


def test_a_spectral_peak_names_its_mode_by_the_number_modal_gives_it():
    """``ltdsim modal`` numbers the modes from 1 = the lowest, the rigid mode at 0 Hz; a
    peak matched to a mode carries that mode's number (index + 1), so "draft mode 3,
    2.00 Hz" is the table's row 3."""
    import numpy as np

    from ltdsim.analysis.spectra import amplitude_spectrum, spectral_peaks

    dt, n = 0.01, 6000
    t = np.arange(n) * dt
    f, a = amplitude_spectrum(np.sin(2 * np.pi * 2.0 * t), dt)
    modes = np.array([0.0, 1.0, 2.0, 3.1])  # as train_modes gives them, lowest first
    (peak,) = spectral_peaks(f, a, {"draft": modes}, max_peaks=1)
    assert peak["mode"] == "draft" and modes[peak["mode_index"]] == pytest.approx(2.0)
    assert peak["mode_index"] + 1 == 3
