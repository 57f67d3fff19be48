"""A sonic displaced from the beam: what it does to method 2 (A2012 section II: the sonic ~1 m below the focus).

For the staring beam along the wind, the lidar's output (any estimator) is a
functional of u on the beam's line.  In a homogeneous Gaussian field the
modes of different k1 are independent, so the conditional mean of the
displaced sonic's Fourier mode given the whole u-line is
``rho(k1) U_0(k1)``, with the normalised cross-spectrum

``rho(k1; dy, dz) = integral Phi_11(k) exp(i (k2 dy + k3 dz)) dk2 dk3 / integral Phi_11(k) dk2 dk3``

(Mann tensor; the shear makes ``Phi_11`` asymmetric in k3, hence a small
imaginary part).  Therefore ``chi_offset = conj(rho) chi_0`` exactly and
``F_vs`` does not change, so method 2 becomes
``Re(conj(rho) chi_0)^2 / F_vs^2``, i.e. ``Re(rho)^2 T2_0`` for the nearly
real ``chi_0`` of a symmetric probe volume.  Method 1 does not change at all
(neither spectrum depends on where the sonic is).
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_real

__all__ = ["offset_coherence"]


def offset_coherence(k1_k, params, dz: float, dy: float = 0.0):
    """``rho(k1)``: normalised u-u cross-spectrum between a point and one displaced by (dy, dz) [m] (complex).

    Quadrature: the tensor's own panel nodes (:func:`cwlidar_sim.turbulence.spectra.half_line_nodes`),
    k2 and k3 over the whole line.
    """

    dz = check_real("dz", dz, lo=-1e3, hi=1e3)
    dy = check_real("dy", dy, lo=-1e3, hi=1e3)
    num, den = _cross_spectrum(k1_k, params, dy, dz)
    return num / den


def _cross_spectrum(k1_k, params, dy, dz):
    """(integral Phi_11 exp(i (k2 dy + k3 dz)), integral Phi_11) over k2, k3: two-sided spectra [m^3 s^-2]."""
    from ..turbulence import spectral_tensor
    from ..turbulence.spectra import _scales, half_line_nodes

    k = np.atleast_1d(np.asarray(k1_k, dtype=np.float64))
    num = np.empty(k.size, dtype=np.complex128)
    den = np.empty(k.size)
    for i, k1 in enumerate(k):
        s, t = _scales(k1, params.length_scale)
        x, w = half_line_nodes(s, math.inf, max(t, 1.0 / max(abs(dz), abs(dy), 1e-3)))
        q = np.concatenate([-x[::-1], x])
        wq = np.concatenate([w[::-1], w])
        K2, K3 = np.meshgrid(q, q, indexing="ij")
        phi = spectral_tensor(k1, K2, K3, params)[..., 0, 0] * np.outer(wq, wq)
        num[i] = np.sum(phi * np.exp(1j * (K2 * dy + K3 * dz)))
        den[i] = np.sum(phi)
    return num, den
