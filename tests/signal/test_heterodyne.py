"""Tier 3: kernels against plain-Python references, Parseval, noise statistics, determinism."""

import math

import numpy as np
import pytest

from cwlidar_sim import _config
from cwlidar_sim._fft import rfft_rows
from cwlidar_sim.signal import PROTOTYPE_2003, simulate_signal_spectra, synthesize_samples, window_samples
from cwlidar_sim.signal import _kernels as K
from cwlidar_sim.signal.heterodyne import _tone_tables

import reference  # noqa: E402

# shot-noise-limited: RIN and reflection off (they are tested in test_continuum)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)
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


# ---------------------------------------------------------------------------
# the fused path (block_normals, tone tables, synth_blocks_kernel, partial power sums)
# ---------------------------------------------------------------------------
def test_block_normals_against_reference_and_normal_pair():
    words = np.empty(40, dtype=np.uint64)
    tails = np.empty(80, dtype=np.int64)
    for n in (64, 63, 80):
        out = np.empty(n)
        K.block_normals(np.uint64(K.stream_start(np.uint64(77), 12)), 0.7, words, tails, out)
        # the kernel's normals interpolate an ndtri table: |dz| < 1e-4, times noise_std = 0.7
        assert np.allclose(out, reference.signal_block_normals(77, 12, n, 0.7), rtol=0, atol=0.7e-4)
        # and they are normal_pair's numbers, bit for bit (tiers 2 and 3 share the generator)
        st = K.stream_start(np.uint64(77), 12)
        pairs = []
        for _ in range((n + 1) // 2):
            # keep the state a uint64 (a Python int below 2**63 would be typed int64)
            st, z0, z1 = K.normal_pair(np.uint64(st))
            pairs += [z0, z1]
        assert np.array_equal(out, 0.7 * np.array(pairs[:n]))


@pytest.mark.parametrize("fn", ["block_normals", "block_normals_tab2"])
def test_block_normals_are_standard_normal(fn):
    n_blocks, n = 2048, 512
    z = np.empty((n_blocks, n))
    words = np.empty(n // 2, dtype=np.uint64)
    tails = np.empty(n, dtype=np.int64)
    for b in range(n_blocks):
        getattr(K, fn)(np.uint64(K.stream_start(np.uint64(3), b)), 1.0, words, tails, z[b])
    z = z.ravel()
    size = z.size
    # moments of N(0, 1): sd of the sample mean 1/sqrt(n), of the mean of z^2 sqrt(2/n), of z^4 sqrt(96/n)
    assert abs(z.mean()) < 4.5 / math.sqrt(size)
    assert abs(np.mean(z**2) - 1) < 4.5 * math.sqrt(2 / size)
    assert abs(np.mean(z**4) - 3) < 4.5 * math.sqrt(96 / size)
    # tails (the Acklam branch beyond |z| = 2.66): binomial counts within 4.5 sd
    from scipy.special import ndtr

    for c in (2.0, 2.66, 3.0, 3.5, 4.0):
        p = 2 * ndtr(-c)
        k = np.count_nonzero(np.abs(z) > c)
        assert abs(k - p * size) < 4.5 * math.sqrt(p * (1 - p) * size), c


def test_block_normals_tab2_against_block_normals_and_reference():
    # the centre bit for bit as block_normals, the tails from the second-level tables
    n_blocks, n = 400, 63
    words = np.empty(32, dtype=np.uint64)
    tails = np.empty(n, dtype=np.int64)
    a, b = np.empty(n), np.empty(n)
    n_tail = 0
    for blk in range(n_blocks):
        st = np.uint64(K.stream_start(np.uint64(8), blk))
        K.block_normals(st, 0.7, words, tails, a)
        K.block_normals_tab2(st, 0.7, words, tails, b)
        centre = np.abs(a) < 0.7 * 2.6
        assert np.array_equal(a[centre], b[centre])
        n_tail += np.count_nonzero(a != b)
        # against exact ndtri: the central table's 1e-4, the tails' tables 1e-5
        ref = reference.signal_block_normals(8, blk, n, 0.7)
        assert np.allclose(b[centre], ref[centre], rtol=0, atol=0.7e-4)
        assert np.allclose(b[~centre], ref[~centre], rtol=0, atol=0.7e-5)
    # about 0.8 % of the samples are in the tails (binomial count within 4.5 sd)
    p = 2 * 64 / 2**14
    assert abs(n_tail - p * n_blocks * n) < 4.5 * math.sqrt(p * n_blocks * n)


def test_tail_normal_against_ndtri():
    from scipy.special import ndtri

    # both tails, the second-level tables and Acklam's outer cells (u < 2^16, u >= 2^32 - 2^16)
    lo = np.concatenate([np.arange(0, 2**16, 37), np.arange(2**16, 2**24, 7919), [2**24 - 1]])
    u = np.concatenate([lo, 2**32 - 1 - lo]).astype(np.uint64)
    got = np.array([K.tail_normal(x) for x in u])
    want = ndtri((u.astype(np.float64) + 0.5) / 2**32)
    assert np.all(np.abs(got - want) < 1e-5)
    far = (u < 2**16) | (u >= 2**32 - 2**16)
    assert np.allclose(got[far], want[far], rtol=2e-9, atol=0)


@pytest.mark.parametrize("ns", [1, 3, 4, 5, 9])
def test_tone_tables_against_reference(ns):
    # N = 80: table factors exp(i theta 32 j) exp(i theta q); M = 150: phasor factors over 64 blocks and a remainder
    rng = np.random.default_rng(ns)
    phase = rng.uniform(0, 2 * np.pi, ns)
    dth = rng.uniform(-3.1, 3.1, ns)
    dth[0] = 1e-4
    n, m = 80, 150
    tab, ph_re, ph_im = _tone_tables(phase[None], dth[None], n, m)
    ref_tab, ref_re, ref_im = reference.signal_tone_tables(phase, dth, n, m, K.TONE_CELLS)
    # tables rounded to float32 (|cos| <= 1: 6e-8); the phasors from products of three factors (a few ulp)
    # and angles theta N i up to 4e4 rad (rounding 7e-12 in either)
    assert tab.shape[1:] == ref_tab.shape
    assert np.allclose(tab[0], ref_tab, rtol=0, atol=1.2e-7)
    assert np.allclose(ph_re[0], ref_re, rtol=0, atol=5e-11) and np.allclose(ph_im[0], ref_im, rtol=0, atol=5e-11)
    # padding cells of the last group: no tone (cos 1, sin 0, phasor 1)
    ncs = tab.shape[1] * K.TONE_CELLS
    assert np.all(ph_re[0][:, ns:ncs] == 1.0) and np.all(ph_im[0][:, ns:ncs] == 0.0)


@pytest.mark.parametrize("n, n_sub, ns", [(80, 2, 3), (80, 5, 3), (64, 1, 3), (64, 1, 5), (64, 4, 9)])
def test_synth_blocks_against_reference(n, n_sub, ns):
    # one group with a padding cell (3), two groups (5), three (9); sub-steps of 40, 16, 64, 16 samples
    rng = np.random.default_rng(11)
    m, ne = 3, 3
    nb = m * ne
    are = rng.normal(size=(ns, nb * n_sub))
    aim = rng.normal(size=(ns, nb * n_sub))
    phase = rng.uniform(0, 2 * np.pi, (ne, ns))
    dth = rng.uniform(-3.1, 3.1, (ne, ns))
    win = np.sin(np.pi * np.arange(n) / n) ** 2
    tab, ph_re, ph_im = _tone_tables(phase, dth, n, m)
    out = np.empty((5, n), dtype=np.float32)
    acc, words, tails = np.empty(n), np.empty(n // 2, dtype=np.uint64), np.empty(n, dtype=np.int64)
    # blocks 2..6 of the chunk span three estimates
    K.synth_blocks_kernel(np.uint64(5), 7, 2, 7, m, n_sub, are, aim, tab, ph_re, ph_im, 0.7, win, True,
                          np.empty((0, 0)), np.uint64(0), 0, np.zeros(0), np.zeros((2, 0)), np.zeros(2), acc, words,
                          tails, out)
    ref = reference.signal_synth_blocks(5, 7, 2, 7, m, n_sub, are, aim, phase, dth, 0.7, win)
    # table normals (|dz| < 1e-4, times 0.7); the tones in float32 (|sum| < 15: 1e-6); float32 output (1e-6)
    assert np.allclose(out, ref, rtol=0, atol=1e-4)
    # the tones alone (noise_std 0) against the reference, to the float32 tones' rounding
    K.synth_blocks_kernel(np.uint64(5), 7, 2, 7, m, n_sub, are, aim, tab, ph_re, ph_im, 0.0, win, True,
                          np.empty((0, 0)), np.uint64(0), 0, np.zeros(0), np.zeros((2, 0)), np.zeros(2), acc, words,
                          tails, out)
    ref = reference.signal_synth_blocks(5, 7, 2, 7, m, n_sub, are, aim, phase, dth, 0.0, win)
    scale = np.abs(are).max() + np.abs(aim).max()
    assert np.allclose(out, ref, rtol=0, atol=4 * ns * scale * 2.0**-24)


def test_power_sum_and_combine_against_reference():
    rng = np.random.default_rng(2)
    X = rfft_rows(rng.normal(size=(7, 64)).astype(np.float32))
    p = np.empty(33)
    K.power_sum_kernel(X, 5, p)
    assert np.allclose(p, reference.signal_power_sum(X, 5), rtol=1e-12)
    part = rng.uniform(size=(2, 3, 33))
    out = np.empty((2, 33))
    K.combine_partials_kernel(part, 0.25, out)
    assert np.allclose(out, 0.25 * part.sum(axis=1), rtol=1e-13)


def test_synthesized_samples_are_the_transformed_ones():
    inst = SMALL.replace(window="hann")
    v = np.array([[3.0, 8.0], [4.0, 9.5], [5.0, 2.0]])
    kw = dict(correlation_time=3e-6)
    x = synthesize_samples(inst, v, [0.4, 0.6], 2.0, 9, **kw)
    spec = simulate_signal_spectra(inst, v, [0.4, 0.6], 2.0, 9, **kw)
    p = np.abs(rfft_rows(x).astype(np.complex128)) ** 2 / np.sum(window_samples(64, "hann") ** 2)
    mean = p.reshape(3, 50, 33).mean(axis=1)
    # the same float32 samples through two FFTW float32 plans: relative rounding ~1e-6 per bin
    assert np.allclose(spec, mean, rtol=1e-4, atol=0)


def test_fused_path_deterministic_over_threads_tasks_and_chunks():
    # N = 2048: tasks of 16 blocks, M = 40 -> three tasks per estimate (16, 16, 8);
    # tau_c = 4 us -> sub-steps of L = 4 samples (n_sub = 512) with a Hann window
    inst = P.replace(n_fft=2048, blocks_per_estimate=40, window="hann")
    v = np.linspace(2, 14, 9).reshape(3, 3)
    w = [0.2, 0.3, 0.5]
    kw = dict(correlation_time=4e-6)
    old = _config.get_num_threads()
    res = []
    try:
        for nt, chunk in ((1, 1 << 22), (2, 1), (3, 5 * 40 * 2048)):
            _config.set_num_threads(nt)
            res.append(simulate_signal_spectra(inst, v, w, -3.0, 21, chunk_samples=chunk, **kw))
            res.append(synthesize_samples(inst, v, w, -3.0, 21, **kw))
    finally:
        _config.set_num_threads(old)
    for a, b in zip(res[:2], res[2:4]):
        assert np.array_equal(a, b)
    for a, b in zip(res[:2], res[4:]):
        assert np.array_equal(a, b)
