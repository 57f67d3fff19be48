"""Tier 2: the tabulated line shape, expected spectra and the speckle-and-noise draw."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT, NJIT_PARALLEL
from .continuum import cell_cosines_row
from .rng import block_normals, stream_start


# ---------------------------------------------------------------------------
# line shape and expected spectrum (tier 2)
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def line_value(table, oversample, n_fft, x):
    """Line shape G(x) at an offset of x bins, from its table on [0, N/2] (step 1/oversample).

    G is even and N-periodic; linear interpolation between table nodes.
    """
    x = x - n_fft * math.floor(x / n_fft)
    if x > 0.5 * n_fft:
        x = n_fft - x
    j = x * oversample
    i = int(j)
    if i >= table.shape[0] - 1:
        return table[table.shape[0] - 1]
    f = j - i
    return table[i] * (1.0 - f) + table[i + 1] * f


@numba.njit(**NJIT_PARALLEL)
def expected_signal_kernel(x_es, amp_es, table, oversample, n_fft, out_ef):
    """Expected signal periodogram ``out[e, k] = sum_s amp[e, s] (G(k - x[e, s]) + G(k + x[e, s]))``.

    ``x_es`` are the (signed) Doppler frequencies in bins; the two terms are
    the line and its homodyne mirror.
    """
    ne, nf = out_ef.shape
    ns = x_es.shape[1]
    for e in numba.prange(ne):
        for k in range(nf):
            acc = 0.0
            for s in range(ns):
                a = amp_es[e, s]
                if a != 0.0:
                    x = x_es[e, s]
                    acc += a * (line_value(table, oversample, n_fft, k - x) + line_value(table, oversample, n_fft, k + x))
            out_ef[e, k] = acc


@numba.njit(**NJIT)
def ncx2_wh(ms, mn, inv_mn, nu, z):
    """Mean-M periodogram bin of signal power ``ms`` plus noise ``mn`` (``nu`` = 2M real dof), from a normal z.

    Conditional on the signal power, the average of M block periodograms of
    a bin is ``mn / nu`` times a noncentral chi-square with ``nu`` degrees of
    freedom and noncentrality ``lam = nu ms / mn``.  Patnaik's two-moment
    approximation makes it ``(mn / nu) (a / f) chi2_f`` with ``a = nu + lam``,
    ``f = a^2 / (a + lam)``, and the Wilson-Hilferty cube of a normal draws
    ``chi2_f / f``.  Mean and variance are exact: ``E = ms + mn``,
    ``Var = (mn^2 + 2 ms mn) * 2 / nu``.  ``inv_mn = 1 / mn``.
    """
    lam = nu * ms * inv_mn
    a = nu + lam
    c = 2.0 * (a + lam) / (9.0 * a * a)
    b = 1.0 - c + z * math.sqrt(c)
    if b < 0.0:
        b = 0.0
    return (mn / nu) * a * b * b * b


@numba.njit(**NJIT)
def spectral_sample_rows(sig_ef, noise_f, gain_eg, m_blocks, key, e0, r_lo, r_hi, out_ef):
    """Rows ``r_lo .. r_hi - 1`` of :func:`spectral_sample_kernel` (serial, ``nogil``; each row on its own)."""
    nf = out_ef.shape[1]
    row_step = 0 if sig_ef.shape[0] == 1 else 1
    coherent = gain_eg.shape[1] == 1
    inv_noise = 1.0 / noise_f
    nu_f = np.full(nf, 2.0 * m_blocks)
    nu_f[0] = m_blocks
    nu_f[nf - 1] = m_blocks
    scale_f = np.empty(nf)
    for k in range(nf):
        scale_f[k] = noise_f[k] / nu_f[k]
    z_f = np.empty(nf)
    g_f = np.empty(nf)
    words = np.empty((nf + 1) // 2, dtype=np.uint64)
    tails = np.empty(nf, dtype=np.int64)
    for e in range(r_lo, r_hi):
        block_normals(stream_start(key, e0 + e), 1.0, words, tails, z_f)
        if coherent:
            g = gain_eg[e, 0]
            for k in range(nf):
                g_f[k] = g
        else:
            for k in range(nf):
                g_f[k] = gain_eg[e, k]
        sig = sig_ef[e * row_step]
        out = out_ef[e]
        for k in range(nf):
            nu = nu_f[k]
            lam = nu * (sig[k] * g_f[k]) * inv_noise[k]
            a = nu + lam
            cc = 2.0 * (a + lam) / (9.0 * a * a)
            b = 1.0 - cc + z_f[k] * math.sqrt(cc)
            if b < 0.0:
                b = 0.0
            out[k] = scale_f[k] * a * b * b * b


@numba.njit(**NJIT_PARALLEL)
def spectral_sample_kernel(sig_ef, noise_f, gain_eg, m_blocks, key, e0, out_ef):
    """Tier 2 speckle draw: ``out[e, k]`` = averaged periodogram of M blocks.

    ``sig_ef`` has 1 or ``ne`` rows (broadcast); ``gain_eg`` (the signal's
    speckle factor, Gamma(M_eff, 1/M_eff)) has 1 column (common to the bins
    of an estimate, 'coherent') or ``nf`` columns ('independent').  Bins 0
    and N/2 of a real signal are real: M real degrees of freedom, not 2M.
    Row e uses random stream ``e0 + e`` (so a run may be drawn in chunks):
    bin 2w takes the high and bin 2w + 1 the low 32 bits of the stream's
    word w (``normal_pair`` order), by :func:`normal_u32`.

    The value of a bin is :func:`ncx2_wh`; :func:`spectral_sample_rows`
    repeats its arithmetic operation for operation (so the bits are the
    same) with the per-bin constants hoisted and the normals of a row drawn
    first (:func:`block_normals`), so that the bin loop vectorises.  The
    package calls spectral_sample_rows from its own threads
    (``processing._run_tasks``); this prange form is kept for direct use.
    """
    ne = out_ef.shape[0]
    n_chunk = 32
    for c in numba.prange((ne + n_chunk - 1) // n_chunk):
        spectral_sample_rows(sig_ef, noise_f, gain_eg, m_blocks, key, e0, c * n_chunk,
                             min(ne, (c + 1) * n_chunk), out_ef)


@numba.njit(**NJIT)
def _lag_one(x_s, amp_s, a_d, out_d):
    """One estimate of :func:`lag_sequence_kernel`: the cells' cosine sums, then the fold."""
    n = out_d.shape[0]
    cd = np.empty(n)
    cell_cosines_row(x_s, amp_s, n, n, cd)
    out_d[0] = a_d[0] * cd[0]
    for d in range(1, n):
        out_d[d] = a_d[d] * cd[d] + a_d[n - d] * cd[n - d]


