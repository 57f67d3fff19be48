"""Tier 2's exact expected spectrum (Chebyshev lag sum + one real FFT) against its defining sums."""

import math

import numpy as np
import pytest

from cwlidar_sim import _config
from cwlidar_sim.signal import expected_spectrum_exact
from cwlidar_sim.signal import PROTOTYPE_2003, expected_spectrum, fejer, window_samples

import reference  # noqa: E402

# shot-noise-limited: RIN and reflection off (they are tested in tests/signal/test_continuum.py)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)
N = P.n_fft
NF = P.n_bins


def cells(seed, ne=3, ns=7):
    """Cell speeds [m/s] spanning both signs, the Nyquist band, aliasing (> Nyquist) and > N bins."""
    rng = np.random.default_rng(seed)
    nyq = P.nyquist_speed
    v = rng.uniform(-1.3 * nyq, 1.3 * nyq, size=(ne, ns))
    v[0, :4] = [0.0, 5 * P.bin_speed, -7.37, 2.2 * nyq]  # zero, a bin centre, negative, beyond one period
    v[1, 0] = 17.0 * P.bin_speed + 0.5 * P.bin_speed  # half-way between bins
    w = rng.uniform(0.2, 1.0, ns)
    return v, w / w.sum()


def rho_of(tau):
    return 1.0 if math.isinf(tau) else math.exp(-1.0 / (P.sample_rate * tau))


@pytest.mark.parametrize("window", ["rect", "hann"])
@pytest.mark.parametrize("tau", [math.inf, 40 * P.block_duration, 0.3 * P.block_duration])
def test_exact_spectrum_equals_the_defining_sum(window, tau):
    inst = P.replace(window=window)
    v, w = cells(1)
    cnr_db = -7.0
    cnr = 10 ** (cnr_db / 10)
    sig, noise = expected_spectrum_exact(inst, v, w, cnr_db, correlation_time=tau)
    x = v / inst.bin_speed
    ref = reference.sensors_expected_spectrum(x, 0.5 * cnr * w, list(window_samples(N, window)), rho_of(tau), NF)
    assert sig.shape == (3, NF) and np.all(noise == 1.0)
    # rounding only: the recurrence errs by <~ d^2 eps (3e-11 of an amplitude at d = N), the FFT by ~eps log N
    assert np.max(np.abs(sig - ref)) <= 1e-9 * np.max(ref)


def test_exact_spectrum_is_the_fejer_kernel_for_rect_frozen_speckle():
    v, w = cells(2, ne=4, ns=11)
    sig, _ = expected_spectrum_exact(P, v, w, 0.0)
    x = v / P.bin_speed
    k = np.arange(NF)[None, :, None]
    ref = np.sum(0.5 * w * (fejer(k - x[:, None, :], N) + fejer(k + x[:, None, :], N)), axis=2)
    assert np.max(np.abs(sig - ref)) <= 1e-9 * np.max(ref)


@pytest.mark.parametrize("window", ["rect", "hann"])
def test_exact_spectrum_against_the_tabulated_one(window):
    """signal.expected_spectrum interpolates G linearly in a table of step h = 1/256 bin.

    Its error per line is <= h^2/8 max|G''| with |G''(u)| <= sum_{|d|<N} |a_d| (2 pi d / N)^2, and each
    cell contributes two lines of weight CNR w_s / 2.
    """
    inst = P.replace(window=window)
    v, w = cells(3)
    cnr_db = 3.0
    cnr = 10 ** (cnr_db / 10)
    tau = 50 * P.block_duration
    ours, _ = expected_spectrum_exact(inst, v, w, cnr_db, correlation_time=tau)
    tab, _ = expected_spectrum(inst, v, w, cnr_db, correlation_time=tau)
    wn = window_samples(N, window)
    r = np.array([np.dot(wn[: N - d], wn[d:]) for d in range(N)])
    a = r / r[0] * rho_of(tau) ** np.arange(N)
    d = np.arange(N)
    g2 = 2 * np.sum(np.abs(a[1:]) * (2 * np.pi * d[1:] / N) ** 2)
    bound = 2 * 0.5 * cnr * np.sum(w) * (1 / 256) ** 2 / 8 * g2
    assert np.max(np.abs(ours - tab)) <= bound
    assert bound < 1e-4 * np.max(ours)  # the table is good to ~1e-5, just not exact


def test_exact_spectrum_parseval_and_homodyne_sign():
    """sum over the N two-sided bins of G(k - x) is N a_0 = N for any x: the spectrum holds N CNR sum(w)."""
    v, w = cells(4, ne=2, ns=9)
    for window in ("rect", "hann"):
        inst = P.replace(window=window)
        sig, _ = expected_spectrum_exact(inst, v, 0.6 * w, -3.0, correlation_time=5 * P.block_duration)
        two_sided = 2 * sig[:, 1:-1].sum(axis=1) + sig[:, 0] + sig[:, -1]
        np.testing.assert_allclose(two_sided, N * 10 ** (-0.3) * 0.6, rtol=1e-12)
        neg, _ = expected_spectrum_exact(inst, -v, 0.6 * w, -3.0, correlation_time=5 * P.block_duration)
        np.testing.assert_allclose(neg, sig, rtol=0, atol=1e-12 * sig.max())


def test_exact_spectrum_is_thread_independent_and_rejects_bad_input():
    v, w = cells(5, ne=40, ns=33)
    old = _config.get_num_threads()
    try:
        _config.set_num_threads(1)
        a, _ = expected_spectrum_exact(P, v, w, -5.0)
        _config.set_num_threads(2)
        b, _ = expected_spectrum_exact(P, v, w, -5.0)
    finally:
        _config.set_num_threads(old)
    assert np.array_equal(a, b)
    # one row alone gives the same bits as inside a batch (per-estimate arithmetic)
    c, _ = expected_spectrum_exact(P, v[7], w, -5.0)
    assert np.array_equal(c[0], a[7])
    with pytest.raises(ValueError, match="weight_s must have shape"):
        expected_spectrum_exact(P, v, w[:-1], -5.0)
    with pytest.raises(ValueError, match="vlos_es must be finite"):
        expected_spectrum_exact(P, np.full((2, 33), np.nan), w, -5.0)
    with pytest.raises(ValueError, match="correlation_time"):
        expected_spectrum_exact(P, v, w, -5.0, correlation_time=0.0)
    with pytest.raises(TypeError, match="instrument must be an Instrument"):
        expected_spectrum_exact("prototype", v, w, -5.0)
