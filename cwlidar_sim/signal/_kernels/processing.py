"""Processing: threshold, estimators and quality flags of one averaged spectrum."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT, NJIT_PARALLEL
from .rng import _DBL_MAX
from .spectral import line_value

# Estimator ids (the registry in processing.py maps names to these).
EST_MEDIAN, EST_CENTROID, EST_PEAK, EST_PEAK_PARABOLIC, EST_PEAK_GAUSSIAN, EST_ML = 0, 1, 2, 3, 4, 5
# Quality flag bits (mirrored by processing.Flag).
F_NO_SIGNAL, F_NEAR_NYQUIST, F_NEAR_ZERO, F_SECOND_PEAK, F_FIT_FAILED = 1, 2, 4, 8, 16
# Threshold kinds.
THR_SIGMA, THR_SNR, THR_PEAK_FRACTION = 0, 1, 2
# Windows.
WIN_RECT, WIN_HANN = 0, 1


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
def _ml_profile(shat, lo, hi, x0, table, oversample, n_fft, a0, g_k):
    """Negative Whittle log-likelihood at line position x0, amplitude profiled by Fisher scoring.

    ``g_k`` is scratch of at least ``hi - lo``: the line's shape at x0, which
    the scoring iterations share (it does not depend on the amplitude).
    """
    g0 = line_value(table, oversample, n_fft, 0.0)
    for k in range(lo, hi):
        g_k[k - lo] = (line_value(table, oversample, n_fft, k - x0) + line_value(table, oversample, n_fft, k + x0)) / g0
    a = a0
    for _ in range(12):
        score = 0.0
        info = 0.0
        for k in range(lo, hi):
            g = g_k[k - lo]
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
        mu = 1.0 + a * g_k[k - lo]
        nll += math.log(mu) + shat[k] / mu
    return nll


@numba.njit(**NJIT)
def _ml_estimate(shat, kp, k_lo, k_hi, table, oversample, n_fft, half_width):
    """Maximum-likelihood line position (bins): golden-section search over [kp - 1, kp + 1]."""
    lo = max(k_lo, kp - half_width)
    hi = min(k_hi, kp + half_width + 1)
    a0 = max(shat[kp] - 1.0, 1e-6)
    g_k = np.empty(max(hi - lo, 1))
    gr = 0.5 * (math.sqrt(5.0) - 1.0)
    a = kp - 1.0
    b = kp + 1.0
    c = b - gr * (b - a)
    d = a + gr * (b - a)
    fc = _ml_profile(shat, lo, hi, c, table, oversample, n_fft, a0, g_k)
    fd = _ml_profile(shat, lo, hi, d, table, oversample, n_fft, a0, g_k)
    for _ in range(40):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - gr * (b - a)
            fc = _ml_profile(shat, lo, hi, c, table, oversample, n_fft, a0, g_k)
        else:
            a, c, fc = c, d, fd
            d = a + gr * (b - a)
            fd = _ml_profile(shat, lo, hi, d, table, oversample, n_fft, a0, g_k)
        if b - a < 1e-6:
            break
    return 0.5 * (a + b)


@numba.njit(**NJIT)
def process_one(spec, inv_bg, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, detect, est_id,
                win_id,
                second_frac, guard_bins, table, oversample, n_fft, ml_half, shat):
    """Threshold one averaged spectrum and estimate its Doppler bin; returns (x [bins] or NaN, flags).

    ``shat`` is scratch of length N/2 + 1 (receives S / B).
    """
    nf = spec.shape[0]
    for k in range(nf):
        shat[k] = spec[k] * inv_bg[k]
    return process_shat(shat, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, detect, est_id,
                        win_id, second_frac, guard_bins, table, oversample, n_fft, ml_half)


@numba.njit(**NJIT)
def process_shat(shat, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, detect, est_id, win_id,
                 second_frac, guard_bins, table, oversample, n_fft, ml_half):
    """:func:`process_one` from ``shat = S / B`` (read only), so several processings can share it."""
    nf = shat.shape[0]
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
        # a peak-relative threshold needs a detection first: the peak must stand detect sigma_y above the
        # floor, or every noise-only spectrum would yield its highest bin as a speed
        if ymax <= detect * sigma_y:
            return np.nan, F_NO_SIGNAL
        t = thr_value * ymax
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
def process_rows(spec_ef, inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, detect,
                 est_id, win_id,
                 second_frac, guard_bins, table, oversample, n_fft, ml_half, r_lo, r_hi, out_x_e, out_flags_e):
    """Rows ``r_lo .. r_hi - 1`` of :func:`process_kernel` (serial, ``nogil``)."""
    shat = np.empty(spec_ef.shape[1])
    for e in range(r_lo, r_hi):
        x, fl = process_one(spec_ef[e], inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y,
                            detect, est_id, win_id, second_frac, guard_bins, table, oversample, n_fft, ml_half, shat)
        out_x_e[e] = x
        out_flags_e[e] = fl


@numba.njit(**NJIT)
def process_rows_variants(spec_ef, inv_bg_f, k_lo_v, k_hi_v, thr_kind_v, thr_value_v, raise_factor_v, raise_offset_v,
                          sigma_y_v, detect_v, est_id_v, win_id, second_frac_v, guard_v, table, oversample, n_fft,
                          ml_half, r_lo, r_hi, out_x_ve, out_flags_ve):
    """Rows ``r_lo .. r_hi - 1`` through every processing variant v (one ``S / B`` per row, read once).

    Each variant's result is that of :func:`process_rows` with its own
    arguments (the ``*_v`` arrays), bit for bit.
    """
    shat = np.empty(spec_ef.shape[1])
    for e in range(r_lo, r_hi):
        row = spec_ef[e]
        for k in range(row.shape[0]):
            shat[k] = row[k] * inv_bg_f[k]
        for v in range(k_lo_v.shape[0]):
            x, fl = process_shat(shat, k_lo_v[v], k_hi_v[v], thr_kind_v[v], thr_value_v[v], raise_factor_v[v],
                                 raise_offset_v[v], sigma_y_v[v], detect_v[v], est_id_v[v], win_id, second_frac_v[v],
                                 guard_v[v], table, oversample, n_fft, ml_half)
            out_x_ve[v, e] = x
            out_flags_ve[v, e] = fl


@numba.njit(**NJIT_PARALLEL)
def process_kernel(spec_ef, inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, detect,
                   est_id, win_id,
                   second_frac, guard_bins, table, oversample, n_fft, ml_half, out_x_e, out_flags_e):
    """:func:`process_one` over every estimate (rows of ``spec_ef``).

    The package runs :func:`process_rows_variants` from its own threads
    (``processing._run_tasks``); this single-processing prange form and
    :func:`process_rows` are kept as the independent forms the tests check it
    against (tests/signal/test_spectral.py, test_estimators.py).
    """
    ne = spec_ef.shape[0]
    n_chunk = 64
    for c in numba.prange((ne + n_chunk - 1) // n_chunk):
        process_rows(spec_ef, inv_bg_f, k_lo, k_hi, thr_kind, thr_value, raise_factor, raise_offset, sigma_y, detect,
                     est_id, win_id,
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