@numba.njit(**NJIT_PARALLEL)
def lag_sequence_kernel(x_es, amp_s, a_d, out_ed):
    """Folded lag sequence of the expected signal spectrum (see :mod:`cwlidar_sim.signal.exact`).

    For each estimate e, with ``theta_s = 2 pi x_s / N`` (``x_s`` the cell's
    Doppler frequency in bins, signed, any size: aliasing is the periodicity
    of the cosine),

    ``C(d) = 2 sum_s amp_s cos(theta_s d)``, d = 0..N-1, by the Chebyshev
    recurrence ``y_{d+1} = 2 cos(theta) y_d - y_{d-1}`` started from
    ``y_0 = amp``, ``y_1 = amp cos(theta)`` (exact up to rounding that grows
    at most like ``d^2 eps``), the cells updated together (a vectorisable
    loop) and summed in 8 fixed partial sums (cell 8 b + j into sum j) and a
    fixed tree;

    ``out[e, 0] = a_0 C(0)``, ``out[e, d] = a_d C(d) + a_{N-d} C(N-d)``:
    the lags d and d - N coincide on integer bins, so the real DFT of ``out``
    gives ``S(k) = sum_{|d|<N} a_d C(d) exp(i 2 pi k d / N)``.
    """
    ne = out_ed.shape[0]
    for e in numba.prange(ne):
        _lag_one(x_es[e], amp_s, a_d, out_ed[e])
