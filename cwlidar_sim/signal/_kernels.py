"""numba kernels of the Doppler signal chain (imported lazily; compile on first use).

Random numbers come from a counter-based scheme: each stream (one estimate in
tier 2, one block of samples or one range cell in tier 3) starts from
``splitmix64(key ^ splitmix64(index))`` and advances as a splitmix64 sequence,
so every number depends only on (seed, index) and never on which thread drew
it.  Slow plain-Python references of every kernel are in ``tests/reference.py``.

Threads: the ``*_rows`` and tier-3 fused kernels are serial and ``nogil``; the
package runs them on its own threads, a task at a time
(``processing._run_tasks``), which copes with a core taken by another process
far better than a static ``prange`` split.  The ``prange`` kernels are kept for
direct use and give the same bits.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.special import ndtri

from .._config import NJIT, NJIT_PARALLEL

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S32 = np.uint64(32)
_LO32 = np.uint64(0xFFFFFFFF)
_TWO_M32 = 2.0**-32
_TWOPI = 2.0 * math.pi
_DBL_MAX = float(np.finfo(np.float64).max)
_START_STREAM = np.uint64(1 << 62)

# Estimator ids (the registry in processing.py maps names to these).
EST_MEDIAN, EST_CENTROID, EST_PEAK, EST_PEAK_PARABOLIC, EST_PEAK_GAUSSIAN, EST_ML = 0, 1, 2, 3, 4, 5
# Quality flag bits (mirrored by processing.Flag).
F_NO_SIGNAL, F_NEAR_NYQUIST, F_NEAR_ZERO, F_SECOND_PEAK, F_FIT_FAILED = 1, 2, 4, 8, 16
# Threshold kinds.
THR_SIGMA, THR_SNR, THR_PEAK_FRACTION = 0, 1, 2
# Windows.
WIN_RECT, WIN_HANN = 0, 1


# ---------------------------------------------------------------------------
# counter-based random numbers
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def mix64(z):
    """splitmix64 finaliser (Steele, Lea & Flood 2014), a bijection of uint64."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@numba.njit(**NJIT)
def stream_start(key, index):
    """Initial state of stream ``index`` under ``key`` (both uint64-convertible)."""
    return mix64(np.uint64(key) ^ mix64(np.uint64(index) * _GOLDEN + _GOLDEN))


# Inverse normal CDF: a table of ndtri on a uniform grid of 2**14 cells of
# (0, 1), linearly interpolated (absolute error < 1e-4 where used), and
# Acklam's rational approximation (relative error < 1.2e-9) in the outer
# 64 cells of each tail (|z| > 2.66), where the table would be too coarse.
_NT_BITS = 14
_NTAB = ndtri(np.arange(2**_NT_BITS + 1) / 2.0**_NT_BITS)
_NT_SHIFT = np.uint64(32 - _NT_BITS)
_NT_FRAC = np.uint64((1 << (32 - _NT_BITS)) - 1)
_NT_FSCALE = 1.0 / (1 << (32 - _NT_BITS))
_NT_LO = 64
_NT_HI = 2**_NT_BITS - 64
_A0, _A1, _A2, _A3, _A4, _A5 = (-3.969683028665376e01, 2.209460984245205e02, -2.759285104469687e02,
                                1.383577518672690e02, -3.066479806614716e01, 2.506628277459239e00)
_B0, _B1, _B2, _B3, _B4 = (-5.447609879822406e01, 1.615858368580409e02, -1.556989798598866e02,
                           6.680131188771972e01, -1.328068155288572e01)
_C0, _C1, _C2, _C3, _C4, _C5 = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e00,
                                -2.549732539343734e00, 4.374664141464968e00, 2.938163982698783e00)
_D0, _D1, _D2, _D3 = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e00, 3.754408661907416e00)


@numba.njit(**NJIT)
def acklam(p):
    """Inverse standard-normal CDF, Acklam's algorithm (relative error < 1.2e-9), 0 < p < 1."""
    if p < 0.02425 or p > 0.97575:
        q = math.sqrt(-2.0 * math.log(p if p < 0.5 else 1.0 - p))
        z = (((((_C0 * q + _C1) * q + _C2) * q + _C3) * q + _C4) * q + _C5) / (
            (((_D0 * q + _D1) * q + _D2) * q + _D3) * q + 1.0)
        return z if p < 0.5 else -z
    q = p - 0.5
    r = q * q
    return (((((_A0 * r + _A1) * r + _A2) * r + _A3) * r + _A4) * r + _A5) * q / (
        ((((_B0 * r + _B1) * r + _B2) * r + _B3) * r + _B4) * r + 1.0)


