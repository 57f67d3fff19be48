"""Continuum speckle (tier 2): block-lag correlations and moments of every bin."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT
from .rng import block_normals, stream_start


# ---------------------------------------------------------------------------
# continuum speckle (tier 2): per-bin block-lag correlations of the signal
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def cell_cosines_row(x_s, amp_s, n_fft, t_max, out_t):
    """``out_t[t] = 2 sum_s amp_s cos(2 pi x_s t / N)`` for t < t_max, 0 beyond.

    Chebyshev recurrence ``y_{t+1} = 2 cos(theta) y_t - y_{t-1}`` per cell
    (``x_s`` reduced to [0, N) first, so an aliased speed is exactly
    periodic; rounding grows like ``t^2 eps``), the cells updated together
    (a loop the compiler vectorises) and summed in 8 fixed partial sums and
    a fixed tree (:func:`lag_sequence_kernel` folds it per estimate).
    """
    ns = x_s.shape[0]
    nt = out_t.shape[0]
    tm = min(t_max, nt)
    nsp = ((ns + 7) // 8) * 8
    ya = np.zeros(nsp)
    yb = np.zeros(nsp)
    c2 = np.zeros(nsp)
    for s in range(ns):
        x = x_s[s] - n_fft * math.floor(x_s[s] / n_fft)
        c = math.cos(2.0 * math.pi * x / n_fft)
        ya[s] = amp_s[s]
        yb[s] = amp_s[s] * c
        c2[s] = 2.0 * c
    for t in range(tm):
        if t >= 2:
            for s in range(nsp):
                ya[s] = c2[s] * yb[s] - ya[s]
            ya, yb = yb, ya
        cur = ya if t == 0 else yb
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
        for b in range(nsp // 8):
            s0 = 8 * b
            a0 += cur[s0]
            a1 += cur[s0 + 1]
            a2 += cur[s0 + 2]
            a3 += cur[s0 + 3]
            a4 += cur[s0 + 4]
            a5 += cur[s0 + 5]
            a6 += cur[s0 + 6]
            a7 += cur[s0 + 7]
        out_t[t] = 2.0 * (((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7)))
    for t in range(tm, nt):
        out_t[t] = 0.0


@numba.njit(**NJIT)
def fold_block_lags(c_t, g_t, r_d, n_fft, out_jn):
    """Folded lag sequences of the block-lag correlations j = 0 .. J of one estimate.

    ``out[j, m] = r_m g(jN + m) c(jN + m) + r_{N-m} g(jN + m - N) c(jN + m - N)``
    (the second term for m >= 1, and for j = 0 read as lag ``N - m``, the
    mirror of ``-m``), whose real DFT is ``sum_{|d|<N} r_|d| g(jN + d)
    c(jN + d) exp(-i 2 pi k d / N)``.  ``c_t`` and ``g_t`` hold lags
    0 .. (J + 1) N - 1.
    """
    nj = out_jn.shape[0]
    n = n_fft
    out_jn[0, 0] = r_d[0] * g_t[0] * c_t[0]
    for m in range(1, n):
        out_jn[0, m] = r_d[m] * g_t[m] * c_t[m] + r_d[n - m] * g_t[n - m] * c_t[n - m]
    for j in range(1, nj):
        out_jn[j, 0] = r_d[0] * g_t[j * n] * c_t[j * n]
        for m in range(1, n):
            out_jn[j, m] = r_d[m] * g_t[j * n + m] * c_t[j * n + m] + r_d[n - m] * g_t[j * n + m - n] * c_t[
                j * n + m - n]


@numba.njit(**NJIT)
def continuum_lag_rows(x_es, amp_s, g_t, r_d, n_fft, t_max, r_lo, r_hi, c_t, out_ejn):
    """Rows ``r_lo .. r_hi - 1``: :func:`cell_cosines_row` then :func:`fold_block_lags` (``c_t`` scratch)."""
    for e in range(r_lo, r_hi):
        cell_cosines_row(x_es[e], amp_s, n_fft, t_max, c_t)
        fold_block_lags(c_t, g_t, r_d, n_fft, out_ejn[e])


@numba.njit(**NJIT)
def noise_tail(fn_jk, nj, m_blocks, out_k):
    """``out[k] = sum_{j = nj}^{J_n - 1} (1 - j/M) |fn[j, k]|^2``: the noise's block lags beyond the signal's.

    Where the signal has no block lag (``j >= nj``) a bin's correlation is the
    noise's alone, the same for every estimate (:func:`continuum_moment_rows`).
    """
    nn = fn_jk.shape[0]
    inv_m = 1.0 / m_blocks
    for k in range(fn_jk.shape[1]):
        q = 0.0
        for j in range(max(nj, 1), nn):
            wj = 1.0 - j * inv_m
            if wj <= 0.0:
                break
            b = fn_jk[j, k]
            q += wj * (b.real * b.real + b.imag * b.imag)
        out_k[k] = q


@numba.njit(**NJIT)
def continuum_moment_rows(f_ejk, fn_jk, tail_k, noise_f, m_blocks, r_lo, r_hi, mean_ef, var_ef, looks_ef):
    """Mean, variance and signal looks of each bin's M-block average (Gaussian-process moments).

    ``f_ejk[e, j]`` is the DFT of the signal's folded lag sequence of block
    lag j (:func:`fold_block_lags`), ``fn_jk`` the same for the noise
    processes other than shot noise (RIN, reflection; its own number of
    lags, row 0 unused), ``tail_k`` their lags beyond the signal's
    (:func:`noise_tail` with ``nj = f_ejk.shape[1]``), ``noise_f`` the
    expected noise floor.  With ``S = Re f[e, 0]``, ``c_j = f[e, j] +
    fn[j]`` (j >= 1):

    ``mean = S + noise``,
    ``var = k_dc [(S + noise)^2 + 2 sum_{j=1}^{J} (1 - j/M) |c_j|^2] / M``

    (``k_dc = 2`` at 0 Hz and Nyquist, whose DFT values are real), and
    ``looks = M S^2 / (S^2 + 2 sum_j (1 - j/M) |f[e, j]|^2)``, the signal's
    effective independent blocks (M where S = 0).
    """
    nj = f_ejk.shape[1]
    nn = fn_jk.shape[0]
    nf = noise_f.shape[0]
    inv_m = 1.0 / m_blocks
    for e in range(r_lo, r_hi):
        for k in range(nf):
            s = f_ejk[e, 0, k].real
            if s < 0.0:
                s = 0.0
            mu = s + noise_f[k]
            qt = 0.0
            qs = 0.0
            for j in range(1, nj):
                wj = 1.0 - j * inv_m
                if wj <= 0.0:
                    break
                a = f_ejk[e, j, k]
                b = a + fn_jk[j, k] if j < nn else a
                qs += wj * (a.real * a.real + a.imag * a.imag)
                qt += wj * (b.real * b.real + b.imag * b.imag)
            qt += tail_k[k]
            kd = 2.0 if (k == 0 or k == nf - 1) else 1.0
            mean_ef[e, k] = mu
            var_ef[e, k] = kd * (mu * mu + 2.0 * qt) * inv_m
            den = s * s + 2.0 * qs
            looks_ef[e, k] = m_blocks if den <= 0.0 else m_blocks * s * s / den


@numba.njit(**NJIT)
def gamma_moment_rows(mean_ef, var_ef, key, e0, r_lo, r_hi, out_ef):
    """Draw each bin as a Gamma variable of the given mean and variance (Wilson-Hilferty cube of a normal).

    Shape ``kappa = mean^2 / var``: ``out = mean (1 - c + z sqrt(c))^3``,
    ``c = 1 / (9 kappa)``, clipped at 0; row e uses the counter-based stream
    ``e0 + e`` (:func:`block_normals`), so rows may be drawn in any chunks.
    """
    nf = out_ef.shape[1]
    z_f = np.empty(nf)
    words = np.empty((nf + 1) // 2, dtype=np.uint64)
    tails = np.empty(nf, dtype=np.int64)
    for e in range(r_lo, r_hi):
        block_normals(stream_start(key, e0 + e), 1.0, words, tails, z_f)
        for k in range(nf):
            mu = mean_ef[e, k]
            c = var_ef[e, k] / (9.0 * mu * mu)
            b = 1.0 - c + z_f[k] * math.sqrt(c)
            if b < 0.0:
                b = 0.0
            out_ef[e, k] = mu * b * b * b




# ---------------------------------------------------------------------------
# continuum speckle, gridded: the cells' cosine sums by Gaussian gridding and one FFT
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def exp_small(z):
    """``exp(z)`` for ``|z| <= 0.25`` by its Taylor series to z^13 (truncation < 3e-18 relative).

    Within an ulp or two of ``math.exp`` there, and a plain polynomial, so a
    loop over cells that calls it vectorises (the gridding's per-cell
    factors: ``|z| <= pi (r - 1/2) / (r w)``, 0.17 for w = 14 and r = 2).
    """
    p = 1.0 / 6227020800.0
    p = p * z + 1.0 / 479001600.0
    p = p * z + 1.0 / 39916800.0
    p = p * z + 1.0 / 3628800.0
    p = p * z + 1.0 / 362880.0
    p = p * z + 1.0 / 40320.0
    p = p * z + 1.0 / 5040.0
    p = p * z + 1.0 / 720.0
    p = p * z + 1.0 / 120.0
    p = p * z + 1.0 / 24.0
    p = p * z + 1.0 / 6.0
    p = p * z + 0.5
    p = p * z + 1.0
    return p * z + 1.0


@numba.njit(**NJIT)
def gaussian_deposit_rows(x_es, amp_s, n_fft, tau_g, e_j, r_lo, r_hi, out_em):
    """Rows ``r_lo .. r_hi - 1``: each cell's amplitude spread on a periodic grid of M angles by a Gaussian.

    ``out[e, m] = sum_s amp_s exp(-(m h - theta_s)^2 / (4 tau_g))`` over the
    ``2 w + 1`` grid points nearest ``theta_s = 2 pi (x_s mod N) / N``
    (``h = 2 pi / M``, ``w = (len(e_j) - 1) / 2``, indices mod M).  With
    ``d = m0 h - theta_s`` (``m0`` the nearest point) the weight of point
    ``m0 + j`` is ``exp(-d^2 / 4 tau_g) E^j e_j[w + j]``, ``E = exp(-d h / 2
    tau_g)``, ``e_j = exp(-(j h)^2 / 4 tau_g)`` tabulated (Greengard & Lee
    2004, fast Gaussian gridding).

    Two passes over the cells, because one cell's work is a chain of
    dependent products too short to keep the core busy: first every cell's
    ``m0``, ``exp(-d^2 / 4 tau_g)`` and ``E`` (independent iterations, a loop
    that vectorises; :func:`exp_small`, ``|z| <= 0.25`` is checked), then
    for ``j = 1 .. w`` every cell's ``E^j`` and ``E^-j`` by one more product
    and its two points, on a row padded by ``w`` each side so that no index
    wraps (the overhangs are folded onto the row's ends at the end).  A grid
    point sums its cells by increasing ``|j|``, then cell order.
    """
    m = out_em.shape[1]
    ns = x_es.shape[1]
    nw = e_j.shape[0]
    w = (nw - 1) // 2
    h = 2.0 * math.pi / m
    inv4t = 1.0 / (4.0 * tau_g)
    if h * h * inv4t > 0.25:
        raise ValueError("gaussian_deposit_rows: h^2 / (4 tau_g) > 0.25 (outside exp_small's range)")
    m0_s = np.empty(ns, dtype=np.int64)
    up_s = np.empty(ns)
    dn_s = np.empty(ns)
    cp_s = np.empty(ns)
    cn_s = np.empty(ns)
    pad = np.empty(m + 2 * w + 1)
    two_pi_n = 2.0 * math.pi / n_fft
    inv_n = 1.0 / n_fft
    for e in range(r_lo, r_hi):
        for s in range(ns):
            xv = x_es[e, s]
            th = two_pi_n * (xv - n_fft * math.floor(xv * inv_n))
            mf = math.floor(th / h + 0.5)
            d = mf * h - th
            m0_s[s] = int(mf)
            up = exp_small(-2.0 * d * h * inv4t)
            up_s[s] = up
            dn_s[s] = 1.0 / up
            c0 = amp_s[s] * exp_small(-d * d * inv4t)
            cp_s[s] = c0
            cn_s[s] = c0
        for i in range(pad.shape[0]):
            pad[i] = 0.0
        ew = e_j[w]
        for s in range(ns):
            pad[m0_s[s] + w] += cp_s[s] * ew
        for j in range(1, w + 1):
            ep = e_j[w + j]
            en = e_j[w - j]
            for s in range(ns):
                cp = cp_s[s] * up_s[s]
                cn = cn_s[s] * dn_s[s]
                cp_s[s] = cp
                cn_s[s] = cn
                b = m0_s[s] + w
                pad[b + j] += cp * ep
                pad[b - j] += cn * en
        row = out_em[e - r_lo]
        for i in range(m):
            row[i] = pad[i + w]
        # pad[p] is grid point p - w: p < w wraps to the end, p >= m + w to the start
        for p in range(w):
            row[m - w + p] += pad[p]
        for p in range(m + w, m + 2 * w + 1):
            row[p - w - m] += pad[p]


@numba.njit(**NJIT)
def gridded_lag_rows(f_em, deconv_t, a_jn, b_jn, r_lo, r_hi, c_t, out_ejn):
    """Rows ``r_lo .. r_hi - 1``: the cosine sums from the gridded FFT, then the fold of :func:`fold_block_lags`.

    ``c(t) = 2 Re(f[e, t]) deconv[t]`` for t < ``len(deconv)`` (the Gaussian's
    transform divided out: ``deconv[t] = sqrt(pi / tau_g) exp(t^2 tau_g) /
    M``), 0 beyond; ``f_em[e - r_lo]`` is the real FFT of the row's grid
    (:func:`gaussian_deposit_rows`); ``c_t`` is scratch of ``J N`` lags.  The
    fold's factors come multiplied out: ``a[j, m] = r_m g(jN + m)``, ``b[j, m]
    = r_{N-m} g(jN + m - N)`` (:func:`fold_factors`), ``out[e, j, m] = a[j, m]
    c(jN + m) + b[j, m] c(jN + m - N)``, the products of :func:`fold_block_lags`
    in its order.
    """
    nt = c_t.shape[0]
    tm = min(deconv_t.shape[0], nt)
    nj, n = a_jn.shape
    for e in range(r_lo, r_hi):
        f = f_em[e - r_lo]
        for t in range(tm):
            c_t[t] = 2.0 * f[t].real * deconv_t[t]
        for t in range(tm, nt):
            c_t[t] = 0.0
        out = out_ejn[e]
        out[0, 0] = a_jn[0, 0] * c_t[0]
        for m in range(1, n):
            out[0, m] = a_jn[0, m] * c_t[m] + b_jn[0, m] * c_t[n - m]
        for j in range(1, nj):
            jn = j * n
            out[j, 0] = a_jn[j, 0] * c_t[jn]
            for m in range(1, n):
                out[j, m] = a_jn[j, m] * c_t[jn + m] + b_jn[j, m] * c_t[jn + m - n]

