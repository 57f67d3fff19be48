"""Aerosol backscatter varying along the beam: a random modulation of the probe-volume weighting.

The backscatter coefficient is taken as ``beta(x) = beta0 m(x)`` with
``m = exp(sigma g - sigma^2 / 2)`` (mean 1) and ``g`` a stationary Gaussian
process of unit variance and exponential correlation ``exp(-|dx| / ell)``
along x, frozen in the flow (it advects with the wind like the turbulence).
A cell's weight becomes ``w_s m(x_s) / sum_s w_s m(x_s)``.  Used by
:func:`cwlidar_sim.analysis.estimator_transfer` (``modulation=``).
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_real

__all__ = ["lognormal_modulation"]


def lognormal_modulation(sigma_ln: float, correlation_length: float):
    """A ``modulation(rng, n, dx)`` callable: periodic log-normal backscatter factors on n points.

    Parameters
    ----------
    sigma_ln : float
        Standard deviation of ``log m`` [-]; in [0, 3].
    correlation_length : float
        e-folding length ``ell`` of the correlation of ``log m`` [m]; in (0, 1e5].
    """
    s = check_real("sigma_ln", sigma_ln, lo=0.0, hi=3.0)
    ell = check_real("correlation_length", correlation_length, lo=0.0, hi=1e5, lo_open=True)

    def draw(rng, n, dx):
        # spectral synthesis of the exponential (Ornstein-Uhlenbeck) correlation on the periodic line
        k = 2.0 * math.pi * np.fft.rfftfreq(n, dx)
        psd = 2.0 * ell / (1.0 + (k * ell) ** 2)          # two-sided density of exp(-|r|/ell), per rad/m
        amp = np.sqrt(psd * (2.0 * math.pi / (n * dx)) / (2.0 * math.pi))
        z = (rng.standard_normal(k.size) + 1j * rng.standard_normal(k.size)) / math.sqrt(2.0)
        z[0] = 0.0
        g = np.fft.irfft(amp * z, n=n) * n
        g /= max(float(np.std(g)), 1e-300)
        return np.exp(s * g - 0.5 * s * s)

    draw.sigma_ln, draw.correlation_length = s, ell
    return draw