@numba.njit(**NJIT)
def normal_u32(u):
    """N(0, 1) number from a 32-bit unsigned integer ``u`` (uniform), by inverse CDF.

    The uniform is ``(u + 1/2) / 2**32``: |z| <= 6.3.
    """
    i = int(u >> _NT_SHIFT)
    if i < _NT_LO or i >= _NT_HI:
        return acklam((float(u) + 0.5) * _TWO_M32)
    f = float(u & _NT_FRAC) * _NT_FSCALE
    return _NTAB[i] + f * (_NTAB[i + 1] - _NTAB[i])


@numba.njit(**NJIT)
def normal_pair(state):
    """Two independent N(0, 1) numbers from one splitmix64 step; returns (state, z0, z1)."""
    state = state + _GOLDEN
    z = mix64(state)
    return state, normal_u32(z >> _S32), normal_u32(z & _LO32)


@numba.njit(**NJIT)
def normal_pair_polar(state):
    """Two independent N(0, 1) numbers by Marsaglia's polar method (no trigonometry)."""
    while True:
        state = state + _GOLDEN
        z = mix64(state)
        a = float(z >> _S32) * (2.0 * _TWO_M32) - 1.0
        b = float(z & _LO32) * (2.0 * _TWO_M32) - 1.0
        s = a * a + b * b
        if 0.0 < s < 1.0:
            f = math.sqrt(-2.0 * math.log(s) / s)
            return state, a * f, b * f


# The inverse-CDF table of normal_u32 as (value, slope) pairs, so that a draw
# reads one 16-byte entry; ``a + f * d`` with ``d`` precomputed is the same
# IEEE arithmetic as normal_u32's ``a + f * (b - a)``, so the two agree bit
# for bit.  Values from cells outside [_NT_LO, _NT_HI) are replaced (Acklam).
_NT_PAIR = np.ascontiguousarray(np.stack([_NTAB[:-1], _NTAB[1:] - _NTAB[:-1]], axis=1))
_U_NT_SHIFT = np.uint64(32 - _NT_BITS)
_U_NT_LO = np.uint64(_NT_LO)
_U_NT_SPAN = np.uint64(_NT_HI - _NT_LO)


