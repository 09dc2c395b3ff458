"""Spectra of recorded signals (the study's §5.2, Tables 6-7, and a time-frequency map).

* :func:`amplitude_spectrum`: single-sided FFT amplitude (the study's view: 10 s windows
  give 0.1 Hz resolution), optionally windowed (``flattop`` reads amplitudes of tones
  between bins to better than 1 %).
* :func:`band_stats`: largest amplitude and band RMS (Parseval) up to 10 Hz.
* :func:`spectral_peaks`: the main peaks, each matched to the nearest natural frequency
  of the train and labelled as a low- or high-stiffness mode (Table 6).
* :func:`welch_psd`, :func:`spectrogram`: Welch PSD and a time-frequency map (scipy).
"""

from __future__ import annotations

import numpy as np
from scipy import fft, signal


def amplitude_spectrum(x, dt: float, detrend: bool = True, window: str = "boxcar"):
    """Single-sided amplitude spectrum of samples ``x`` taken every ``dt`` seconds.

    Returns ``(f, a)``: frequencies (Hz, resolution ``1 / (len(x) dt)``) and the
    amplitude of the sinusoid at each frequency, in the unit of ``x`` (a sine of
    amplitude A on a bin reads A). With ``detrend`` the mean is removed first (the DC
    term is the steady force, not an oscillation). ``window`` is any scipy window name;
    amplitudes are corrected for its coherent gain.
    """
    x = np.asarray(x, dtype=float)
    if detrend:
        x = x - x.mean()
    n = x.size
    w = signal.get_window(window, n, fftbins=True)
    a = np.abs(fft.rfft(x * w)) / w.sum()
    a[1:] *= 2.0
    if n % 2 == 0:
        a[-1] /= 2.0  # the Nyquist bin is not doubled
    return fft.rfftfreq(n, dt), a


def band_stats(f, a, f_max: float = 10.0, f_min: float = 0.0) -> dict:
    """Largest amplitude, its frequency, and the RMS of the signal content in the band
    ``[f_min, f_max]`` Hz (Parseval: ``sqrt(sum a^2 / 2)`` over the band's sinusoids)."""
    band = (f >= f_min) & (f <= f_max)
    k = int(np.argmax(np.where(band, a, -np.inf)))
    return {"max": float(a[k]), "f_at_max_hz": float(f[k]),
            "rms": float(np.sqrt(np.sum(a[band] ** 2) / 2.0))}


def spectral_peaks(f, a, modes_low=(), modes_high=(), f_max: float = 10.0,
                   rel_height: float = 0.2, max_peaks: int = 5) -> list[dict]:
    """The main peaks of an amplitude spectrum below ``f_max`` (Hz): local maxima at
    least ``rel_height`` of the largest, largest first. Each is matched to the nearest
    natural frequency in ``modes_low`` / ``modes_high`` (Hz) and labelled "low" or
    "high" stiffness mode by which is nearer."""
    band = f <= f_max
    idx, _ = signal.find_peaks(a[band], height=rel_height * a[band].max())
    idx = idx[np.argsort(-a[band][idx])][:max_peaks]
    out = []
    for i in idx:
        peak = {"frequency_hz": float(f[i]), "amplitude": float(a[i])}
        best = None
        for label, modes in (("low", modes_low), ("high", modes_high)):
            for j, fm in enumerate(modes):
                if fm <= 0:
                    continue
                d = abs(fm - f[i])
                if best is None or d < best[0]:
                    best = (d, label, j, fm)
        if best is not None:
            peak.update(mode=best[1], mode_index=best[2], mode_frequency_hz=float(best[3]))
        out.append(peak)
    return out


def welch_psd(x, dt: float, segment_s: float = 10.0):
    """Welch power spectral density (unit^2/Hz) with ``segment_s``-second Hann segments."""
    nper = min(int(round(segment_s / dt)), len(x))
    return signal.welch(np.asarray(x, dtype=float), fs=1.0 / dt, nperseg=nper)


def spectrogram(x, dt: float, segment_s: float = 10.0, overlap: float = 0.75):
    """Time-frequency map ``(f Hz, t s, amplitude)``: amplitude spectra of Hann-windowed
    ``segment_s`` windows, ``overlap`` of a window apart."""
    nper = min(int(round(segment_s / dt)), len(x))
    f, t, z = signal.stft(np.asarray(x, dtype=float), fs=1.0 / dt, window="hann",
                          nperseg=nper, noverlap=int(overlap * nper), detrend="constant",
                          boundary=None, padded=False)
    return f, t, 2.0 * np.abs(z)
