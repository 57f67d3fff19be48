"""Noise of the detector signal: window, shot noise, relative-intensity noise and the 0 Hz reflection.

The lowest module of the signal chain's physics: :func:`noise_floor` (the
expected noise spectrum every tier and the processing use), the correlation of
the coloured noise processes (:func:`noise_correlation`) and the window's
autocorrelation (:func:`lag_coefficients`).  The coloured components are
described in :mod:`cwlidar_sim.signal.instrument` (``rin_*``,
``reflection_*``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .._validation import check_choice, check_int

__all__ = ["noise_floor", "noise_correlation", "lag_coefficients", "window_samples"]

#: Relative correlation below which a lag is dropped.
_G_CUT = 1e-12


def window_samples(n_fft: int, window: str) -> np.ndarray:
    """Window ``w_n``, n = 0..N-1: 'rect' (ones) or 'hann' (periodic, ``sin^2(pi n / N)``)."""
    n_fft = check_int("n_fft", n_fft, lo=2, hi=65536)
    check_choice("window", window, ("rect", "hann"))
    if window == "rect":
        return np.ones(n_fft)
    return np.sin(np.pi * np.arange(n_fft) / n_fft) ** 2


def _noise_components(instrument):
    """(level, corner) of the Lorentzian noise processes above shot noise: RIN, internal reflection."""
    out = []
    if instrument.rin_level > 0.0:
        out.append((instrument.rin_level, instrument.rin_corner))
    if instrument.reflection_level > 0.0:
        out.append((instrument.reflection_level, instrument.reflection_corner))
    return out


def _noise_lag_count(instrument):
    cut = math.log(1.0 / _G_CUT)
    t = 0.0
    for _, fc in _noise_components(instrument):
        t = max(t, cut * instrument.sample_rate / (2.0 * math.pi * fc))
    return t


def noise_correlation(instrument, n_lags: int) -> np.ndarray:
    """Correlation of the noise above shot noise (RIN plus the 0 Hz reflection) at lags 0 .. n_lags - 1.

    Each component of level ``P0`` (its density at 0 Hz relative to shot
    noise) and corner ``f_c`` is a real Gaussian process with correlation
    ``r(tau) = P0 (1 - rho) / (1 + rho) rho^|tau|``, ``rho = exp(-2 pi f_c / f_s)``
    (sampled exponential, i.e. a discrete AR(1)): its spectrum is
    ``P0 (1 - rho)^2 / (1 - 2 rho cos(2 pi f / f_s) + rho^2)``, exactly ``P0``
    at 0 Hz and ``P0 / (1 + (f / f_c)^2)`` for ``f << f_s`` (the Lorentzian
    of the ``rin_level`` of :class:`~cwlidar_sim.signal.Instrument`).  In units of the shot-noise variance.
    """
    t = np.arange(check_int("n_lags", n_lags, lo=1), dtype=np.float64)
    r = np.zeros(t.size)
    for p0, fc in _noise_components(instrument):
        rho = math.exp(-2.0 * math.pi * fc / instrument.sample_rate)
        r += p0 * (1.0 - rho) / (1.0 + rho) * rho ** t
    r[np.abs(r) < _G_CUT * max(1e-300, float(np.max(np.abs(r))) if r.size else 1.0)] = 0.0
    return r


@functools.lru_cache(maxsize=16)
def lag_coefficients(n_fft: int, window: str, rho: float) -> np.ndarray:
    """``a_d = R_w(d) rho^d / R_w(0)``, d = 0..N-1: the window's autocorrelation times an AR(1) factor (read-only)."""
    w = window_samples(n_fft, window)
    r = np.array([np.dot(w[: n_fft - d], w[d:]) for d in range(n_fft)])
    a = r / r[0]
    if rho < 1.0:
        a = a * rho ** np.arange(n_fft)
    a.setflags(write=False)
    return a


def _window_lags(instrument):
    return lag_coefficients(instrument.n_fft, instrument.window, 1.0)


def _fold_noise(instrument, n_j=None):
    """DFT (k = 0..N/2) of the folded noise lag sequences for block lags j = 0 .. n_j - 1 (default: all needed)."""
    from . import _kernels as K
    from .._fft import rfft_rows

    n = instrument.n_fft
    if n_j is None:
        n_j = int(math.ceil(_noise_lag_count(instrument) / n)) + 1
    r = noise_correlation(instrument, (n_j + 1) * n)
    lags = np.empty((n_j, n))
    K.fold_block_lags(r, np.ones(r.size), _window_lags(instrument), n, lags)
    return rfft_rows(lags)


def noise_floor(instrument) -> np.ndarray:
    """Expected noise spectrum per one-sided bin, in units of the shot-noise level [-].

    White shot noise (1 in every bin) plus the relative-intensity noise and
    the 0 Hz internal reflection, each a real Gaussian process of density
    ``P0`` at 0 Hz and corner ``f_c`` (:func:`cwlidar_sim.signal.spectral.noise_correlation`):
    the expected block periodogram of such a process is the exact lag sum
    ``sum_{|d|<N} (R_w(d) / R_w(0)) r(d) exp(-i 2 pi k d / N)``, close to
    ``P0 / (1 + (f / f_c)^2)`` for ``f << f_s`` and a corner of several bins.
    """
    if not _noise_components(instrument):
        return np.ones(instrument.n_bins)
    return 1.0 + np.maximum(_fold_noise(instrument, 1)[0].real, 0.0)
