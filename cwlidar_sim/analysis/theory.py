"""Theoretical transfer functions of a staring cw lidar (A2012 Eq. 9 and Eqs. 12-14).

Spectrum convention: the spectra returned here are *one-sided* in k1
[rad/m], like :func:`cwlidar_sim.turbulence.one_point_spectra` and the
measured spectra (``sigma^2 = integral over 0..inf``); ratios of them are
the transfer functions and do not depend on the convention.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_real

__all__ = ["transfer_aligned", "misaligned_spectra"]


def transfer_aligned(k, zR):
    """Power transfer function of a beam along the mean wind, exp(-2 |k| zR) (A2012 Eq. 9).

    Parameters
    ----------
    k : float or array_like
        Wavenumber k1 [rad/m].
    zR : float
        Rayleigh length [m], >= 0 (0 is a point measurement).

    Returns
    -------
    ndarray or float
        ``|phi_hat(k)|^2`` [-]; even in k, so it multiplies one- and
        two-sided spectra alike.
    """
    zR = check_real("zR", zR, lo=0.0)
    k_arr = np.asarray(k, dtype=float)
    if not np.all(np.isfinite(k_arr)):
        raise ValueError("k must be finite; allowed: any finite wavenumber in rad/m")
    out = np.exp(-2.0 * np.abs(k_arr) * zR)
    return float(out) if out.ndim == 0 else out


def _k2_nodes(k1, c, s, zR, L):
    """Quadrature nodes/weights on the whole k2 line for one k1 >= 0.

    The weights exp(-a |k1 c + k2 s|) have a kink at k2 = -k1 c / s, and the
    tensor has its structure about k2 = 0 on the scales |k1| and 1/L; the
    line is cut at both points and each piece gets geometric Gauss-Legendre
    panels (``half_line_nodes``) growing away from its cut points, which
    resolve the kink and the tensor at every scale.
    """
    from ..turbulence.spectra import half_line_nodes

    scales = [1.0 / L]
    if k1 > 0.0:
        scales.append(k1)
    if zR > 0.0 and s != 0.0:
        scales.append(1.0 / (2.0 * zR * abs(s)))
    lo_s, hi_s = min(scales), max(scales)
    cuts = [0.0]
    if s != 0.0 and c != 0.0 and k1 > 0.0:
        cuts.append(-k1 * c / s)
    cuts = sorted(cuts)
    xs, ws = [], []
    x, w = half_line_nodes(lo_s, math.inf, hi_s)
    xs += [cuts[0] - x[::-1], cuts[-1] + x]
    ws += [w[::-1], w]
    for a, b in zip(cuts[:-1], cuts[1:]):
        xh, wh = half_line_nodes(lo_s, 0.5 * (b - a), hi_s)
        xs += [a + xh, b - xh[::-1]]
        ws += [wh, wh[::-1]]
    return np.concatenate(xs), np.concatenate(ws)


def misaligned_spectra(k1_k, params, theta_deg, zR):
    """Sonic, lidar and cross spectra for a beam misaligned by theta (A2012 Eqs. 12-14).

    For the beam direction ``n = (cos theta, sin theta, 0)`` and Taylor's
    hypothesis (the lidar's Lorentzian weighting, A2012 Eq. 4, applied
    along n to the frozen field):

    * ``F_vs(k1) = n_i n_j integral Phi_ij(k) dk2 dk3``            (Eq. 12)
    * ``F_vr(k1) = n_i n_j integral Phi_ij exp(-2 zR |k.n|) dk2 dk3`` (Eq. 13)
    * ``chi(k1)  = n_i n_j integral Phi_ij exp(-zR |k.n|) dk2 dk3``  (Eq. 14)

    (A2012 prints ``exp(-2 zR k.n)``; the Lorentzian's transform is
    ``exp(-zR |k.n|)``.)

    Parameters
    ----------
    k1_k : array_like
        Longitudinal wavenumbers k1 [rad/m], any sign (the spectra are even
        in k1).
    params : MannParameters
        Mann tensor parameters.
    theta_deg : float
        Angle between the beam and the mean wind (x) in the horizontal plane
        [degree], in [-180, 180].
    zR : float
        Rayleigh length [m], >= 0.

    Returns
    -------
    F_vs_k, F_vr_k, chi_k : ndarray
        *One-sided* spectra [m^3 s^-2] (``sigma^2 = integral over 0..inf
        dk1``; twice the two-sided integrals above), the convention of the
        measured ``F_s_k``, ``F_r_k`` and ``chi_k`` of
        :func:`cwlidar_sim.analysis.transfer_functions`: at theta = 0, ``F_vs`` is F11 of
        :func:`cwlidar_sim.turbulence.one_point_spectra` and at 90 degrees
        F22.  ``chi`` is real (the weights and ``n Phi n`` are real).
        ``F_vr F_vs >= chi^2`` by the Cauchy-Schwarz inequality.

    Notes
    -----
    The k3 integral of Phi at each (k1, k2) runs on the k3 nodes of the
    one-point quadrature's fine rule for that k1 (geometric Gauss-Legendre
    panels with extra edges about the shear peak, where k3 + beta k1 = 0;
    ``turbulence.spectra._onepoint_nodes``, ``_kernels.plane_rows_kernel``);
    the k2 integral runs over the whole line,
    cut at 0 and at the kink of the weight, ``k2 = -k1 cot theta``, because
    n_i n_j Phi_ij contains the k2-odd Phi_12 and the weight is not even in
    k2.  The theta = 0 and 90 degree results equal ``one_point_spectra``'s
    F11 and F22 (a folded quadrature) within 2e-7 for Gamma in 0..8, and an
    independent double integral (tests/reference.py) within 3e-8 (tested at
    1e-6).  The plane generator's k3 nodes, which this used before, have no
    edges about the shear peak: 1e-5 off at Gamma = 3.9, 9e-5 at Gamma = 8.
    About 15-25 ms per k1 value on one core; the nodes are shared among the
    configured threads.
    """
    from .. import _config
    from ..turbulence._kernels import plane_rows_kernel
    from ..turbulence.spectra import _onepoint_nodes, _padded_rows
    from ..turbulence.tensor import _check_params, _prefactor, lifetime_table

    _check_params(params)
    theta = check_real("theta_deg", theta_deg, lo=-180.0, hi=180.0)
    zR = check_real("zR", zR, lo=0.0)
    k1 = np.asarray(k1_k, dtype=float)
    if not np.all(np.isfinite(k1)):
        raise ValueError("k1_k must be finite; allowed: any finite wavenumber in rad/m")
    shape = k1.shape
    k1 = np.abs(k1.ravel())
    th = math.radians(theta)
    c, s = math.cos(th), math.sin(th)
    # Exact zeros keep the weight's kink out of the k2 nodes when theta is a
    # multiple of 90 degrees.
    if abs(c) < 1e-15:
        c = 0.0
    if abs(s) < 1e-15:
        s = 0.0
    L = params.length_scale
    tab = lifetime_table()
    nodes = [_k2_nodes(kk, c, s, zR, L) for kk in k1]
    sizes = np.array([len(n[0]) for n in nodes])
    k1_m = np.repeat(k1, sizes)
    k2_m = np.concatenate([n[0] for n in nodes])
    w2_m = np.concatenate([n[1] for n in nodes])
    # k3: the one-point quadrature's fine rule of each k1, edges about the shear peak included
    q3_rj, w3_rj = _padded_rows([_onepoint_nodes(float(kk), L, params.gamma, math.inf, math.inf, tab, "fine")[1]
                                 for kk in k1])
    row_m = np.repeat(np.arange(k1.size), sizes)
    phi_m6 = np.empty((k1_m.size, 6))
    # Fixed chunks by node index: the same arithmetic for any thread count.
    step = 2048
    tasks = [(i, min(k1_m.size, i + step)) for i in range(0, k1_m.size, step)]

    def work(_w, t):
        lo, hi = t
        plane_rows_kernel(k1_m[lo:hi], k2_m[lo:hi], row_m[lo:hi], q3_rj, w3_rj, L, params.gamma, tab,
                          phi_m6[lo:hi])

    _config.run_static(tasks, work)
    # n Phi n for n = (c, s, 0): Phi11 c^2 + Phi22 s^2 + 2 Phi12 c s.
    pnn_m = phi_m6[:, 0] * c * c + phi_m6[:, 1] * s * s + 2.0 * phi_m6[:, 4] * c * s
    pnn_m *= w2_m * _prefactor(params) ** 2
    kn_m = np.abs(k1_m * c + k2_m * s)
    seg_m = np.repeat(np.arange(k1.size), sizes)
    F_vs_k = np.bincount(seg_m, weights=pnn_m, minlength=k1.size)
    F_vr_k = np.bincount(seg_m, weights=pnn_m * np.exp(-2.0 * zR * kn_m), minlength=k1.size)
    chi_k = np.bincount(seg_m, weights=pnn_m * np.exp(-zR * kn_m), minlength=k1.size)
    # one-sided: twice the integrals over the whole (k2, k3) plane (Mann's two-sided spectra)
    return 2.0 * F_vs_k.reshape(shape), 2.0 * F_vr_k.reshape(shape), 2.0 * chi_k.reshape(shape)
