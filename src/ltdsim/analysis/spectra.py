"""Spectra of recorded signals (the study's §5.2, Tables 6-7, and a time-frequency map).

* :func:`amplitude_spectrum`: single-sided FFT amplitude (the study's view: 10 s windows
  give 0.1 Hz resolution), optionally windowed (``flattop`` reads amplitudes of tones
  between bins to better than 1 %).
* :func:`band_stats`: largest amplitude and band RMS (Parseval) up to 10 Hz.
* :func:`spectral_peaks`: the main peaks, each matched to the nearest natural frequency
  of the train on the coupling branch (draft or buff) engaged in that phase
  (:func:`engaged_branches`; Table 6), never below the spectrum's resolution.
* :func:`welch_psd`, :func:`spectrogram`: Welch PSD and a time-frequency map (scipy).
"""

from __future__ import annotations

import numpy as np
from scipy import fft, signal

from ltdsim.results.io import scenario_of


def amplitude_spectrum(x, dt: float, detrend="constant", window: str = "boxcar"):
    """Single-sided amplitude spectrum of samples ``x`` taken every ``dt`` seconds.

    Returns ``(f, a)``: frequencies (Hz, resolution ``1 / (len(x) dt)``) and the
    amplitude of the sinusoid at each frequency, in the unit of ``x`` (a sine of
    amplitude A on a bin reads A). ``detrend`` removes the mean first (``"constant"`` or
    True: the DC term is the steady force, not an oscillation), or the straight line
    through the samples (``"linear"``: a force that drifts over the window would
    otherwise leak into the lowest lines), or nothing (False). ``window`` is any scipy
    window name; amplitudes are corrected for its coherent gain.
    """
    x = np.asarray(x, dtype=float)
    if detrend is True or detrend == "constant":
        x = x - x.mean()
    elif detrend == "linear":
        x = signal.detrend(x, type="linear")
    elif detrend is not False:
        raise ValueError(f"detrend must be 'constant', 'linear' or False, got {detrend!r}")
    n = x.size
    w = signal.get_window(window, n, fftbins=True)
    a = np.abs(fft.rfft(x * w)) / w.sum()
    a[1:] *= 2.0
    if n % 2 == 0:
        a[-1] /= 2.0  # the Nyquist bin is not doubled
    return fft.rfftfreq(n, dt), a


def band_stats(f, a, f_max: float = 10.0, f_min: float = 0.0) -> dict:
    """Largest amplitude, its frequency, and two RMS values over the band ``[f_min,
    f_max]`` Hz, in the unit of the amplitudes:

    * ``rms``: the RMS of the signal content in the band (Parseval: ``sqrt(sum a^2 / 2)``
      over the band's sinusoids); it grows with the number of lines and can exceed the
      largest single line;
    * ``spectrum_rms``: the RMS of the amplitude spectrum's values over the band's
      lines, ``sqrt(mean a^2)``, never above the largest line. The study's Table 7
      ("maximum and average (RMS between 0-10 Hz)") reads as this one.
    """
    band = (f >= f_min) & (f <= f_max)
    k = int(np.argmax(np.where(band, a, -np.inf)))
    return {"max": float(a[k]), "f_at_max_hz": float(f[k]),
            "rms": float(np.sqrt(np.sum(a[band] ** 2) / 2.0)),
            "spectrum_rms": float(np.sqrt(np.mean(a[band] ** 2)))}


def spectral_peaks(f, a, modes=None, f_max: float = 10.0, rel_height: float = 0.2,
                   max_peaks: int = 5, f_min: float | None = None) -> list[dict]:
    """The main peaks of an amplitude spectrum below ``f_max`` (Hz): local maxima at
    least ``rel_height`` of the largest, largest first. ``modes`` maps a branch name
    ("draft", "buff") to the train's natural frequencies (Hz) on that branch; each peak
    at or above ``f_min`` (Hz; default twice the spectrum's resolution ``f[1]``: a line
    nearer to 0 Hz is the window's trend, not a mode) is matched to the nearest of them
    and labelled with its branch and ``mode_index`` into that branch's frequencies (the
    rigid mode at 0 Hz counted: mode number ``mode_index + 1``, as ``ltdsim modal``'s
    table numbers them; the rigid mode itself is never matched)."""
    band = f <= f_max
    idx, _ = signal.find_peaks(a[band], height=rel_height * a[band].max())
    idx = idx[np.argsort(-a[band][idx])][:max_peaks]
    f_min = 2.0 * float(f[1]) if f_min is None else f_min
    out = []
    for i in idx:
        peak = {"frequency_hz": float(f[i]), "amplitude": float(a[i])}
        best = None
        if f[i] >= f_min:
            for label, freqs in (modes or {}).items():
                # (j indexes all the modes, the rigid one at 0 Hz included, as
                # ltdsim modal's table numbers them: mode j + 1)
                for j, fm in enumerate(freqs):
                    if fm <= 1e-6:
                        continue
                    d = abs(fm - f[i])
                    if best is None or d < best[0]:
                        best = (d, label, j, fm)
        if best is not None:
            peak.update(mode=best[1], mode_index=best[2], mode_frequency_hz=float(best[3]))
        out.append(peak)
    return out


