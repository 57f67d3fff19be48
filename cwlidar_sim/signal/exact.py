"""Tier 2's expected Doppler spectrum by the exact lag sum (no line-shape table).

Derivation
----------
With the line shape ``G(u) = sum_{|d|<N} a_d exp(i 2 pi u d / N)``,
``a_d = R_w(d) rho^|d| / R_w(0)`` (:mod:`cwlidar_sim.signal.spectral`), the
expected signal periodogram of an estimate is

``S(k) = sum_s A_s [G(k - x_s) + G(k + x_s)] = sum_{|d|<N} a_d C(d) exp(i 2 pi k d / N)``,
``C(d) = sum_s A_s 2 cos(2 pi x_s d / N)``,

``A_s = CNR w_s / 2`` and ``x_s = vlos_es / bin_speed`` the cell's Doppler
frequency in bins (signed; the homodyne mirror is the ``+x_s`` term, and a
speed beyond Nyquist aliases through the periodicity of the cosine).  On
integer bins the lags ``d`` and ``d - N`` coincide, so ``S`` is the real DFT
of the folded sequence ``b_0 = a_0 C(0)``, ``b_d = a_d C(d) + a_{N-d} C(N-d)``.
``C(d)`` for ``d = 0..N-1`` comes from the Chebyshev recurrence
``cos((d+1) t) = 2 cos t cos(d t) - cos((d-1) t)`` (about 3 flops per cell
and lag), then one length-N real FFT per estimate
(``cwlidar_sim._fft.rfft_rows``).  The result equals the defining sum to
rounding (~1e-13 relative), whereas
:func:`cwlidar_sim.signal.expected_spectrum` interpolates a tabulated ``G``
(error <= 1.3e-5 of the peak for the prototype).  Tiny negative rounding
residues (~1e-14 of the peak) are clipped to 0.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_choice, check_real
from ._gridded import gridded_lag_tasks
from .instrument import Instrument
from .noise import lag_coefficients, noise_floor
from .spectral import _as_2d, _signal_lag_rows, _weights, cnr_linear

__all__ = ["expected_spectrum_exact", "signal_rows", "ar1_rho"]


def ar1_rho(instrument, correlation_time: float) -> float:
    """Sample-to-sample correlation ``exp(-1 / (f_s tau_c))`` of the speckle amplitude (1 for a frozen speckle)."""
    return 1.0 if math.isinf(correlation_time) else math.exp(-1.0 / (instrument.sample_rate * correlation_time))


def signal_rows(instrument, vlos_es, amp_s, a_d, *, method: str = "gridded") -> np.ndarray:
    """Expected signal periodogram rows from cell speeds [m/s] and amplitudes ``CNR w_s / 2``.

    ``a_d`` from :func:`cwlidar_sim.signal.noise.lag_coefficients`; returns
    shape ``(n_estimates, N/2 + 1)``.  ``method`` is how the cells' cosine
    sums are formed (:func:`cwlidar_sim.signal.spectral.continuum_moments`):
    'gridded' (default, 1.5-2.5x faster) or 'exact' (the per-cell
    recurrence of ``_kernels.lag_sequence_kernel``, bit for bit); the two
    agree to rounding (about 1e-13 of the total).
    """
    from .._fft import rfft_rows

    check_choice("method", method, ("exact", "gridded"))
    if method == "exact":
        lags = _signal_lag_rows(instrument, vlos_es, amp_s, a_d, method)
        sig = np.ascontiguousarray(rfft_rows(lags).real)
        np.maximum(sig, 0.0, out=sig)
        return sig
    # gridded: the cosine sums, their fold and transform a task at a time in the worker's cache
    n = instrument.n_fft
    x = np.ascontiguousarray(np.asarray(vlos_es, dtype=np.float64) / instrument.bin_speed)
    if x.ndim != 2:
        raise ValueError(f"vlos_es must be 2-D (estimates, cells), got shape {x.shape}")
    sig = np.empty((x.shape[0], n // 2 + 1))

    def real_part(lo, hi, f_rjk):
        np.maximum(f_rjk[:, 0, :].real, 0.0, out=sig[lo:hi])

    gridded_lag_tasks(x, np.ascontiguousarray(amp_s, dtype=np.float64), np.ones(2 * n),
                      np.ascontiguousarray(a_d, dtype=np.float64), n, n, 1, real_part)
    return sig


def check_correlation_time(correlation_time):
    """A speckle correlation time [s]: > 0, or +inf (frozen)."""
    if isinstance(correlation_time, float) and math.isinf(correlation_time) and correlation_time > 0:
        return math.inf
    return check_real("correlation_time", correlation_time, lo=0.0, lo_open=True)


def expected_spectrum_exact(instrument, vlos_es, weight_s, cnr_db: float, *, correlation_time: float = math.inf):
    """Expected averaged spectrum of each estimate, exact (no line-shape table).

    Same model, arguments and returns as
    :func:`cwlidar_sim.signal.expected_spectrum`, computed by the lag sum of
    the module notes: ``O(N n_cells + N log N)`` per estimate.

    Parameters
    ----------
    instrument : Instrument
    vlos_es : array_like, shape (n_estimates, n_cells) or (n_cells,)
        Radial speed of each cell during each estimate [m/s] (signed).
    weight_s : array_like, shape (n_cells,)
        Beam weights [-], >= 0, summing to a value in (0, 1].
    cnr_db : float
        Wideband carrier-to-noise ratio [dB].
    correlation_time : float
        Speckle correlation time tau_c [s]; > 0 or inf (frozen).

    Returns
    -------
    signal_ef : ndarray, shape (n_estimates, N/2 + 1)
        Expected signal part of the averaged periodogram, one-sided bins
        k = 0..N/2, each ``|X_k|^2 / sum w_n^2`` (module convention of
        :mod:`cwlidar_sim.signal.processing`) [units of the noise floor].
    noise_f : ndarray, shape (N/2 + 1,)
        Expected noise floor [-].
    """
    if not isinstance(instrument, Instrument):
        raise TypeError(f"instrument must be an Instrument, got {type(instrument).__name__}")
    v = _as_2d("vlos_es", vlos_es)
    w = _weights(weight_s, v.shape[1])
    cnr = cnr_linear(cnr_db)
    tau = check_correlation_time(correlation_time)
    a_d = lag_coefficients(instrument.n_fft, instrument.window, ar1_rho(instrument, tau))
    return signal_rows(instrument, v, 0.5 * cnr * w, a_d), noise_floor(instrument)
