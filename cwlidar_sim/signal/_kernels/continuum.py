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
def continuum_moment_rows(f_ejk, fn_jk, noise_f, m_blocks, r_lo, r_hi, mean_ef, var_ef, looks_ef):
    """Mean, variance and signal looks of each bin's M-block average (Gaussian-process moments).

    ``f_ejk[e, j]`` is the DFT of the signal's folded lag sequence of block
    lag j (:func:`fold_block_lags`), ``fn_jk`` the same for the noise
    processes other than shot noise (RIN, reflection; its own number of
    lags, row 0 unused), ``noise_f`` the
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
    nmax = max(nj, nn)
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
            for j in range(1, nmax):
                wj = 1.0 - j * inv_m
                if wj <= 0.0:
                    break
                a = f_ejk[e, j, k] if j < nj else 0.0j
                b = a + fn_jk[j, k] if j < nn else a
                qs += wj * (a.real * a.real + a.imag * a.imag)
                qt += wj * (b.real * b.real + b.imag * b.imag)
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
def gaussian_deposit_rows(x_es, amp_s, n_fft, tau_g, e_j, r_lo, r_hi, out_em):
    """Rows ``r_lo .. r_hi - 1``: each cell's amplitude spread on a periodic grid of M angles by a Gaussian.

    ``out[e, m] = sum_s amp_s exp(-(m h - theta_s)^2 / (4 tau_g))`` over the
    ``2 w + 1`` grid points nearest ``theta_s = 2 pi (x_s mod N) / N``
    (``h = 2 pi / M``, ``w = (len(e_j) - 1) / 2``, indices mod M), cells in
    order.  With ``d = m0 h - theta_s`` (``m0`` the nearest point) the weight
    of point ``m0 + j`` is ``exp(-d^2 / 4 tau_g) E^j e_j[w + j]``, ``E =
    exp(-d h / 2 tau_g)``, ``e_j = exp(-(j h)^2 / 4 tau_g)`` tabulated
    (Greengard & Lee 2004, fast Gaussian gridding); ``E^j`` and ``E^-j`` are
    products from the centre out (odd and even j stepped by ``E^2``; ``E^-1 =
    1 / E``), within a few ulp of ``exp``.
    """
    m = out_em.shape[1]
    ns = x_es.shape[1]
    nw = e_j.shape[0]
    w = (nw - 1) // 2
    h = 2.0 * math.pi / m
    inv4t = 1.0 / (4.0 * tau_g)
    for e in range(r_lo, r_hi):
        row = out_em[e - r_lo]
        for i in range(m):
            row[i] = 0.0
        for s in range(ns):
            a = amp_s[s]
            if a == 0.0:
                continue
            x = x_es[e, s] - n_fft * math.floor(x_es[e, s] / n_fft)
            th = 2.0 * math.pi * x / n_fft
            m0 = int(math.floor(th / h + 0.5))
            d = m0 * h - th
            # one exp for E and 1/E (|d| <= h/2: E is within a few percent of 1)
            up = math.exp(-2.0 * d * h * inv4t)
            down = 1.0 / up
            c0 = a * math.exp(-d * d * inv4t)
            if m0 - w >= 0 and m0 + w < m:
                seg = row[m0 - w:m0 + w + 1]
                seg[w] += c0 * e_j[w]
                # E^j and E^-j as four product chains (odd and even j, stepped by E^2),
                # so that the multiplications' latencies overlap
                up2 = up * up
                down2 = down * down
                po = c0 * up
                pe = po * up
                no = c0 * down
                ne_ = no * down
                for j in range(1, w, 2):
                    seg[w + j] += po * e_j[w + j]
                    seg[w - j] += no * e_j[w - j]
                    seg[w + j + 1] += pe * e_j[w + j + 1]
                    seg[w - j - 1] += ne_ * e_j[w - j - 1]
                    po *= up2
                    no *= down2
                    pe *= up2
                    ne_ *= down2
                if w % 2 == 1:
                    seg[2 * w] += po * e_j[2 * w]
                    seg[0] += no * e_j[0]
            else:
                # near the ends of the grid: the same sums, indices wrapped (plain chains)
                row[m0 % m] += c0 * e_j[w]
                cp = c0
                cn = c0
                for j in range(1, w + 1):
                    cp *= up
                    cn *= down
                    row[(m0 + j) % m] += cp * e_j[w + j]
                    row[(m0 - j) % m] += cn * e_j[w - j]


@numba.njit(**NJIT)
def gridded_lag_rows(f_em, deconv_t, g_t, r_d, n_fft, t_max, r_lo, r_hi, c_t, out_ejn):
    """Rows ``r_lo .. r_hi - 1``: the cosine sums from the gridded FFT, then :func:`fold_block_lags`.

    ``c(t) = 2 Re(f[e, t]) deconv[t]`` for t < t_max (the Gaussian's
    transform divided out: ``deconv[t] = sqrt(pi / tau_g) exp(t^2 tau_g) /
    M``), 0 beyond; ``f_em[e - r_lo]`` is the real FFT of the row's grid
    (:func:`gaussian_deposit_rows`); ``c_t`` is scratch.
    """
    nt = c_t.shape[0]
    tm = min(t_max, nt)
    for e in range(r_lo, r_hi):
        f = f_em[e - r_lo]
        for t in range(tm):
            c_t[t] = 2.0 * f[t].real * deconv_t[t]
        for t in range(tm, nt):
            c_t[t] = 0.0
        fold_block_lags(c_t, g_t, r_d, n_fft, out_ejn[e])
