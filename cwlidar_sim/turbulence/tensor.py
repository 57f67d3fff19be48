"""The Mann (1994) uniform-shear spectral tensor Phi_ij(k).

Convention: ``Phi_ij(k)`` is the spectral density in wave-vector space, so
that the covariance is ``<u_i u_j> = integral of Phi_ij(k) d^3k`` over all of
R^3, with k in rad/m.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .parameters import MannParameters

_TABLE_SIZE = 4097


@functools.lru_cache(maxsize=1)
def lifetime_table() -> np.ndarray:
    """log f(x) on the grid used by the kernels (x = |k| L, beta = Gamma f).

    f(x) = x^(-2/3) / sqrt(2F1(1/3, 17/6; 4/3; -x^-2)).  Linear interpolation
    in log-log on 4097 points over x in [1e-4, 1e4] has a relative error
    below 2e-6 (tested against scipy.special.hyp2f1).
    """
    from scipy.special import hyp2f1

    from ._kernels import LOG_X_HI, LOG_X_LO

    lx = np.linspace(LOG_X_LO, LOG_X_HI, _TABLE_SIZE)
    x = np.exp(lx)
    f = x ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(x**-2)))
    tab = np.log(f)
    tab.setflags(write=False)
    return tab


def energy_spectrum(k, params: MannParameters):
    """von Karman energy spectrum E(k) [m^3 s^-2].

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude |k| [rad/m], >= 0.
    params : MannParameters

    Returns
    -------
    E : ndarray
        ``alpha_eps L^(5/3) (kL)^4 / (1 + (kL)^2)^(17/6)``; integrates over
        0..inf to the turbulent kinetic energy (sum of the three variances / 2).
    """
    _check_params(params)
    k = np.abs(np.asarray(k, dtype=float))
    kl = k * params.length_scale
    return params.alpha_eps * params.length_scale ** (5.0 / 3.0) * kl**4 / (1.0 + kl**2) ** (17.0 / 6.0)


def eddy_lifetime(k, params: MannParameters):
    """Dimensionless eddy lifetime beta(k) = Gamma (kL)^(-2/3) / sqrt(2F1(1/3, 17/6; 4/3; -(kL)^-2)).

    Computed exactly with scipy (the kernels use an interpolation table).

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude [rad/m], > 0.
    """
    from scipy.special import hyp2f1

    _check_params(params)
    kl = np.abs(np.asarray(k, dtype=float)) * params.length_scale
    with np.errstate(divide="ignore"):
        return params.gamma * kl ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(kl**-2.0)))


def amplitude_matrix(k1, k2, k3, params: MannParameters):
    """Real amplitude matrix M(k) with Phi(k) = M M^T.

    Parameters
    ----------
    k1, k2, k3 : array_like
        Wave-vector components [rad/m], broadcast together.
    params : MannParameters

    Returns
    -------
    M : ndarray, shape broadcast + (3, 3)
        ``M = D(k) A_iso(k0)`` of Mann (1998), including the factor
        sqrt(alpha_eps / (4 pi)) L^(17/6); units m^(5/2) s^-1 so that
        ``M M^T`` is the spectral density [m^5 s^-2].
    """
    from ._kernels import amplitude_many

    _check_params(params)
    b1, b2, b3 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (k1, k2, k3)))
    shape = b1.shape
    out = np.empty((b1.size, 3, 3))
    amplitude_many(b1.ravel().copy(), b2.ravel().copy(), b3.ravel().copy(),
                   params.length_scale, params.gamma, lifetime_table(), out)
    out *= _prefactor(params)
    return out.reshape(shape + (3, 3))


def spectral_tensor(k1, k2, k3, params: MannParameters):
    """Mann spectral tensor Phi_ij(k) [m^5 s^-2].

    Parameters
    ----------
    k1, k2, k3 : array_like
        Wave-vector components [rad/m], broadcast together.
    params : MannParameters

    Returns
    -------
    Phi : ndarray, shape broadcast + (3, 3)
        Real symmetric, positive semi-definite, divergence-free
        (``k_i Phi_ij = 0``); ``<u_i u_j> = integral of Phi_ij d^3k``.
    """
    m = amplitude_matrix(k1, k2, k3, params)
    return m @ np.swapaxes(m, -1, -2)


def _prefactor(params: MannParameters) -> float:
    return math.sqrt(params.alpha_eps / (4.0 * math.pi)) * params.length_scale ** (17.0 / 6.0)


def _check_params(params):
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be a MannParameters, got {type(params).__name__}")
