"""Tier 3: kernels against plain-Python references, Parseval, noise statistics, determinism."""

import math

import numpy as np
import pytest

from cwlidar_sim import _config
from cwlidar_sim._fft import rfft_rows
from cwlidar_sim.signal import PROTOTYPE_2003, simulate_signal_spectra, synthesize_samples
from cwlidar_sim.signal import _kernels as K

import reference  # noqa: E402

P = PROTOTYPE_2003
SMALL = P.replace(n_fft=64, blocks_per_estimate=50)


def test_ar1_and_synth_against_reference():
    std = np.array([1.0, 0.5, 0.2])
    re = np.empty((12, 3))
    im = np.empty((12, 3))
    K.ar1_amplitudes_kernel(np.uint64(99), 4, 0.9, std, np.array([0.1, 0.2, 0.3]), np.zeros(3), re, im)
    rr, ri = reference.signal_ar1_amplitudes(99, 4, 12, 0.9, std, [0.1, 0.2, 0.3], [0, 0, 0])
    # kernel normals interpolate an ndtri table: |dz| < 1e-4
    assert np.allclose(re, rr, atol=1e-4) and np.allclose(im, ri, atol=1e-4)
    rng = np.random.default_rng(1)
    nb, n, n_sub = 3, 16, 2
    ph0 = rng.uniform(0, 6.28, (nb, 3))
    dth = rng.uniform(-3, 3, (nb, 3))
    are = rng.normal(size=(nb * n_sub, 3))
    aim = rng.normal(size=(nb * n_sub, 3))
    win = np.sin(np.pi * np.arange(n) / n) ** 2
    out = np.empty((nb, n), dtype=np.float32)
    K.synth_kernel(np.uint64(5), 7, n_sub, are, aim, ph0, dth, 0.7, win, True, out)
    ref = reference.signal_synth(5, 7, nb, n, n_sub, are, aim, ph0, dth, 0.7, win)
    # float32 storage of O(3) values and the float64 Chebyshev recurrence over 8 samples
    assert np.allclose(out, ref, atol=1e-5)


def test_power_average_against_reference_and_parseval():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(6, 64)).astype(np.float32)
    X = rfft_rows(x)
    out = np.empty((2, 33))
    K.power_average_kernel(X, 3, 1 / 64, out)
    assert np.allclose(out, reference.signal_power_average(X, 3, 1 / 64), rtol=1e-6)
    # Parseval for a real block: sum_n x^2 = (|X_0|^2 + 2 sum_{0<k<N/2} |X_k|^2 + |X_N/2|^2) / N
    p = np.abs(X.astype(np.complex128)) ** 2
    lhs = (x.astype(np.float64) ** 2).sum(axis=1)
    rhs = (p[:, 0] + 2 * p[:, 1:-1].sum(axis=1) + p[:, -1]) / 64
    assert np.allclose(lhs, rhs, rtol=1e-5)


def test_signal_power_is_cnr_plus_noise():
    # variance of the real signal = CNR (total signal power) + 1 (noise): the CNR definition
    cnr_db = 3.0
    x = synthesize_samples(SMALL, np.full((40, 2), 5.0), [0.5, 0.5], cnr_db, 3, correlation_time=2e-6)
    # 40 * 50 blocks, speckle renewing every ~tau: sd of the variance estimate below 3 %
    assert x.astype(np.float64).var() == pytest.approx(1 + 10 ** (cnr_db / 10), rel=0.06)


def test_noise_only_spectrum_statistics():
    spec = simulate_signal_spectra(SMALL, np.zeros((400, 1)), [1.0], -200.0, 4)
    # white noise: every bin has mean 1; mean of M = 50 blocks has variance 1/M (2/M at 0 and Nyquist)
    var = np.full(33, 1 / 50)
    var[[0, -1]] = 2 / 50
    z = (spec.mean(axis=0) - 1) / np.sqrt(var / 400)
    assert np.max(np.abs(z)) < 4.5
    # relative sd of a sample variance of 400 near-Gaussian draws: sqrt(2/399) = 0.071; 5 sd
    assert np.allclose(spec.var(axis=0) / var, 1, atol=0.35)


def test_deterministic_over_threads_and_chunks():
    v = np.linspace(3, 9, 12).reshape(4, 3)
    w = [0.2, 0.3, 0.5]
    old = _config.get_num_threads()
    try:
        _config.set_num_threads(1)
        a = simulate_signal_spectra(SMALL, v, w, -5.0, 8, correlation_time=3e-5)
        _config.set_num_threads(2)
        b = simulate_signal_spectra(SMALL, v, w, -5.0, 8, correlation_time=3e-5, chunk_samples=1)
    finally:
        _config.set_num_threads(old)
    assert np.array_equal(a, b)


def test_homodyne_folding_signal():
    a = simulate_signal_spectra(SMALL, np.full((20, 1), 7.0), [1.0], 0.0, 1)
    b = simulate_signal_spectra(SMALL, np.full((20, 1), -7.0), [1.0], 0.0, 1)
    assert np.argmax(a.mean(0)) == np.argmax(b.mean(0)) == round(7.0 / SMALL.bin_speed)


def test_bad_input():
    with pytest.raises(ValueError, match="correlation_time"):
        simulate_signal_spectra(SMALL, [1.0], [1.0], 0.0, 1, correlation_time=-1.0)
    with pytest.raises(ValueError, match="vlos_es"):
        simulate_signal_spectra(SMALL, [[np.nan]], [1.0], 0.0, 1)