@numba.njit(**NJIT)
def block_normals(state0, noise_std, words_w, tails_n, out_n):
    """``out_n[:] = noise_std * z`` with z the normals of stream ``state0`` (normal_pair order).

    Word w of the stream is ``mix64(state0 + (w + 1) * golden)`` (what
    ``normal_pair`` steps through); sample 2w comes from its high 32 bits and
    sample 2w + 1 from its low 32 bits, both by :func:`normal_u32` (an odd
    length drops the last low half).  ``words_w`` (>= ceil(n / 2)) and
    ``tails_n`` (>= n) are scratch.
    """
    nn = out_n.shape[0]
    nw = (nn + 1) // 2
    # counter-based words: no carried dependence, the loop vectorises
    for w in range(nw):
        words_w[w] = mix64(state0 + np.uint64(w + 1) * _GOLDEN)
    # table part (every 18-bit cell index is a valid row); samples in the Acklam
    # tails are listed without a branch and recomputed after
    cnt = np.uint64(0)
    for w in range(nn // 2):
        z = words_w[w]
        u = z >> _S32
        i = u >> _U_NT_SHIFT
        f = float(np.int64(u & _NT_FRAC)) * _NT_FSCALE
        out_n[2 * w] = noise_std * (_NT_PAIR[i, 0] + f * _NT_PAIR[i, 1])
        tails_n[cnt] = 2 * w
        cnt += np.uint64((i - _U_NT_LO) >= _U_NT_SPAN)
        u = z & _LO32
        i = u >> _U_NT_SHIFT
        f = float(np.int64(u & _NT_FRAC)) * _NT_FSCALE
        out_n[2 * w + 1] = noise_std * (_NT_PAIR[i, 0] + f * _NT_PAIR[i, 1])
        tails_n[cnt] = 2 * w + 1
        cnt += np.uint64((i - _U_NT_LO) >= _U_NT_SPAN)
    if nn % 2 == 1:
        out_n[nn - 1] = noise_std * normal_u32(words_w[nw - 1] >> _S32)
    for c in range(int(cnt)):
        n = tails_n[c]
        z = words_w[n // 2]
        u = (z >> _S32) if n % 2 == 0 else (z & _LO32)
        out_n[n] = noise_std * acklam((float(u) + 0.5) * _TWO_M32)


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


# ---------------------------------------------------------------------------
# processing: threshold, estimators, flags
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def _interp_peak(yl, yc, yr, est_id, win_id):
    """Sub-bin offset of a peak from its bin and its two neighbours (values of y = S/B - 1)."""
    if est_id == EST_PEAK:
        # Magnitude ratio matched to the window's line shape: for a tone at
        # offset d from the peak bin, |X(neighbour)| / |X(peak)| is
        # d / (1 - d) (rect) or (1 + d) / (2 - d) (Hann).
        right = yr >= yl
        yn = yr if right else yl
        if yc <= 0.0 or yn <= 0.0:
            return 0.0
        r = math.sqrt(yn / yc)
        if win_id == WIN_RECT:
            d = r / (1.0 + r)
        else:
            d = (2.0 * r - 1.0) / (1.0 + r)
        if d < 0.0:
            d = 0.0
        if d > 0.5:
            d = 0.5
        return d if right else -d
    if est_id == EST_PEAK_GAUSSIAN:
        if yl > 0.0 and yc > 0.0 and yr > 0.0:
            yl, yc, yr = math.log(yl), math.log(yc), math.log(yr)
    den = yl - 2.0 * yc + yr
    if den >= 0.0:
        return 0.0
    d = 0.5 * (yl - yr) / den
    if d < -0.5:
        d = -0.5
    if d > 0.5:
        d = 0.5
    return d


@numba.njit(**NJIT)
def _ml_profile(shat, lo, hi, x0, table, oversample, n_fft, a0):
    """Negative Whittle log-likelihood at line position x0, amplitude profiled by Fisher scoring."""
    g0 = line_value(table, oversample, n_fft, 0.0)
    a = a0
    for _ in range(12):
        score = 0.0
        info = 0.0
        for k in range(lo, hi):
            g = (line_value(table, oversample, n_fft, k - x0) + line_value(table, oversample, n_fft, k + x0)) / g0
            mu = 1.0 + a * g
            score += g * (shat[k] - mu) / (mu * mu)
            info += g * g / (mu * mu)
        if info <= 0.0:
            break
        step = score / info
        a_new = a + step
        if a_new < 0.5 * a:
            a_new = 0.5 * a
        if abs(a_new - a) <= 1e-10 * (1.0 + a):
            a = a_new
            break
        a = a_new
    nll = 0.0
    for k in range(lo, hi):
        g = (line_value(table, oversample, n_fft, k - x0) + line_value(table, oversample, n_fft, k + x0)) / g0
        mu = 1.0 + a * g
        nll += math.log(mu) + shat[k] / mu
    return nll


@numba.njit(**NJIT)
def _ml_estimate(shat, kp, k_lo, k_hi, table, oversample, n_fft, half_width):
    """Maximum-likelihood line position (bins): golden-section search over [kp - 1, kp + 1]."""
    lo = max(k_lo, kp - half_width)
    hi = min(k_hi, kp + half_width + 1)
    a0 = max(shat[kp] - 1.0, 1e-6)
    gr = 0.5 * (math.sqrt(5.0) - 1.0)
    a = kp - 1.0
    b = kp + 1.0
    c = b - gr * (b - a)
    d = a + gr * (b - a)
    fc = _ml_profile(shat, lo, hi, c, table, oversample, n_fft, a0)
    fd = _ml_profile(shat, lo, hi, d, table, oversample, n_fft, a0)
    for _ in range(40):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - gr * (b - a)
            fc = _ml_profile(shat, lo, hi, c, table, oversample, n_fft, a0)
        else:
            a, c, fc = c, d, fd
            d = a + gr * (b - a)
            fd = _ml_profile(shat, lo, hi, d, table, oversample, n_fft, a0)
        if b - a < 1e-6:
            break
    return 0.5 * (a + b)


@numba.njit(**NJIT)
def process_one(spec, inv_bg, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, est_id, win_id,
                second_frac, guard_bins, table, oversample, n_fft, ml_half, shat):
    """Threshold one averaged spectrum and estimate its Doppler bin; returns (x [bins] or NaN, flags).

    ``shat`` is scratch of length N/2 + 1 (receives S / B).
    """
    nf = spec.shape[0]
    for k in range(nf):
        shat[k] = spec[k] * inv_bg[k]
    # threshold on y = S/B - 1
    if thr_kind == THR_SIGMA:
        t = thr_value * sigma_y
    elif thr_kind == THR_SNR:
        t = thr_value
    else:
        ymax = -1.0
        for k in range(k_lo, k_hi):
            if shat[k] - 1.0 > ymax:
                ymax = shat[k] - 1.0
        t = thr_value * ymax if ymax > 0.0 else 0.0
    # the raise: t -> raise_factor t + raise_offset (processing.threshold_levels)
    t = raise_factor * t + raise_offset
    # totals, argmax, separated groups of thresholded bins
    total = 0.0
    first = 0.0
    kp = -1
    pmax = 0.0
    best = 0.0
    second = 0.0
    run = 0.0
    gap = 3
    for k in range(k_lo, k_hi):
        p = shat[k] - 1.0 - t
        if p > 0.0:
            total += p
            first += k * p
            if p > pmax:
                pmax = p
                kp = k
            if gap > 2:
                # a new group starts: file the previous one
                if run > best:
                    second = best
                    best = run
                elif run > second:
                    second = run
                run = 0.0
            run += p
            gap = 0
        else:
            gap += 1
    if run > best:
        second = best
        best = run
    elif run > second:
        second = run
    if total <= 0.0 or kp < 0:
        return np.nan, F_NO_SIGNAL
    flags = 0
    if second >= second_frac * best:
        flags |= F_SECOND_PEAK
    # the strongest thresholded bin at an edge of the scanned band: the line lies in the blind zone (or
    # beyond Nyquist) and only its tail is seen, whatever the estimate (docs/stability.md)
    if kp == k_lo:
        flags |= F_NEAR_ZERO
    if kp == k_hi - 1:
        flags |= F_NEAR_NYQUIST
    if est_id == EST_MEDIAN:
        half = 0.5 * total
        cum = 0.0
        x = np.nan
        for k in range(k_lo, k_hi):
            p = shat[k] - 1.0 - t
            if p > 0.0:
                if cum + p >= half:
                    # the bin's power is spread evenly over [k - 1/2, k + 1/2]
                    x = k - 0.5 + (half - cum) / p
                    break
                cum += p
    elif est_id == EST_CENTROID:
        x = first / total
    elif est_id == EST_ML:
        x = _ml_estimate(shat, kp, k_lo, k_hi, table, oversample, n_fft, ml_half)
    else:
        yl = shat[kp - 1] - 1.0 if kp >= 1 else 0.0
        yr = shat[kp + 1] - 1.0 if kp + 1 < nf else 0.0
        x = kp + _interp_peak(yl, shat[kp] - 1.0, yr, est_id, win_id)
    if not (x == x):
        return np.nan, flags | F_FIT_FAILED
    if x < k_lo + guard_bins:
        flags |= F_NEAR_ZERO
    if x > (nf - 1) - guard_bins:
        flags |= F_NEAR_NYQUIST
    return x, flags


@numba.njit(**NJIT)
def process_rows(spec_ef, inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, est_id, win_id,
                 second_frac, guard_bins, table, oversample, n_fft, ml_half, r_lo, r_hi, out_x_e, out_flags_e):
    """Rows ``r_lo .. r_hi - 1`` of :func:`process_kernel` (serial, ``nogil``)."""
    shat = np.empty(spec_ef.shape[1])
    for e in range(r_lo, r_hi):
        x, fl = process_one(spec_ef[e], inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y,
                            est_id, win_id, second_frac, guard_bins, table, oversample, n_fft, ml_half, shat)
        out_x_e[e] = x
        out_flags_e[e] = fl


@numba.njit(**NJIT_PARALLEL)
def process_kernel(spec_ef, inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, est_id, win_id,
                   second_frac, guard_bins, table, oversample, n_fft, ml_half, out_x_e, out_flags_e):
    """:func:`process_one` over every estimate (rows of ``spec_ef``).

    The package calls :func:`process_rows` from its own threads
    (``processing._run_tasks``); this prange form is kept for direct use.
    """
    ne = spec_ef.shape[0]
    n_chunk = 64
    for c in numba.prange((ne + n_chunk - 1) // n_chunk):
        process_rows(spec_ef, inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, est_id, win_id,
                     second_frac, guard_bins, table, oversample, n_fft, ml_half, c * n_chunk,
                     min(ne, (c + 1) * n_chunk), out_x_e, out_flags_e)


@numba.njit(**NJIT)
def valid_spectra_rows(spec_ef, r_lo, r_hi):
    """True when every value of rows ``r_lo .. r_hi - 1`` is finite and >= 0 (one pass, no temporaries)."""
    nf = spec_ef.shape[1]
    ok = True
    for e in range(r_lo, r_hi):
        row = spec_ef[e]
        for k in range(nf):
            v = row[k]
            # NaN fails both comparisons
            ok &= (v >= 0.0) & (v <= _DBL_MAX)
    return ok


# ---------------------------------------------------------------------------
# tier 3: heterodyne signal
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def ar1_cell(key, s, step0, rho, std, first_re, first_im, out_re_t, out_im_t):
    """AR(1) amplitudes of range cell ``s`` for steps ``step0 .. step0 + len - 1`` (see ar1_amplitudes_kernel)."""
    nt = out_re_t.shape[0]
    inno = math.sqrt(max(0.0, 1.0 - rho * rho))
    ckey = mix64(np.uint64(key) ^ mix64(np.uint64(s) + _GOLDEN))
    sd = std * math.sqrt(0.5)
    ar = first_re
    ai = first_im
    for t in range(nt):
        st = stream_start(ckey, step0 + t)
        st, z0, z1 = normal_pair(st)
        if step0 + t == 0:
            ar = sd * z0
            ai = sd * z1
        else:
            ar = rho * ar + inno * sd * z0
            ai = rho * ai + inno * sd * z1
        out_re_t[t] = ar
        out_im_t[t] = ai


@numba.njit(**NJIT_PARALLEL)
def ar1_amplitudes_kernel(key, step0, rho, std_s, first_re_s, first_im_s, out_re_ts, out_im_ts):
    """AR(1) complex-Gaussian speckle amplitudes of each range cell.

    ``a[t] = rho a[t-1] + sqrt(1 - rho^2) xi[t]`` with ``E|a|^2 = std_s^2``;
    ``first_*`` is the amplitude before step ``step0`` (ignored when
    ``step0 == 0``: the first step is drawn from the stationary law).  The
    innovation of global step t of cell s comes from stream (cell s, step t).
    """
    ns = out_re_ts.shape[1]
    for s in numba.prange(ns):
        ar1_cell(key, s, step0, rho, std_s[s], first_re_s[s], first_im_s[s], out_re_ts[:, s], out_im_ts[:, s])


@numba.njit(**NJIT_PARALLEL)
def synth_kernel(key, block0, n_sub, amp_re_ts, amp_im_ts, phase0_bs, dtheta_bs, noise_std, window_n, use_window,
                 out_bn):
    """Real heterodyne samples of ``out_bn.shape[0]`` blocks starting at global block ``block0``.

    ``x[n] = sum_s Re(a_s e^{i (phase0_s + dtheta_s n)}) + noise_std * xi[n]``;
    the amplitude of cell s is constant over each of the ``n_sub`` sub-steps
    of a block (row ``b * n_sub + j`` of ``amp_*_ts``).  The tones follow the
    Chebyshev recurrence ``y[n] = 2 cos(theta) y[n-1] - y[n-2]`` (float64),
    restarted at each sub-step, with the cells interleaved so that their
    independent recurrences pipeline.  Noise of global block b comes from
    stream b (Marsaglia's polar method).

    The package now synthesises with :func:`synth_blocks_kernel` (table
    normals, vectorised tones, fused with the FFT); this unfused form is
    kept as a second, independent implementation of the same signal model
    (it is checked against the plain-Python reference in the tests).
    """
    nb, nn = out_bn.shape
    ns = dtheta_bs.shape[1]
    ln = nn // n_sub
    for b in numba.prange(nb):
        st = stream_start(key, block0 + b)
        for n in range(0, nn, 2):
            st, z0, z1 = normal_pair_polar(st)
            out_bn[b, n] = noise_std * z0
            out_bn[b, n + 1] = noise_std * z1
        y0 = np.empty(ns)
        y1 = np.empty(ns)
        c2 = np.empty(ns)
        for j in range(n_sub):
            n0 = j * ln
            for s in range(ns):
                ar = amp_re_ts[b * n_sub + j, s]
                ai = amp_im_ts[b * n_sub + j, s]
                th = dtheta_bs[b, s]
                ph = phase0_bs[b, s] + th * n0
                y0[s] = ar * math.cos(ph) - ai * math.sin(ph)
                y1[s] = ar * math.cos(ph + th) - ai * math.sin(ph + th)
                c2[s] = 2.0 * math.cos(th)
            acc0 = 0.0
            acc1 = 0.0
            for s in range(ns):
                acc0 += y0[s]
                acc1 += y1[s]
            out_bn[b, n0] += acc0
            if ln > 1:
                out_bn[b, n0 + 1] += acc1
            for n in range(2, ln):
                acc = 0.0
                for s in range(ns):
                    y2 = c2[s] * y1[s] - y0[s]
                    y0[s] = y1[s]
                    y1[s] = y2
                    acc += y2
                out_bn[b, n0 + n] += acc
        if use_window:
            for n in range(nn):
                out_bn[b, n] *= window_n[n]


@numba.njit(**NJIT_PARALLEL)
def power_average_kernel(spec_bf, m_blocks, scale, out_ef):
    """``out[e, k] = scale / M * sum_b |X[e M + b, k]|^2`` (blocks summed in order).

    The unfused form of :func:`power_sum_kernel` + :func:`combine_partials_kernel`.
    """
    ne, nf = out_ef.shape
    for e in numba.prange(ne):
        for k in range(nf):
            out_ef[e, k] = 0.0
        for b in range(e * m_blocks, (e + 1) * m_blocks):
            for k in range(nf):
                v = spec_bf[b, k]
                out_ef[e, k] += v.real * v.real + v.imag * v.imag
        for k in range(nf):
            out_ef[e, k] *= scale / m_blocks


# ---------------------------------------------------------------------------
# tier 3, fused path: one block at a time into a worker's FFT input buffer
# ---------------------------------------------------------------------------
#: Samples per group of the tone loop: the tone's phasor is stepped once per
#: group and the samples of a group come from a table of ``exp(i j theta)``,
#: so the inner loop has no carried dependence and vectorises.
TONE_GROUP = 32


@numba.njit(**NJIT)
def tone_tables_kernel(dtheta_es, ln, rot_re_esq, rot_im_esq, step_es4):
    """Rotation factors of each cell's tone in each estimate (speeds are constant over an estimate).

    ``rot[e, s, q] = exp(i q dtheta)`` for q < G = :data:`TONE_GROUP` by the
    complex recurrence (error O(G * 1e-16)); ``step[e, s] = (cos G dtheta,
    sin G dtheta, cos L dtheta, sin L dtheta)`` from their own cos/sin, L the
    sub-step length.
    """
    ne, ns = dtheta_es.shape
    for e in range(ne):
        for s in range(ns):
            th = dtheta_es[e, s]
            c1 = math.cos(th)
            s1 = math.sin(th)
            rr = 1.0
            ri = 0.0
            for q in range(TONE_GROUP):
                rot_re_esq[e, s, q] = rr
                rot_im_esq[e, s, q] = ri
                rr, ri = rr * c1 - ri * s1, rr * s1 + ri * c1
            step_es4[e, s, 0] = math.cos(TONE_GROUP * th)
            step_es4[e, s, 1] = math.sin(TONE_GROUP * th)
            step_es4[e, s, 2] = math.cos(ln * th)
            step_es4[e, s, 3] = math.sin(ln * th)


@numba.njit(**NJIT)
def add_tones(n_sub, amp_re_j, amp_im_j, phase0, rot_re_q, rot_im_q, step_4, acc_n):
    """``acc_n[n] += Re(a_j exp(i (phase0 + dtheta n)))``, ``a_j`` constant over sub-step j of L = len / n_sub.

    The phasor ``exp(i (phase0 + dtheta n0))`` starts from cos/sin of
    ``phase0`` (exact re-anchoring at every block) and is rotated by
    ``exp(i L dtheta)`` from sub-step to sub-step; ``z = a_j exp(i (phase0 +
    dtheta n))`` is rotated by ``exp(i G dtheta)`` (G = :data:`TONE_GROUP`)
    from group to group of G samples, and within a group sample ``n + q`` is
    ``Re(z exp(i q dtheta))`` with the factors of ``rot_*_q``
    (:func:`tone_tables_kernel`), so the inner loop has no carried
    dependence and vectorises.  All in float64: after the at most ``len``
    rotations of a block the rounding error is O(len * 1e-16) of the amplitude.
    """
    nn = acc_n.shape[0]
    ln = nn // n_sub
    ng = ln // TONE_GROUP
    cg = step_4[0]
    sg = step_4[1]
    cl = step_4[2]
    sl = step_4[3]
    pr = math.cos(phase0)
    pi = math.sin(phase0)
    for j in range(n_sub):
        ar = amp_re_j[j]
        ai = amp_im_j[j]
        zr = ar * pr - ai * pi
        zi = ar * pi + ai * pr
        n0 = j * ln
        # whole groups: a constant trip count over a slice (indices provably >= 0),
        # which the compiler vectorises
        for gi in range(ng):
            seg = acc_n[n0 + gi * TONE_GROUP:n0 + (gi + 1) * TONE_GROUP]
            for q in range(TONE_GROUP):
                seg[q] += zr * rot_re_q[q] - zi * rot_im_q[q]
            zr, zi = zr * cg - zi * sg, zr * sg + zi * cg
        seg = acc_n[n0 + ng * TONE_GROUP:n0 + ln]
        for q in range(seg.shape[0]):
            seg[q] += zr * rot_re_q[q] - zi * rot_im_q[q]
        pr, pi = pr * cl - pi * sl, pr * sl + pi * cl


@numba.njit(**NJIT)
def synth_blocks_kernel(key, block0, b_lo, b_hi, m_blocks, n_sub, amp_re_st, amp_im_st, phase_es, dtheta_es,
                        rot_re_esq, rot_im_esq, step_es4, noise_std, window_n, use_window, extra_et, acc_n, words_w,
                        tails_n, out_bn):
    """Real heterodyne samples of blocks ``b_lo .. b_hi - 1`` of a chunk into rows 0.. of ``out_bn`` (float32).

    The signal of :func:`synth_kernel`, ``x[n] = noise_std * xi[n] + sum_s
    Re(a_s e^{i (phase0_s + dtheta_s n)})``, windowed.  Chunk block b is
    global block ``block0 + b``, block ``i = b mod M`` of the chunk's
    estimate ``e = b // M``, and starts at Doppler phase ``phase0_s =
    (phase_es[e, s] + dtheta_es[e, s] N i) mod 2 pi``; tone tables from
    :func:`tone_tables_kernel`; noise from stream ``block0 + b``
    (:func:`block_normals`: table normals, where synth_kernel uses the
    polar method); amplitudes ``amp_*_st[s, b n_sub + j]``, j < n_sub.
    Cells are added in order in float64 (:func:`add_tones`), then the window
    is applied and the sum rounded to float32.  Every block depends only on
    its own inputs, so the result does not depend on how blocks are split
    between calls or threads (serial and ``nogil``: worker threads call it
    on disjoint blocks).  ``extra_et`` (rows: the chunk's estimates, M N
    samples each; or 0 rows) is added to the samples before the window: the
    continuum signal and the RIN (:func:`continuum_shape_noise`).
    ``acc_n``, ``words_w``, ``tails_n`` are scratch (lengths N, ceil(N/2), N).
    """
    nn = acc_n.shape[0]
    ns = phase_es.shape[1]
    for b in range(b_lo, b_hi):
        block_normals(stream_start(key, block0 + b), noise_std, words_w, tails_n, acc_n)
        t0 = b * n_sub
        e = b // m_blocks
        i = b - e * m_blocks
        for s in range(ns):
            ph0 = (phase_es[e, s] + dtheta_es[e, s] * (nn * i)) % _TWOPI
            add_tones(n_sub, amp_re_st[s, t0:t0 + n_sub], amp_im_st[s, t0:t0 + n_sub], ph0, rot_re_esq[e, s],
                      rot_im_esq[e, s], step_es4[e, s], acc_n)
        if extra_et.shape[0] > 0:
            xr = extra_et[e, i * nn:(i + 1) * nn]
            for n in range(nn):
                acc_n[n] += xr[n]
        r = b - b_lo
        if use_window:
            for n in range(nn):
                out_bn[r, n] = np.float32(acc_n[n] * window_n[n])
        else:
            for n in range(nn):
                out_bn[r, n] = np.float32(acc_n[n])


@numba.njit(**NJIT)
def power_sum_kernel(spec_bf, n_rows, out_f):
    """``out_f[k] = sum_{b < n_rows} |X[b, k]|^2`` in float64, rows summed in order."""
    nf = out_f.shape[0]
    for k in range(nf):
        out_f[k] = 0.0
    for b in range(n_rows):
        for k in range(nf):
            v = spec_bf[b, k]
            re = np.float64(v.real)
            im = np.float64(v.imag)
            out_f[k] += re * re + im * im


@numba.njit(**NJIT)
def combine_partials_kernel(partial_erf, factor, out_ef):
    """``out[e, k] = factor * sum_r partial[e, r, k]`` (r in order)."""
    ne, nr, nf = partial_erf.shape
    for e in range(ne):
        for k in range(nf):
            out_ef[e, k] = 0.0
        for r in range(nr):
            for k in range(nf):
                out_ef[e, k] += partial_erf[e, r, k]
        for k in range(nf):
            out_ef[e, k] *= factor


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
    a fixed tree (``sensors._kernels.lag_sequence_kernel`` folds it per estimate).
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
# tier 3, continuum path: a Gaussian process synthesised from its spectrum
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def continuum_correlation_fill(x_s, amp2_s, g_t, rn_t, n_fft, t_max, buf_p):
    """``buf[tau] = sum_s amp2_s exp(i 2 pi x_s tau / N) g(tau) + 2 rn(tau)`` for tau < t_max, its conjugate at P - tau.

    The complex correlation of the synthesised process (signal cells of
    power ``amp2_s = E|a_s|^2`` at ``x_s`` bins, plus twice the real noise
    correlation ``rn``, so that the real part carries ``rn``); 0 elsewhere.
    The phasor of a cell is rotated lag by lag (error O(tau eps)).
    """
    p = buf_p.shape[0]
    for i in range(p):
        buf_p[i] = 0.0j
    ns = x_s.shape[0]
    for s in range(ns):
        a = amp2_s[s]
        if a == 0.0:
            continue
        x = x_s[s] - n_fft * math.floor(x_s[s] / n_fft)
        th = 2.0 * math.pi * x / n_fft
        c = math.cos(th)
        sn = math.sin(th)
        zr = a
        zi = 0.0
        for t in range(t_max):
            buf_p[t] += complex(zr * g_t[t], zi * g_t[t])
            zr, zi = zr * c - zi * sn, zr * sn + zi * c
    for t in range(t_max):
        buf_p[t] += 2.0 * rn_t[t]
    for t in range(1, t_max):
        buf_p[p - t] = buf_p[t].conjugate()


@numba.njit(**NJIT)
def continuum_shape_noise(key, stream, buf_p, words_w, tails_n, tmp_n):
    """Replace the spectrum ``S_m`` in ``buf`` by ``sqrt(max(Re S_m, 0) / (2P)) (z0 + i z1)``.

    ``z0, z1`` standard normals from the counter-based streams
    ``stream_start(mix64(key ^ stream), c)``, c = 0, 1, .. (``tmp_n.shape[0]``
    normals each); the inverse FFT of the result is a circular complex
    Gaussian process with correlation ``(1/P) sum_m S_m exp(i 2 pi m n / P)``.
    """
    p = buf_p.shape[0]
    nc = tmp_n.shape[0]
    skey = mix64(np.uint64(key) ^ mix64(np.uint64(stream) + _GOLDEN))
    inv = 1.0 / (2.0 * p)
    c = 0
    pos = nc
    for m in range(p):
        if pos + 2 > nc:
            block_normals(stream_start(skey, c), 1.0, words_w, tails_n, tmp_n)
            c += 1
            pos = 0
        s = buf_p[m].real
        a = math.sqrt(s * inv) if s > 0.0 else 0.0
        buf_p[m] = complex(a * tmp_n[pos], a * tmp_n[pos + 1])
        pos += 2


@numba.njit(**NJIT)
def real_part_into(buf_p, n, out_n):
    """``out_n[:n] = Re buf_p[:n]``."""
    for i in range(n):
        out_n[i] = buf_p[i].real


@numba.njit(**NJIT)
def ar1_noise_kernel(key, stream, var_c, rho_c, words_w, tails_n, tmp_n, out_t):
    """``out_t[:] = sum_c x_c``, each ``x_c`` a stationary real AR(1) process of variance ``var_c[c]``.

    ``x[0] = sqrt(var) z_0``, ``x[t] = rho x[t-1] + sqrt(var (1 - rho^2)) z_t``: correlation
    ``var rho^|tau|`` exactly (the RIN and reflection of ``spectral.noise_correlation``).
    Normals from the counter-based streams ``stream_start(mix64(key ^ stream), j)``, one per
    chunk j of ``B = tmp_n.shape[0] // n_c`` samples (component c takes normals
    ``c B .. (c + 1) B - 1`` of its chunk), the starting values from stream 2^62; the
    components' recursions run side by side.
    """
    nt = out_t.shape[0]
    nc = var_c.shape[0]
    bl = tmp_n.shape[0] // nc
    skey = mix64(np.uint64(key) ^ mix64(np.uint64(stream) + _GOLDEN))
    x = np.zeros(nc)
    sdi = np.empty(nc)
    for c in range(nc):
        sdi[c] = math.sqrt(var_c[c] * (1.0 - rho_c[c] * rho_c[c]))
    # stationary start: x[-1] ~ N(0, var) (a stream of its own), so x[0] = rho x[-1] + innovation is too
    st = stream_start(skey, _START_STREAM)
    for c in range(nc):
        st, z0, _z1 = normal_pair(st)
        x[c] = math.sqrt(var_c[c]) * z0
    j = 0
    for t0 in range(0, nt, bl):
        block_normals(stream_start(skey, j), 1.0, words_w, tails_n, tmp_n)
        j += 1
        t1 = min(nt, t0 + bl)
        for t in range(t0, t1):
            acc = 0.0
            for c in range(nc):
                x[c] = rho_c[c] * x[c] + sdi[c] * tmp_n[c * bl + (t - t0)]
                acc += x[c]
            out_t[t] = acc
