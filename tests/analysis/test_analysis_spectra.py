"""Segment-averaged spectra, log-binning and measured transfer functions (A2012 section V)."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis import (
    bin_average,
    component_spectra,
    log_bins,
    segment_spectra,
    transfer_functions,
)


# --------------------------------------------------------------------------
# binning
# --------------------------------------------------------------------------
def test_log_bins_are_geometric_with_exact_ends():
    e = log_bins(1e-3, 5.0, 10)
    assert e[0] == 1e-3 and e[-1] == 5.0
    # ceil(10 * log10(5000)) = ceil(36.99) = 37 bins of equal ratio.
    assert e.size == 38
    r = e[1:] / e[:-1]
    np.testing.assert_allclose(r, r[0], rtol=1e-12)
    assert r[0] <= 10 ** (1 / 10) + 1e-12
    # Whole decades give exactly per_decade bins per decade.
    assert log_bins(0.01, 10.0, 4).size == 13


def test_bin_average_half_open_bins_empty_and_complex():
    x = np.array([0.5, 1.0, 1.5, 2.0, 3.9, 4.0, 10.0])
    v = np.array([9.0, 1.0, 3.0, 5.0, 7.0, 100.0, 100.0])
    mean, cnt = bin_average(x, v, [1.0, 2.0, 3.0, 4.0])
    # [1, 2) holds 1.0 and 1.5; [2, 3) holds 2.0; [3, 4) holds 3.9; 0.5, 4.0 and 10 lie outside.
    np.testing.assert_array_equal(cnt, [2, 1, 1])
    np.testing.assert_allclose(mean, [2.0, 5.0, 7.0])
    mean, cnt = bin_average(x, v + 1j * (2 * v), [1.0, 2.0, 3.0, 3.5, 4.0])
    assert np.iscomplexobj(mean)
    np.testing.assert_allclose(mean[[0, 1, 3]], np.array([2.0, 5.0, 7.0]) * (1 + 2j))
    assert np.isnan(mean[2]) and cnt[2] == 0
    # Leading axes are averaged independently.
    m2, _ = bin_average(x, np.stack([v, 2 * v]), [1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(m2, [[2.0, 5.0, 7.0], [4.0, 10.0, 14.0]])


# --------------------------------------------------------------------------
# normalisation
# --------------------------------------------------------------------------
@pytest.mark.parametrize("n_per", [1000, 999])
def test_parseval_one_segment_even_and_odd(n_per):
    rng = np.random.default_rng(1)
    fs = 10.0
    x = 3.0 + rng.standard_normal(n_per).cumsum() * 0.1
    y = -1.0 + 0.5 * x + rng.standard_normal(n_per)
    s = segment_spectra(x, y, fs=fs, segment_duration=n_per / fs)
    df = fs / n_per
    assert s.n_segments == 1 and s.f_f[0] == pytest.approx(df) and s.f_f.size == n_per // 2
    # Exact identities (rounding only): variance about the removed mean.
    assert np.sum(s.psd_xf) * df == pytest.approx(np.var(x), rel=1e-12)
    assert np.sum(s.psd_yf) * df == pytest.approx(np.var(y), rel=1e-12)
    cov = np.mean((x - x.mean()) * (y - y.mean()))
    assert np.sum(s.csd_f).real * df == pytest.approx(cov, rel=1e-12)
    # Mean square = removed mean^2 + integral of the one-sided PSD.
    assert x.mean() ** 2 + np.sum(s.psd_xf) * df == pytest.approx(np.mean(x**2), rel=1e-12)


def test_parseval_many_segments_and_linear_detrend():
    rng = np.random.default_rng(2)
    fs, n_per, m = 4.0, 256, 5
    x = rng.standard_normal(n_per * m + 100) + 0.01 * np.arange(n_per * m + 100)  # tail dropped
    s = segment_spectra(x, fs=fs, segment_duration=n_per / fs)
    segs = x[: n_per * m].reshape(m, n_per)
    assert s.n_segments == m and s.n_rejected == 0
    assert np.sum(s.psd_xf) * s.df == pytest.approx(np.mean(np.var(segs, axis=1)), rel=1e-12)
    s_lin = segment_spectra(x, fs=fs, segment_duration=n_per / fs, detrend="linear")
    t = np.arange(n_per)
    res = [seg - np.polyval(np.polyfit(t, seg, 1), t) for seg in segs]
    assert np.sum(s_lin.psd_xf) * s_lin.df == pytest.approx(np.mean([np.mean(r**2) for r in res]), rel=1e-10)


def test_sinusoid_lands_in_its_frequency_and_bin():
    fs, T = 10.0, 600.0
    t = np.arange(int(fs * T)) / fs
    f0, A = 37 / T, 1.7  # on the frequency grid j / T
    s = segment_spectra(4.0 + A * np.sin(2 * math.pi * f0 * t + 0.3), fs=fs, segment_duration=T)
    j = int(np.argmax(s.psd_xf))
    assert s.f_f[j] == pytest.approx(f0)
    # All the power A^2 / 2 in that one frequency; leakage only at rounding level.
    assert s.psd_xf[j] * s.df == pytest.approx(A**2 / 2, rel=1e-12)
    assert np.sum(np.delete(s.psd_xf, j)) * s.df < 1e-20
    e = log_bins(s.f_f[0], fs / 2, 8)
    mean, cnt = bin_average(s.f_f, s.psd_xf, e)
    b = int(np.nanargmax(mean))
    assert e[b] <= f0 < e[b + 1]


def test_white_noise_level_within_chi_square_scatter():
    rng = np.random.default_rng(3)
    fs, sigma, T, m = 10.0, 2.0, 600.0, 6
    x = sigma * rng.standard_normal(int(fs * T) * m)
    level = 2 * sigma**2 / fs  # one-sided white PSD
    for window in ("none", "hann"):
        s = segment_spectra(x, fs=fs, segment_duration=T, window=window)
        e = log_bins(s.f_f[0], s.f_f[-1] * 0.999, 5)
        mean, cnt = bin_average(s.f_f, s.psd_xf, e)
        n = cnt * s.n_segments
        ok = n >= 30
        # Each raw periodogram value is level * chi2_2 / 2 (relative std 1);
        # the mean of n of them has relative std 1/sqrt(n) (with "hann",
        # neighbouring frequencies are correlated, so the scatter is larger
        # by about sqrt(35/18); the bound allows for it).  |z| < 4.5 on ~15
        # bins fails with probability < 1e-4.
        infl = 1.0 if window == "none" else math.sqrt(35 / 18)
        z = (mean[ok] / level - 1) * np.sqrt(n[ok]) / infl
        assert np.all(np.abs(z) < 4.5), (window, z)
        # Global level from all 18000 values: relative std 1/sqrt(18000) = 0.75 %.
        assert np.mean(s.psd_xf) / level == pytest.approx(1.0, abs=4 * infl / math.sqrt(s.psd_xf.size * m))


# --------------------------------------------------------------------------
# transfer functions
# --------------------------------------------------------------------------
def test_identical_series_give_unit_transfer():
    rng = np.random.default_rng(4)
    x = rng.standard_normal(12000)
    tf = transfer_functions(x, x, fs=10.0, U=8.0, k_edges=log_bins(2e-3, 3.0, 5))
    ok = tf.n_k > 0
    np.testing.assert_allclose(tf.transfer_ratio_k[ok], 1.0, rtol=1e-12)
    np.testing.assert_allclose(tf.transfer_cross_k[ok], 1.0, rtol=1e-12)
    np.testing.assert_allclose(tf.coherence_k[ok], 1.0, rtol=1e-12)
    assert np.all(tf.transfer_ratio_sigma_k[ok] < 1e-6) and np.all(tf.transfer_cross_sigma_k[ok] < 1e-6)
    assert np.all(np.isnan(tf.transfer_ratio_k[~ok]))
    np.testing.assert_allclose(tf.k_k, np.sqrt(tf.k_edges[1:] * tf.k_edges[:-1]))


@pytest.mark.parametrize("delay", [0, 1])
def test_known_filter_gives_T2_equal_ReH2_and_T1_with_noise_floor(delay):
    # Sonic x: white noise.  Lidar y = (h * x) delayed by `delay` samples plus
    # independent noise, h the zero-phase kernel (1/4, 1/2, 1/4):
    # H(f) = cos^2(pi f / fs) exp(-i 2 pi f dt), dt = delay / fs, so
    # T2 = Re(chi)^2 / F_s^2 = (bin mean of H cos(k U dt))^2 (Eq. 11 keeps only
    # the in-phase part: a timing error shows up as cos^2(k U dt)) while
    # T1 = (bin mean of |H|^2) + S_noise / S_x does not see the delay.
    rng = np.random.default_rng(5)
    fs, U, T, m = 10.0, 8.0, 600.0, 6
    n = int(fs * T) * m
    x = rng.standard_normal(n)
    y = 0.5 * x + 0.25 * (np.roll(x, 1) + np.roll(x, -1))
    y = np.roll(y, delay)
    noise_var = 0.3**2
    y += math.sqrt(noise_var) * rng.standard_normal(n)
    e = log_bins(2e-3, 3.9, 5)
    tf = transfer_functions(y, x, fs=fs, U=U, k_edges=e, segment_duration=T)
    assert tf.n_segments == m and tf.n_rejected == 0
    f = np.arange(1, int(fs * T) // 2 + 1) / T
    H = np.cos(math.pi * f / fs) ** 2
    k = 2 * math.pi * f / U
    mReH, _ = bin_average(k, H * np.cos(k * U * delay / fs), e)
    mH2, _ = bin_average(k, H**2, e)
    ok = tf.n_k >= 30  # the delta-method sigma needs many raw values
    assert ok.sum() >= 10
    z2 = (tf.transfer_cross_k - mReH**2)[ok] / tf.transfer_cross_sigma_k[ok]
    z1 = (tf.transfer_ratio_k - (mH2 + noise_var))[ok] / tf.transfer_ratio_sigma_k[ok]
    # Gaussian to first order: |z| < 4.5 for ~15 bins fails with p < 1e-4, and
    # mean(z^2) ~ chi2_nu / nu lies in [0.2, 2.6] with p > 0.998 for nu >= 10
    # (the sigmas themselves are calibrated against seed scatter below).
    for z in (z1, z2):
        assert np.all(np.abs(z) < 4.5), z
        assert 0.2 < np.mean(z**2) < 2.6, np.mean(z**2)
    # Noise lifts method 1 where the filter is strong, not method 2 (A2012 Fig. 6).
    hi = ok & (tf.k_k > 2.5)
    assert np.all(tf.transfer_ratio_k[hi] > noise_var) and np.all(tf.transfer_cross_k[hi] < 0.5 * noise_var)
    # Im(chi) is H sin(k U dt) F_s: zero-phase leaves none beyond scatter (std of the
    # Im part of a mean of n raw values: sqrt((Fr Fs - Re^2) / (2 n))); a delay does.
    sd_im = np.sqrt((tf.F_r_k * tf.F_s_k - tf.chi_k.real**2) / (2 * tf.n_k))
    mImH, _ = bin_average(k, -H * np.sin(k * U * delay / fs), e)
    assert np.all(np.abs(tf.chi_k.imag[ok] / tf.F_s_k[ok] - mImH[ok]) < 4.5 * sd_im[ok] / tf.F_s_k[ok])
    if delay:
        # where k U dt = pi / 2 (k = 1.96 rad/m) the in-phase part vanishes: T2 << |chi|^2 / F_s^2
        mid = ok & (tf.k_k > 1.5) & (tf.k_k < 2.5)
        assert mid.any()
        assert np.all(tf.transfer_cross_k[mid] < 0.1 * np.abs(tf.chi_k[mid]) ** 2 / tf.F_s_k[mid] ** 2)


def _sigma_calibration(n_seeds, delay, noise_sd, fs=10.0, U=8.0, n_per=512, m=8):
    """T1, T2 and their reported sigmas over seeds: y = (h * x) delayed + noise, short series."""
    e = np.array([0.12, 0.3, 0.7, 1.6, 3.5])
    T1, T2, s1, s2 = [], [], [], []
    for seed in range(n_seeds):
        rng = np.random.default_rng([11, seed])
        x = rng.standard_normal(n_per * m)
        y = 0.5 * x + 0.25 * (np.roll(x, 1) + np.roll(x, -1))
        y = np.roll(y, delay) + noise_sd * rng.standard_normal(x.size)
        tf = transfer_functions(y, x, fs=fs, U=U, k_edges=e, segment_duration=n_per / fs)
        T1.append(tf.transfer_ratio_k)
        T2.append(tf.transfer_cross_k)
        s1.append(tf.transfer_ratio_sigma_k)
        s2.append(tf.transfer_cross_sigma_k)
    return tf.n_k, np.array(T1), np.array(T2), np.array(s1), np.array(s2)


@pytest.mark.parametrize("delay", [0, 1])
def test_reported_sigmas_match_the_scatter_over_seeds(delay):
    """sigma_T1 and sigma_T2 (delta method) against the std of T1, T2 over 400 seeds, to 15 %.

    400 seeds: the sample std has relative standard error 1 / sqrt(2 * 400) = 3.5 %
    (a little more for the non-Gaussian ratios), so 15 % is > 4 standard errors;
    the first-order formulas are accurate to O(1 / N) with N = 96-1000 raw values
    per bin.  A sigma 1.5x or 2x too large (or small) fails.
    """
    n_k, T1, T2, s1, s2 = _sigma_calibration(400, delay, 0.5)
    assert np.all(n_k >= 90)
    for est, sig, name in ((T1, s1, "T1"), (T2, s2, "T2")):
        ratio = est.std(axis=0, ddof=1) / np.sqrt(np.mean(sig**2, axis=0))
        ok = np.isfinite(ratio)
        assert ok.sum() == 4
        assert np.all(np.abs(ratio[ok] - 1) < 0.15), (name, ratio)


def test_wavenumber_conversion_preserves_variance():
    rng = np.random.default_rng(6)
    fs, U, T = 20.0, 5.0, 100.0
    n = int(fs * T) * 3
    u = 5.0 + rng.standard_normal(n)
    w = -0.4 * (u - 5.0) + 0.5 * rng.standard_normal(n)
    v = 0.7 * rng.standard_normal(n)
    s = segment_spectra(u, w, fs=fs, segment_duration=T)
    dk = 2 * math.pi / (U * T)
    e = np.array([0.5 * dk, 2 * math.pi * fs / 2 / U * 1.0001])  # one bin holding every frequency
    k, F11, F22, F33, F13, nk = component_spectra(u, v, w, fs=fs, U=U, k_edges=e, segment_duration=T)
    nf = s.f_f.size
    assert nk[0] == 3 * nf
    # integral of F dk = integral of S df (one-sided both): bin mean x count x dk.
    assert F11[0] * nf * dk == pytest.approx(np.sum(s.psd_xf) * s.df, rel=1e-12)
    assert F33[0] * nf * dk == pytest.approx(np.sum(s.psd_yf) * s.df, rel=1e-12)
    assert F13[0] * nf * dk == pytest.approx(np.sum(s.csd_f).real * s.df, rel=1e-12)
    segs = v.reshape(3, -1)
    assert F22[0] * nf * dk == pytest.approx(np.mean(np.var(segs, axis=1)), rel=1e-12)


# --------------------------------------------------------------------------
# gaps
# --------------------------------------------------------------------------
def test_gaps_interpolated_or_rejected_and_counted():
    rng = np.random.default_rng(7)
    fs, T = 10.0, 100.0
    n_per = int(fs * T)
    x = rng.standard_normal(3 * n_per)
    y = rng.standard_normal(3 * n_per)
    xg, yg = x.copy(), y.copy()
    xg[100:120] = np.nan  # 2 % of segment 0: filled
    yg[n_per + 10 : n_per + 210] = np.nan  # 20 % of segment 1 (in y only): rejected
    s = segment_spectra(xg, yg, fs=fs, segment_duration=T, max_gap_fraction=0.05)
    assert (s.n_segments, s.n_rejected, s.n_interpolated) == (2, 1, 1)
    # Same as analysing the linearly interpolated segment 0 and segment 2.
    j = np.arange(n_per)
    x0 = xg[:n_per].copy()
    bad = np.isnan(x0)
    x0[bad] = np.interp(j[bad], j[~bad], x0[~bad])
    ref = segment_spectra(np.concatenate([x0, x[2 * n_per :]]), np.concatenate([y[:n_per], y[2 * n_per :]]),
                          fs=fs, segment_duration=T)
    np.testing.assert_allclose(s.psd_xf, ref.psd_xf, rtol=1e-12)
    np.testing.assert_allclose(s.csd_f, ref.csd_f, rtol=1e-12, atol=1e-15)
    # Strict limit: any gap rejects the segment.
    s0 = segment_spectra(xg, yg, fs=fs, segment_duration=T, max_gap_fraction=0.0)
    assert (s0.n_segments, s0.n_rejected, s0.n_interpolated) == (1, 2, 0)
    tf = transfer_functions(xg, yg, fs=fs, U=5.0, k_edges=log_bins(0.01, 3.0, 5), segment_duration=T)
    assert (tf.n_segments, tf.n_rejected, tf.n_interpolated) == (2, 1, 1)
    with pytest.raises(ValueError, match="no usable segment"):
        segment_spectra(np.where(np.arange(x.size) % 5 == 0, np.nan, x), fs=fs, segment_duration=T)


# --------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------
def test_bad_input():
    x = np.zeros(1000)
    with pytest.raises(ValueError, match="hi"):
        log_bins(1.0, 1.0, 5)
    with pytest.raises(ValueError, match="lo"):
        log_bins(0.0, 1.0, 5)
    with pytest.raises(ValueError, match="per_decade"):
        log_bins(0.1, 1.0, 0)
    with pytest.raises(ValueError, match="edges"):
        bin_average([1.0, 2.0], [1.0, 2.0], [1.0, 3.0, 2.0])
    with pytest.raises(ValueError, match="values_f"):
        bin_average([1.0, 2.0], [1.0, 2.0, 3.0], [1.0, 3.0])
    with pytest.raises(ValueError, match="fs"):
        segment_spectra(x, fs=0.0)
    with pytest.raises(ValueError, match="fewer than one segment"):
        segment_spectra(x, fs=1.0, segment_duration=2000.0)
    with pytest.raises(ValueError, match="x_t"):
        segment_spectra(x.reshape(10, 100), fs=1.0, segment_duration=10.0)
    with pytest.raises(ValueError, match="y_t"):
        segment_spectra(x, x[:-1], fs=1.0, segment_duration=10.0)
    with pytest.raises(ValueError, match="detrend"):
        segment_spectra(x, fs=1.0, segment_duration=10.0, detrend="quadratic")
    with pytest.raises(ValueError, match="window"):
        segment_spectra(x, fs=1.0, segment_duration=10.0, window="kaiser")
    with pytest.raises(ValueError, match="max_gap_fraction"):
        segment_spectra(x, fs=1.0, segment_duration=10.0, max_gap_fraction=1.0)
    with pytest.raises(ValueError, match="segment_duration"):
        segment_spectra(x, fs=1.0, segment_duration=1.0)
    with pytest.raises(ValueError, match="U"):
        transfer_functions(x, x, fs=1.0, U=-1.0, k_edges=[0.1, 1.0], segment_duration=10.0)
    with pytest.raises(ValueError, match="k_edges"):
        transfer_functions(x, x, fs=1.0, U=1.0, k_edges=[0.0, 1.0], segment_duration=10.0)
    with pytest.raises(ValueError, match="k_edges"):
        component_spectra(x, x, x, fs=1.0, U=1.0, k_edges=[1.0], segment_duration=10.0)
    with pytest.raises(ValueError, match="equal lengths"):
        component_spectra(x, x, x[:-1], fs=1.0, U=1.0, k_edges=[0.1, 1.0], segment_duration=10.0)


def test_the_two_methods_carry_the_results_files_names():
    """One name per quantity: method 1 is transfer_ratio, method 2 transfer_cross, in the API as in a results file."""
    import dataclasses

    from cwlidar_sim.analysis import EstimatorTransfer, TransferEstimate

    names = {f.name for f in dataclasses.fields(TransferEstimate)}
    assert {"transfer_ratio_k", "transfer_cross_k", "transfer_ratio_sigma_k", "transfer_cross_sigma_k"} <= names
    assert {"transfer_cross_ek", "transfer_cross_sigma_ek"} <= {f.name for f in dataclasses.fields(EstimatorTransfer)}
    assert not any(n.startswith(("T1", "T2", "sigma_T")) for n in names)
