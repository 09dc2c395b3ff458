"""Amplitude spectra of recorded signals (the study's Table 6-7 view, paper §5.2).

Only the basic single-sided amplitude spectrum and its band statistics live here so far;
identification, modal analysis and time-frequency maps are issue 5's.
"""

from __future__ import annotations

import numpy as np
from scipy import fft


def amplitude_spectrum(x, dt: float, detrend: bool = True):
    """Single-sided amplitude spectrum of samples ``x`` taken every ``dt`` seconds.

    Returns ``(f, a)``: frequencies (Hz, resolution ``1 / (len(x) dt)``) and the
    amplitude of the sinusoid at each frequency, in the unit of ``x`` (a sine of
    amplitude A on a bin reads A). With ``detrend`` the mean is removed first (the DC
    term is the steady force, not an oscillation).
    """
    x = np.asarray(x, dtype=float)
    if detrend:
        x = x - x.mean()
    n = x.size
    a = np.abs(fft.rfft(x)) / n
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