def engaged_branches(deflection, slack: float, share: float = 0.2) -> list[str]:
    """The coupling branches a coupler spends at least ``share`` (0-1) of a record in:
    "draft" (deflection beyond half its ``slack`` in tension, m) and/or "buff" (in
    compression), in that order; empty when it spends the record in its slack. A
    spectral peak is a mode of the train linearised on the branch its couplers are on."""
    d = np.asarray(deflection, dtype=float)
    if d.size == 0:
        return []
    h = 0.5 * slack
    out = []
    if np.mean(d > h) >= share:
        out.append("draft")
    if np.mean(d < -h) >= share:
        out.append("buff")
    return out


def welch_psd(x, dt: float, segment_s: float = 10.0):
    """Welch power spectral density (unit^2/Hz) with ``segment_s``-second Hann segments."""
    nper = min(int(round(segment_s / dt)), len(x))
    return signal.welch(np.asarray(x, dtype=float), fs=1.0 / dt, nperseg=nper)


def spectrogram(x, dt: float, segment_s: float = 10.0, overlap: float = 0.75,
                detrend: str = "constant"):
    """Time-frequency map ``(f Hz, t s, amplitude)``: amplitude spectra of Hann-windowed
    ``segment_s`` windows, ``overlap`` of a window apart, each window's mean
    (``detrend="constant"``) or straight-line trend (``"linear"``) removed first."""
    nper = min(int(round(segment_s / dt)), len(x))
    f, t, z = signal.stft(np.asarray(x, dtype=float), fs=1.0 / dt, window="hann",
                          nperseg=nper, noverlap=int(overlap * nper), detrend=detrend,
                          boundary=None, padded=False)
    return f, t, 2.0 * np.abs(z)


def phase_spectra(ds, scenario=None, couplers=(0, 7, 8), f_max: float = 10.0,
                  lead: str = "held", detrend="linear"):
    """Per phase and coupler (``couplers``: indices from 0; coupler 1 as people count,
    behind the lead, is index 0; the table has both, ``coupler`` the index and
    ``coupler_number`` the number people read, 1 = behind the lead, for what is shown
    or written): largest amplitude (N) and its frequency (Hz), band RMS (N)
    up to ``f_max``, the spectrum's resolution (Hz), the coupling branches engaged
    (:func:`engaged_branches`), and the main peaks matched to the train's modes on those
    branches (the study's Tables 6 and 7), each force's trend removed first
    (``detrend``, :func:`amplitude_spectrum`). Modes from
    :func:`ltdsim.analysis.modal.train_modes` on the draft and buff branches, the couplings as the
    kernel simulates them; couplers whose model has no linearised stiffness are matched
    to none."""

    import pandas as pd

    from ltdsim.analysis.modal import train_modes
    from ltdsim.analysis.phases import phases_of

    scenario = scenario_of(ds, scenario)
    modes = {}
    for branch in ("draft", "buff"):
        try:
            modes[branch] = train_modes(scenario, branch, lead).frequency_hz.values
        except ValueError:
            pass
    dt = float(ds.time[1] - ds.time[0])
    rows = []
    for name, a, b in phases_of(ds, scenario):
        w = ds.sel(time=slice(a, b - 0.5 * dt))
        for c in couplers:
            f, amp = amplitude_spectrum(w.coupler_force.isel(coupler=c).values, dt,
                                        detrend=detrend)
            s = band_stats(f, amp, f_max)
            engaged = engaged_branches(w.coupler_deflection.isel(coupler=c).values,
                                       scenario.coupler(c).slack)
            peaks = spectral_peaks(f, amp, {k: modes[k] for k in engaged if k in modes},
                                   f_max)
            rows.append({"phase": name, "coupler": c, "coupler_number": c + 1,
                         "max_N": s["max"],
                         "f_at_max_hz": s["f_at_max_hz"], "band_rms_N": s["rms"],
                         "spectrum_rms_N": s["spectrum_rms"],
                         "resolution_hz": float(f[1]) if f.size > 1 else float("nan"),
                         "branches": " + ".join(engaged) or "slack",
                         "peaks": "; ".join(f"{p['frequency_hz']:.1f} Hz"
                                            + (f" ({p['mode']} mode {p['mode_index'] + 1}, "
                                               f"{p['mode_frequency_hz']:.2f} Hz)"
                                               if "mode" in p else "") for p in peaks)})
    return pd.DataFrame(rows)


def band_share(ds, scenario=None, couplers=(0, 7, 8), f_split: float = 4.0,
               f_max: float = 10.0) -> dict:
    """Share (0-1) of each coupler's force fluctuation between 0 and ``f_max`` Hz that
    lies below ``f_split`` Hz, per phase: ``{phase: {coupler index: share}}`` (Parseval:
    sums of squared amplitudes of the spectrum with its linear trend removed). The study finds the coupler
    forces' content within 0-4 Hz (§5.2)."""

    from ltdsim.analysis.phases import phases_of

    scenario = scenario_of(ds, scenario)
    dt = float(ds.time[1] - ds.time[0])
    out = {}
    for name, a, b in phases_of(ds, scenario):
        w = ds.coupler_force.sel(time=slice(a, b - 0.5 * dt))
        out[name] = {}
        for c in couplers:
            f, amp = amplitude_spectrum(w.isel(coupler=c).values, dt, detrend="linear")
            total = np.sum(amp[f <= f_max] ** 2)
            out[name][str(c)] = float(np.sum(amp[f < f_split] ** 2) / total) if total > 0 else 1.0
    return out


